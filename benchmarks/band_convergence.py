"""Do the regularised laws' orbits converge as their velocity band narrows?

The full-slip and Stribeck laws replace the sign of the slip velocity by ``tanh(v / eps_v)``
(docs/model.md section 6), with ``eps_v = eps_rel v_ref`` (default ``eps_rel = 0.05``).  The
band is a numerical knob like the stick-slip law's ``k_t``: the convergence evidence of a
Stribeck or full-slip map refines it (``band``: ``eps_v / 2``) and reports whether the labels
hold.  This measures what a label does not show: how far the attractor itself moves.

For each law, at the paper's Fig 13 loads (``f0`` 0.47, 1, 5 at the middle anchor 0.75, i.e.
``f0_rel`` 0.627, 1.333, 6.667; ``Omega = 1.5``; three modes; the paper runs' model,
``config/paper.yaml``: ``mu = 0.3``, the dashpot rule ``interface_damping = 0.5``; Stribeck
``F_s = mu p``, ``F_c = F_s / 2``, ``v_s = 4e-4``) it runs the point from rest at ``eps_rel``
0.05 for 456 transient periods (what the pipeline's adaptive transient used there), then
continues the end state at 0.025 and at 0.0125 for 150 periods each (the same attractor
followed as the band narrows), each with 4 recorded periods, the last one sampled 64 times.
It prints, per load and halving, the largest difference of the tip's w, u1 and u2 over that
period relative to their peak-to-peak amplitude, the Poincare state's relative change (q and
v apart), the spread of the recorded Poincare states (is it settled) and the share of
interface points inside the band (``stick_fraction``).

    .venv/bin/python benchmarks/band_convergence.py              # both laws, about 7 minutes
    .venv/bin/python benchmarks/band_convergence.py --law stribeck

Results: docs/pipeline.md, "The velocity band of the regularised laws".
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from beamsim.simulate import restart_params, simulate_batch

#: the paper runs' model (config/paper.yaml) at Fig 13's frequency
BASE = {"n_modes": 3, "Omega": 1.5, "mu_s": 0.3, "mu_k": 0.3, "p": 1e-4, "interface_damping": 0.5}
LAWS = {"stribeck": {"law": "stribeck", "F_s": 3e-5, "F_c": 1.5e-5, "v_s": 4e-4, "k_v": 0.0},
        "full-slip": {"law": "full-slip"}}
#: Fig 13's loads f0 = 0.47, 1, 5 over the middle anchor 0.75
LOADS = (0.6267, 1.3333, 6.6667)
#: (eps_rel, transient periods): from rest, then each continued from the previous band's end
BANDS = ((0.05, 456), (0.025, 150), (0.0125, 150))
SAMPLES = 64


def follow(law: str, threads: int) -> dict:
    """Per load, per band: the tip over the last recorded period, the Poincare state, the
    4-period spread of the Poincare states (relative) and the stick fraction."""
    pts = [BASE | LAWS[law] | {"f0_rel": f} for f in LOADS]
    out = {f: [] for f in LOADS}
    for eps, n_transient in BANDS:
        t0 = time.perf_counter()
        pts = [p | {"eps_rel": eps} for p in pts]
        res = simulate_batch(pts, n_transient=n_transient, n_record=4, method="rk4", step_factor=1.0,
                             n_threads=threads, dense_per_period=SAMPLES)
        for f, r in zip(LOADS, res):
            ps = np.asarray(r.poincare_state)
            spread = float(np.abs(ps - ps[-1]).max() / np.abs(ps[-1]).max())
            tip = np.asarray(r.dense)[-(SAMPLES + 1):, :3]  # w, u1, u2 at the tip
            out[f].append((tip, ps[-1], spread, float(r.stick_fraction)))
        pts = [restart_params(r) for r in res]
        print(f"  {law}, eps_rel {eps}: {time.perf_counter() - t0:.0f} s", flush=True)
    return out


def report(law: str, out: dict) -> None:
    print(f"{law}: change per halving of the band (0.05 -> 0.025, 0.025 -> 0.0125)")
    for f, rows in out.items():
        tips = [t for t, *_ in rows]
        amp = np.ptp(tips[-1], axis=0)
        tip = [np.abs(tips[i] - tips[i + 1]).max(axis=0) / amp for i in range(2)]
        n = len(rows[0][1]) // 2
        rel = [[np.linalg.norm(a[part] - b[part]) / np.linalg.norm(rows[-1][1][part])
                for a, b in ((rows[i][1], rows[i + 1][1]) for i in range(2))]
               for part in (slice(0, n), slice(n, None))]
        print(f"  f0_rel {f}: tip amplitude w {amp[0]:.4g}, u1 {amp[1]:.4g}, u2 {amp[2]:.4g}; "
              f"max |change| / amplitude: w {tip[0][0]:.3f} {tip[1][0]:.3f}, u1 {tip[0][1]:.3f} "
              f"{tip[1][1]:.3f}, u2 {tip[0][2]:.3f} {tip[1][2]:.3f}; Poincare |dq|/|q| {rel[0][0]:.2f} "
              f"{rel[0][1]:.2f}, |dv|/|v| {rel[1][0]:.2f} {rel[1][1]:.2f}; spread "
              f"{', '.join(f'{s:.0e}' for _, _, s, _ in rows)}; stick fraction "
              f"{', '.join(f'{s:.3f}' for *_, s in rows)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", choices=sorted(LAWS), action="append",
                    help="a law (repeatable; default both)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    t0 = time.perf_counter()
    for law in args.law or ["stribeck", "full-slip"]:
        report(law, follow(law, args.threads))
    print(f"(benchmark {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
