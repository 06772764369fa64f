# Checks the config and the grid file, plans the run and provides input functions; nothing else.
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.logging import logger

from analysis.paper.config import build_paper_plan, paper_file
from analysis.paper.runs import FIGURES as PAPER_FIGURES
from analysis.paper.runs import NEEDS_CHAOS_RATIO as PAPER_NEEDS_CHAOS_RATIO
from analysis.paper.runs import RUN_ITEMS as PAPER_RUN_ITEMS
from analysis.paper.runs import stribeck_constants
from analysis.paper.tables import paper_config_hash
from analysis.pipeline.convergence import unchecked_reason
from analysis.pipeline.cost import convergence_cells, estimate_run
from analysis.pipeline.grid import RESULTS_VERSION
from analysis.pipeline.outcome import check_targets_made
from analysis.pipeline.plan import build_plan
from analysis.pipeline.preflight import check_results_dir, check_run_length
from analysis.regimes import CLASSIFIER_VERSION
from beamsim.mode_cache import model_cache_key


def estimate_cores() -> int:
    """The cores the run's time estimate assumes (the log line of every call, and the length
    gate): ``-c`` locally; on a cluster ``--jobs`` jobs at a time, each with the computing
    rules' one thread (known only once the executor is chosen, in ``onstart``: while the
    workflow is parsed Snakemake counts as local)."""
    if workflow.local_exec:
        return workflow.global_resources.get("_cores") or 1
    return workflow.global_resources.get("_nodes") or 1


#: every check that can refuse an input runs here, while the workflow is parsed (before any job)
PLAN = build_plan(config, Path(workflow.basedir) / "workflow" / "schemas")
GRIDS = PLAN.grids
POINTS = PLAN.points
CHUNKS = PLAN.chunks
#: numerics that change results, resolved (defaults filled in): they enter every point id
RESULT_NUMERICS = PLAN.result_numerics
CONFIG_HASH = PLAN.config_hash
TABLE_CONFIG = PLAN.table_config
#: integrators of each stage (compile_kernels builds just these): the reference runs', the
#: Lyapunov stage's free copies'
STAGE_METHODS = {"simulate": PLAN.simulation_methods, "lyapunov": PLAN.lyapunov_methods}
#: the convergence evidence of every map (analysis.pipeline.convergence): refinements that run
CONVERGENCE = PLAN.convergence
CONVERGENCE_SETTINGS = CONVERGENCE.as_dict() | {"refinements": list(CONVERGENCE.refinements)}
#: per grid, the refinements that run: the knobs of its law among them (k_t: stick-slip; band:
#: full-slip, stribeck), none when convergence.sample is 0
GRID_REFINEMENTS = PLAN.grid_refinements
#: the runs of a map's cells from other starts (analysis.pipeline.cell_attractors)
MULTISTABILITY = PLAN.multistability
MULTISTABILITY_SETTINGS = MULTISTABILITY.as_dict()
#: the lifetime runs of a map's chaos below the lock-up limit (analysis.pipeline.chaos_lifetime)
LIFETIMES = PLAN.lifetimes
LIFETIME_SETTINGS = LIFETIMES.as_dict()
#: the content-addressed per-point store (analysis.pipeline.store)
STORE_ROOT = "results/store"
#: the paper target (--config paper_file=..., else config/paper.yaml of the working directory,
#: else the workflow's own), checked with the rest
PAPER = build_paper_plan(config, paper_file(config, Path(workflow.basedir)),
                         Path(workflow.basedir) / "workflow" / "schemas")
PAPER_HASH = paper_config_hash(TABLE_CONFIG, PAPER.paper)
#: the Stribeck law of figs 12-13 (analysis.paper.runs.stribeck_constants)
PAPER_STRIBECK = stribeck_constants(PAPER.paper, PAPER.model)


if workflow.is_main_process:  # not in the per-job processes of a cluster executor
    # the convergence refinements whose runs are not on disk yet
    PENDING_CONVERGENCE = [
        (POINTS[g], [r for r in GRID_REFINEMENTS[g]
                     if not Path(f"results/regimes/{g}/convergence/{r}.parquet").exists()],
         convergence_cells(CONVERGENCE.sample, CONVERGENCE.census, len(POINTS[g])))
        for g in GRIDS["grids"]
    ]
    PENDING_LINES = [pts for g, lines in PLAN.lines.items() for line, pts in lines.items()
                     if not Path(f"results/regimes/{g}/lines/{line}.parquet").exists()]
    PENDING_MULTISTABILITY = [
        (POINTS[g], MULTISTABILITY.n_cells(len(POINTS[g])),
         MULTISTABILITY.starts_per_cell(len(GRIDS["grids"][g]["axes"])))
        for g in GRIDS["grids"] if not Path(f"results/regimes/{g}/attractors.parquet").exists()
    ]
    PENDING_LIFETIMES = [
        (POINTS[g], LIFETIMES)
        for g in GRIDS["grids"] if not Path(f"results/regimes/{g}/lifetimes.parquet").exists()
    ]
    ESTIMATE = estimate_run([p for pts in POINTS.values() for p in pts], PLAN.numerics, STORE_ROOT,
                            convergence=PENDING_CONVERGENCE, lines=PENDING_LINES,
                            multistability=PENDING_MULTISTABILITY, lifetimes=PENDING_LIFETIMES)
    logger.info(f"regimes: {ESTIMATE.summary(estimate_cores())}")


