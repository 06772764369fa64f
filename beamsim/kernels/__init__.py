r"""Compiled (numba) kernels of the simulator: one module per integrator family.

Layout (scipy's ``integrate/_ivp`` shape: shared utilities, one file per solver family, a
thin public entry in :mod:`beamsim.simulate` that dispatches by a table):

* :mod:`beamsim.kernels.bundles` -- the named argument bundles every kernel takes;
* :mod:`beamsim.kernels.common` -- what every integrator shares: the energy, the Poincare
  record and dense output, the return mapping of the Jenkins elements, the start of a point,
  the end-of-step bookkeeping, the Illinois bracket update of an event location;
* :mod:`beamsim.kernels.rk4` -- the RK4 reference (right-hand side, one step with located
  stick/slip switches, the point and batch drivers);
* :mod:`beamsim.kernels.expo` -- exact piecewise-linear propagation between located switches;
* :mod:`beamsim.kernels.newmark` -- implicit average-acceleration Newmark with an implicit
  return mapping;
* :mod:`beamsim.kernels.copies` -- a drive and perturbed / coupled copies (Lyapunov estimates);
* :mod:`beamsim.kernels.expo_copies` -- a drive and free copies on ``expo`` (the Lyapunov
  stage's free copy for the stick-slip law);
* :mod:`beamsim.kernels.thread_pool` -- a batch's items on a pool of threads.

Arguments travel as named bundles (:mod:`beamsim.kernels.bundles`): ``Point`` (the constant
inputs of one parameter point), ``Schedule`` (step, steps per period, periods, output and
divergence settings), ``Outputs`` (the batch's output arrays, indexed by the point), ``State``
(``q, v, z, mode``), ``Tally`` (energy ledger and slip statistics), and per-integrator scratch.

The step contract (what an integrator kernel must do, and what adding one means)
---------------------------------------------------------------------------------
A point kernel ``_<name>_point(p, pt, sched, x0, out, ...)`` integrates point ``p`` over
``(n_trans + n_rec) * n_per`` fixed steps of length ``h`` (a forcing period is exactly
``n_per`` steps, so every step end ``k h`` is a possible Poincare sample):

1. start with :func:`beamsim.kernels.common.start_point` (consistent interface state at
   ``t = 0``, initial energy, the first record);
2. advance the state ``(q, v, z, mode)`` over a step, booking the work of the load, the
   friction dissipation and the damping dissipation in ``tally.ecum`` (cumulative, so that
   ``E_mech - E_mech0 = W_in - D_friction - D_damping`` holds to the integrator's accuracy) and
   the first slip in ``tally.stats``; a stick/slip switch inside a step is located (its time
   is a continuous function of the state);
3. after every step call :func:`beamsim.kernels.common.post_step` (return mapping or slip
   statistics sampled at the step end; ``expo``, whose steps are a few per period, tallies its
   stick statistics per interval between switches instead, exactly) and
   :func:`beamsim.kernels.common.end_of_step` (divergence check, Poincare
   record at period ends, dense output), stopping the point when the latter returns True;
4. finish with :func:`beamsim.kernels.common.final_flags` (slip indicators, final state).

An item kernel ``run_point(..., p)`` (``nogil``) runs the point kernel on point ``p`` of a
batch (``expo``'s is the point kernel itself: numba optimises and generates the machine code
of a callee's whole call tree again inside each caller, so a wrapper around a large kernel
costs seconds of compilation, docs/performance.md, "Compilation"), and
:func:`beamsim.kernels.thread_pool.run_items` hands the points to a pool of threads; each
point's arithmetic is independent of the others, so results do not depend on the number of
threads.  To add an integrator: write its module here, add its batch runner to the method
table of :mod:`beamsim.simulate` (``METHODS``), give its default steps per period in
:func:`beamsim.point.period_steps`, and test it against the RK4 reference (tests/beamsim).
"""
