"""The run plan: config and grid file checked and expanded, before any job (one pass).

The Snakefile calls :func:`check_config_files` before Snakemake reads the config files, and
``workflow/rules/common.smk`` calls :func:`build_plan` right after: every check that can refuse
an input runs here, so a bad input stops the workflow while it is parsed -- no job has run and
nothing under ``results/`` exists or changed -- and the tests can run exactly the workflow's
checks in-process (``tests/workflow/test_config_mutations.py``).  Every refusal is a
``WorkflowError`` with one line, ``invalid config: <key> = <value> (...); allowed: ... [<file>]``.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import yaml
from snakemake.exceptions import WorkflowError

from analysis.pipeline.cell_attractors import MultistabilitySettings
from analysis.pipeline.chaos_lifetime import LifetimeSettings
from analysis.pipeline.config import Numerics
from analysis.pipeline.convergence import ConvergenceSettings, grid_refinements, refine
from analysis.pipeline.grid import GridPoint, canonical_json, chunk_points, expand_grid
from analysis.pipeline.stages import free_copy_integrator, integrator
from analysis.pipeline.validation import (
    load_yaml_mapping,
    validate_config,
    validate_grid_points,
    validate_grid_values,
    validate_integrators,
    validate_lyapunov_laws,
    validate_model,
)

__all__ = ["Plan", "RUN_ONLY_KEYS", "build_plan", "check_config_files"]

#: config keys that steer a run but not its results: left out of the tables' config and hash
RUN_ONLY_KEYS = ("grid_file", "paper_file", "allow_long")


@dataclass(frozen=True)
class Plan:
    """What the workflow will compute.

    grids : the grid file's contents (validated).
    numerics : the resolved numerical settings; result_numerics : those that change results.
    table_config : the config stored with every table (contents only, no run-only keys);
    config_hash : 16 hex digits of ``table_config`` and ``grids``.
    points : grid name -> its points in axis order; chunks : grid name -> its chunks.
    simulation_methods : integrators of the reference runs (with ``expo``, RK4 too: the
    fallback of a run that meets ``expo``'s Zeno guard).
    lyapunov_methods : integrators of the Lyapunov stage's free copies, with RK4 always (its
    pair is compiled first in any case: the fallback and the second opinion).
    rigid_stick : whether a grid or a line has rigid-stick points (whose kernels are their own,
    so compile_kernels builds them too).
    convergence : the convergence runs' settings (sample size, seed, refinements).
    grid_refinements : grid name -> the refinements its convergence runs make: those of
        ``convergence`` (none when its sample is 0) that are knobs of the grid's law
        (``k_t`` of stick-slip, ``band`` of full-slip and stribeck).
    multistability : the settings of the runs of a map's cells from other starts.
    lifetimes : the settings of the lifetime runs of a map's chaos below the lock-up limit.
    lines : grid name -> line name -> the line's points in axis order (continuation sweeps).
    """

    grids: dict
    numerics: Numerics
    result_numerics: dict
    table_config: dict
    config_hash: str
    points: dict[str, list[GridPoint]]
    chunks: dict[str, list[list[GridPoint]]]
    simulation_methods: list[str]
    lyapunov_methods: list[str]
    rigid_stick: bool
    convergence: ConvergenceSettings
    grid_refinements: dict[str, tuple[str, ...]]
    multistability: MultistabilitySettings
    lifetimes: LifetimeSettings
    lines: dict[str, dict[str, list[GridPoint]]]


def check_config_files(paths) -> None:
    """Each config file must be a YAML mapping without a key given twice (Snakemake's own loader
    keeps the last of two and reports a syntax error without file or line)."""
    for path in paths:
        load_yaml_mapping(str(path), "config file", "'model:', 'numerics:' and 'modes:'")


def build_plan(config: dict, schemas: Path) -> Plan:
    """Check ``config`` (Snakemake's, defaults of the schema filled in place) and the grid file
    it names against ``schemas`` (``config.schema.yaml``, ``grid.schema.yaml``) and the model's
    rules, and expand the grids into points and chunks."""
    validate_config(config, schemas / "config.schema.yaml", "config")
    validate_model(config["model"], "config")
    grid_file = config.get("grid_file", "config/grid.yaml")
    grids = load_yaml_mapping(grid_file, "grid_file", "a 'grids:' mapping")
    validate_config(grids, schemas / "grid.schema.yaml", grid_file)
    model_schema = yaml.safe_load((schemas / "config.schema.yaml").read_text())["$defs"]["model"]
    validate_grid_values(grids["grids"], model_schema, grid_file)

    try:
        numerics = Numerics.from_dict(config["numerics"])
    except ValueError as exc:  # settings that contradict each other (n_transient_max < n_transient, ...)
        raise WorkflowError(f"invalid config: {exc}") from None
    result_numerics = numerics.result_dict()
    table_config = {k: v for k, v in config.items() if k not in RUN_ONLY_KEYS}
    payload = canonical_json({"config": table_config, "grids": grids})
    config_hash = hashlib.sha256(payload.encode()).hexdigest()[:16]
    try:
        points = {name: expand_grid(name, grid, config["model"], result_numerics)
                  for name, grid in grids["grids"].items()}
    except ValueError as exc:  # unknown parameter, axis and fixed naming one key, repeated points
        raise WorkflowError(f"invalid config: {exc} [{grid_file}]") from None
    validate_grid_points(points, grids["grids"], grid_file)
    chunks = {name: chunk_points(pts, numerics.chunk_size) for name, pts in points.items()}
    lines = _expand_lines(grids["grids"], config["model"], result_numerics, model_schema, grid_file)
    methods = {integrator(numerics.method, p.params) for pts in points.values() for p in pts}
    # a point whose expo run meets expo's Zeno guard is run on RK4 (stages.simulate_runs): its
    # kernel compiled beforehand too, so that no chunk job compiles one (docs/reliability.md)
    methods = sorted(methods | ({"rk4"} if "expo" in methods else set()))
    every = [p for group in (points, *lines.values()) for pts in group.values() for p in pts]
    # the RK4 pair with them always: compile_kernels builds it first whatever the grids (the
    # fallback, the second opinion), so a grid that adds RK4 free copies (mu_s = mu_k) leaves the
    # Lyapunov stamp's params as they were; changed params rebuild the stamp, and Snakemake then
    # drops the jobs that read it through ancient() (analysis.pipeline.outcome)
    free_methods = sorted({free_copy_integrator(numerics.lyapunov.method, p.params) for p in every}
                          | {"rk4"})
    rigid = any(p.params.get("law") == "rigid-stick" for p in every)
    validate_lyapunov_laws(points, grid_file)
    validate_integrators(points, numerics, grid_file)
    try:
        convergence = ConvergenceSettings.from_dict(config.get("convergence"))
        multistability = MultistabilitySettings.from_dict(config.get("multistability"))
        lifetimes = LifetimeSettings.from_dict(config.get("lifetimes"))
        refinements = {}  # per grid, the refinements that are knobs of its law
        for name, pts in points.items():
            refinements[name] = grid_refinements(convergence.active, [p.params for p in pts], name)
            for ref in refinements[name]:  # each applies to every point (modes + 1 <= max)
                for p in pts:
                    refine(ref, p.params, numerics)
    except ValueError as exc:
        raise WorkflowError(f"invalid config: {exc}") from None
    return Plan(grids, numerics, result_numerics, table_config, config_hash, points, chunks,
                methods, free_methods, rigid, convergence, refinements, multistability, lifetimes,
                lines)


def _expand_lines(grids: dict, model: dict, result_numerics: dict, model_schema: dict,
                  grid_file: str) -> dict[str, dict[str, list[GridPoint]]]:
    """The continuation lines of every grid (``grids.<g>.lines.<l>``: one axis, ``fixed`` on top
    of the grid's), checked like grids: each point starts from its neighbour's end state, so a
    line whose points differ in the state's layout (``n_modes`` or ``n_quad`` along it) needs
    the elastic stick, whose states :func:`beamsim.state_transfer.transfer_state` carries."""
    as_grids = {}
    for g, grid in grids.items():
        for name, line in grid.get("lines", {}).items():
            # a line has no place on its grid's other axes unless it fixes them: it would run
            # at the model's values there (config.yaml's Omega 1, f0_rel 2), off the map
            loose = [a for a in grid["axes"] if a not in line["axes"] and a not in line.get("fixed", {})]
            if loose:
                raise WorkflowError(
                    f"invalid config: grids.{g}.lines.{name}: the grid's axis {loose[0]} is neither the "
                    f"line's axis nor in its fixed (the line would run at the model's {loose[0]} = "
                    f"{model.get(loose[0])!r}); give grids.{g}.lines.{name}.fixed.{loose[0]} [{grid_file}]")
            inherited = {k: v for k, v in grid.get("fixed", {}).items() if k not in line["axes"]}
            as_grids[f"{g}.lines.{name}"] = {"axes": line["axes"],
                                             "fixed": inherited | dict(line.get("fixed", {}))}
    if not as_grids:
        return {g: {} for g in grids}
    validate_grid_values(as_grids, model_schema, grid_file)
    try:
        expanded = {name: expand_grid(name, line, model, result_numerics) for name, line in as_grids.items()}
    except ValueError as exc:
        raise WorkflowError(f"invalid config: {exc} [{grid_file}]") from None
    validate_grid_points(expanded, as_grids, grid_file)
    out: dict = {g: {} for g in grids}
    for name, pts in expanded.items():
        sizes = {(p.params.get("n_modes"), p.params.get("n_quad")) for p in pts}
        laws = {p.params.get("law", "stick-slip") for p in pts}
        if len(sizes) > 1 and laws != {"stick-slip"}:
            raise WorkflowError(f"invalid config: grids.{name}: a continuation line along n_modes or "
                                f"n_quad needs law stick-slip (law {', '.join(sorted(laws))}: its state "
                                f"cannot be carried between bases) [{grid_file}]")
        g, _, line = name.split(".", 2)
        out[g][line] = pts
    return out
