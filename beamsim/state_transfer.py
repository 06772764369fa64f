r"""A state of one Galerkin model of the beam as a state of another (more modes, a stiffer stick).

Two models of the same beam (geometry ``alpha1``, ``alpha2``, ``beta``, boundary conditions)
that differ in the Galerkin basis (``n_modes``), the interface points (``n_quad``) or the stick
stiffness ``k_t`` have states of different layout or meaning: ``[q, v, z, mode]``
(:func:`beamsim.point.prepare_point`).  :func:`transfer_state` carries a state across:

* ``q`` and ``v``: the displacement fields ``w``, ``u1``, ``u2``
  (:meth:`beamsim.two_layer.TwoLayerModel.displacements`) projected onto the target basis in
  the kinetic-energy metric, ``min sum_i alpha_i int (w_t - w_s)^2 + (u_it - u_is)^2 dtheta``
  on a Gauss grid over ``[0, beta]``.  Where the target basis contains the source's (more
  modes: the arch modes of ``N`` are the first ``N`` of ``N + 1``; the same interface points
  do not change it), the fields are carried exactly, up to round-off; otherwise they are the
  best approximation the target basis has;
* ``z`` (each Jenkins element's internal slip, elastic stick only): the element's **traction**
  ``k_t (s_j - z_j)`` is kept, interpolated along the interface (linear in ``theta``,
  constant beyond the outermost points) where the points differ, and the target's ``z``
  follows from its own slip ``s = S q`` and stiffness;
* ``mode`` (0 stuck, +-1 slipping): the nearest source point's.

The target starts where the source was, with the stresses the interface held; the first
event check of a run settles any element whose carried state is inconsistent with its limit.
Only the elastic stick (law ``stick-slip``) has a stick elongation to carry: for the rigid
stick ``z`` is a stuck element's locked-in traction, and the regularised laws have no stick, so
:func:`transfer_state` refuses them.
"""

from __future__ import annotations

import numpy as np

from beamsim.two_layer import TwoLayerModel

__all__ = ["transfer_state"]

#: Gauss points of the projection grid over ``[0, beta]`` (the models' own mass matrices use
#: 400 or more)
GRID_POINTS = 600


def _same_beam(src: TwoLayerModel, dst: TwoLayerModel) -> None:
    a, b = src.geom, dst.geom
    for key in ("alpha1", "alpha2", "alpha_modes", "beta", "bc"):
        if getattr(a, key) != getattr(b, key):
            raise ValueError(f"transfer_state: the models are of different beams ({key} "
                             f"{getattr(a, key)!r} and {getattr(b, key)!r})")


def _fields_matrix(model: TwoLayerModel, theta: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Rows: the three fields at every grid point, each times ``sqrt(density x weight)``;
    columns: the model's generalised coordinates."""
    g = model.geom
    f = model.displacements(np.eye(model.n), theta)  # (3, nt, n)
    dens = np.array([g.alpha1 + g.alpha2, g.alpha1, g.alpha2])
    return (f * np.sqrt(dens[:, None, None] * weight[None, :, None])).reshape(-1, model.n)


def transfer_state(state, src: TwoLayerModel, dst: TwoLayerModel, law: str = "stick-slip") -> np.ndarray:
    """``state`` (``[q, v, z, mode]`` of model ``src``, e.g. ``SimResult.final_state``) as a
    state of model ``dst`` of the same beam (module docstring: fields projected, tractions
    kept, modes of the nearest point), for the friction law ``law`` of both (``stick-slip``
    only; ``ValueError`` otherwise, or for models of different beams).  Returns a new array of
    ``dst``'s layout; the identity (to round-off) when the models are the same."""
    from beamsim.modes import gauss_legendre

    if law != "stick-slip":
        raise ValueError(f"transfer_state: law {law!r} has no stick elongation to carry (stick-slip only)")
    _same_beam(src, dst)
    x = np.asarray(state, dtype=float)
    n, nq = src.n, src.n_quad
    if x.shape != (2 * n + 2 * nq,):
        raise ValueError(f"transfer_state: a state of the source model has {2 * n + 2 * nq} entries, "
                         f"got shape {x.shape}")
    q, v, z, mode = x[:n], x[n:2 * n], x[2 * n:2 * n + nq], x[2 * n + nq:]
    theta, weight = gauss_legendre(0.0, src.geom.beta, GRID_POINTS, panels=20)
    a_src, a_dst = _fields_matrix(src, theta, weight), _fields_matrix(dst, theta, weight)
    qv = np.linalg.lstsq(a_dst, a_src @ np.column_stack([q, v]), rcond=None)[0]
    q_dst, v_dst = qv[:, 0], qv[:, 1]

    traction = src.geom.k_t * (src.S @ q - z)
    if np.array_equal(src.theta_q, dst.theta_q):
        tr_dst, mode_dst = traction, mode.copy()
    else:
        tr_dst = np.interp(dst.theta_q, src.theta_q, traction)
        nearest = np.abs(dst.theta_q[:, None] - src.theta_q[None, :]).argmin(axis=1)
        mode_dst = mode[nearest]
    z_dst = dst.S @ q_dst - tr_dst / dst.geom.k_t
    return np.concatenate([q_dst, v_dst, z_dst, mode_dst])