onstart:
    # a real run (not -n) with its jobs known: refuse it before the first job if too long
    # without the opt-in, or if results/ cannot take the new files
    jobs = {job.rule.name for job in workflow.dag.needrun_jobs()}
    if jobs & {"simulate_chunk", "lyapunov_chunk"}:
        check_run_length(ESTIMATE, estimate_cores(), config.get("allow_long", False))
    if jobs:
        check_results_dir("results", ESTIMATE.disk_bytes)


onsuccess:
    # every file asked for exists (Snakemake can drop a chain after a killed run: analysis.pipeline.outcome),
    # unless the run was cut short on request (--until, --omit-from)
    dag = workflow.dag
    if not (dag.untilrules or dag.untilfiles or dag.omitrules or dag.omitfiles):
        check_targets_made(f for job in dag.targetjobs for f in [*job.output, *job.input])


def chunk_ids(grid: str) -> list[str]:
    return [f"{k:03d}" for k in range(len(CHUNKS[grid]))]


def chunk_files(grid: str, stage: str) -> list[str]:
    return [f"results/regimes/{grid}/chunks/{c}.{stage}.parquet" for c in chunk_ids(grid)]


def chunk_payload(wildcards) -> list[dict]:
    """Points of one chunk, as the stage functions take them (also a params: rerun trigger)."""
    return [{"point_id": p.point_id, "params": p.params} for p in CHUNKS[wildcards.grid][int(wildcards.chunk)]]


def chunk_mode_files(wildcards) -> list[str]:
    """The cached modes (one file per geometry) the points of a chunk need."""
    keys = sorted({model_cache_key(p.params) for p in CHUNKS[wildcards.grid][int(wildcards.chunk)]})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def grid_mode_files(wildcards) -> list[str]:
    """The cached modes every point of a grid needs."""
    keys = sorted({model_cache_key(p.params) for p in POINTS[wildcards.grid]})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def convergence_mode_files(wildcards) -> list[str]:
    """The cached modes the refined points of one refinement of a grid may need (any point of
    the grid can be in the sample)."""
    from analysis.pipeline.convergence import refine

    if wildcards.refinement not in GRID_REFINEMENTS[wildcards.grid]:
        raise WorkflowError(f"results/regimes/{wildcards.grid}/convergence/{wildcards.refinement}"
                            f".parquet: grid {wildcards.grid} runs the refinements "
                            f"{list(GRID_REFINEMENTS[wildcards.grid])} (the knobs of its law and "
                            f"convergence.sample > 0)")
    keys = sorted({model_cache_key(refine(wildcards.refinement, p.params, PLAN.numerics)[0])
                   for p in POINTS[wildcards.grid]})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def convergence_files(wildcards) -> list[str]:
    """The per-refinement convergence runs of a grid (none when ``convergence.sample`` is 0 or
    no refinement of the list is a knob of the grid's law)."""
    return [f"results/regimes/{wildcards.grid}/convergence/{r}.parquet"
            for r in GRID_REFINEMENTS[wildcards.grid]]


def convergence_table(wildcards) -> list[str]:
    """The convergence table a grid's map figure reports (none when the grid has no convergence
    runs: :func:`convergence_files`)."""
    if not GRID_REFINEMENTS[wildcards.grid]:
        return []
    return [f"results/regimes/{wildcards.grid}/convergence.parquet"]


def attractor_table(wildcards) -> list[str]:
    """The multistability table a grid's map figure draws (none when multistability is off)."""
    return [f"results/regimes/{wildcards.grid}/attractors.parquet"] if MULTISTABILITY.active else []


def lifetime_table(wildcards) -> list[str]:
    """The lifetime table a grid's map figure marks (none when the lifetime step is off)."""
    return [f"results/regimes/{wildcards.grid}/lifetimes.parquet"] if LIFETIMES.active else []


def mode_key() -> str:
    """Cache key of the default model geometry with config['modes']['n_modes'] modes."""
    return model_cache_key(config["model"], config["modes"]["n_modes"])



def paper_chaos_input(wildcards) -> list[str]:
    if wildcards.item in PAPER_NEEDS_CHAOS_RATIO:
        return ["results/paper/chaos_ratio/measured.parquet"]
    return []


def paper_section(wildcards) -> dict:
    """The parts of the paper config one item's runs read (a change elsewhere reruns nothing)."""
    keys = ["mapping"] + ([wildcards.item] if wildcards.item in PAPER.paper else [])
    return {k: PAPER.paper[k] for k in keys}


def paper_figure_settings(wildcards) -> dict:
    """Dense-history settings for the items that draw attractors (none for chaos_ratio)."""
    return {} if wildcards.item == "chaos_ratio" else PAPER.paper["figures"]


def paper_table_input(item: str) -> list[str]:
    """The measured table a paper item's figures are drawn from (none for modes and fig12)."""
    return [f"results/paper/{item}/measured.parquet"] if item in PAPER_RUN_ITEMS else []


def line_points(wildcards) -> list[dict]:
    """The parameters of a continuation line's points, in axis order."""
    return [p.params for p in PLAN.lines[wildcards.grid][wildcards.line]]


def line_axis(wildcards) -> str:
    return next(iter(GRIDS["grids"][wildcards.grid]["lines"][wildcards.line]["axes"]))


def line_mode_files(wildcards) -> list[str]:
    """The cached modes the points of a continuation line need."""
    keys = sorted({model_cache_key(p) for p in line_points(wildcards)})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def line_files(suffix: str) -> list[str]:
    """Every continuation line's output with ``suffix`` (``.parquet``, ``.png``)."""
    return [f"results/regimes/{g}/lines/{line}{suffix}" for g, lines in PLAN.lines.items() for line in lines]
