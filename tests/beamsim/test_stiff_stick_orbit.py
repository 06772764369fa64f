"""A regular orbit of the default map converges as the stick stiffens, with ``mu_s > mu_k``.

The chaotic exponents of this friction have no stiff-stick limit (docs/lyapunov.md, section
11); the map's regular orbits do (docs/pipeline.md, "The regular orbits under more modes and a
stiffer stick", `benchmarks/orbit_convergence.py --knob k_t`).  At one slipping period-1 cell
of the default grid whose label every neighbour shares, run from rest at the map's physical load
and frequency (``f_cr`` and ``omega_1`` depend on ``k_t``), the tip waveform over a period moves
less and less as ``k_t`` grows from the default 10 towards 1000.
"""

import numpy as np

from beamsim.point import prepare_point
from beamsim.simulate import simulate_batch

#: the default grid's cell (Omega 3.661, f0_rel 2.610): periodic-1, 37 % of the interface
#: stuck, every grid neighbour periodic-1 too (results version 26)
CELL = {"Omega": 3.6613882832, "f0_rel": 2.61033899224, "n_modes": 3, "mu_s": 0.45, "mu_k": 0.3,
        "p": 1e-4, "interface_viscosity": 0.0939}
LADDER = (10.0, 30.0, 100.0, 300.0, 1000.0)
SAMPLES = 64


def test_a_regular_orbit_converges_as_the_stick_stiffens():
    pp = prepare_point(**CELL)  # k_t = 10, the map's model: its physical load and frequency
    base = {k: v for k, v in CELL.items() if k not in ("Omega", "f0_rel")} | {"f0": pp.f0, "omega": pp.omega}
    runs = [simulate_batch([base | {"k_t": kt}], n_transient=600, n_record=8, method="expo",
                           dense_per_period=SAMPLES, n_threads=1)[0] for kt in LADDER]
    waves = [np.asarray(r.dense)[-(SAMPLES + 1):, 0] for r in runs]  # tip w over the last period
    amp = np.ptp(waves[-1])
    for r in runs:  # each run on a period-1 orbit that slips
        assert np.ptp(np.asarray(r.poincare_tip)[:, 0]) < 1e-3 * amp
        assert 0.0 < r.stick_fraction < 1.0
    dist = [float(np.abs(w - waves[-1]).max() / amp) for w in waves[:-1]]
    print(f"\nwaveform distance to k_t = 1000 at k_t = {LADDER[:-1]}: {np.round(dist, 5).tolist()}")
    assert all(a > b for a, b in zip(dist, dist[1:])), dist  # closer at every step of the ladder
    assert dist[-1] < dist[0] / 4, dist
