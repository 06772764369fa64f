# Validates the config, loads the grids and provides input functions; nothing else.
import hashlib
from pathlib import Path

import yaml
from snakemake.exceptions import WorkflowError

from analysis.pipeline.config import Numerics
from analysis.pipeline.grid import canonical_json, chunk_points, expand_grid
from analysis.pipeline.stages import integrator
from analysis.pipeline.validation import (
    load_grid_file,
    validate_config,
    validate_grid_points,
    validate_grid_values,
    validate_model,
)
from analysis.regimes import CLASSIFIER_VERSION
from beamsim.mode_cache import model_cache_key


SCHEMAS = Path(workflow.basedir) / "workflow" / "schemas"


validate_config(config, SCHEMAS / "config.schema.yaml", "config")
validate_model(config["model"], "config")
GRID_FILE = config.get("grid_file", "config/grid.yaml")
GRIDS = load_grid_file(GRID_FILE)
validate_config(GRIDS, SCHEMAS / "grid.schema.yaml", GRID_FILE)
validate_grid_values(
    GRIDS["grids"],
    yaml.safe_load((SCHEMAS / "config.schema.yaml").read_text())["$defs"]["model"],
    GRID_FILE,
)

NUMERICS = Numerics.from_dict(config["numerics"])
#: numerics that change results, resolved (defaults filled in): they enter every point id
RESULT_NUMERICS = NUMERICS.result_dict()
#: the content-addressed per-point store (analysis.pipeline.store)
STORE_ROOT = "results/store"
#: the config as stored with every table and hashed: contents only (the grid file's location
#: is not part of the result; its contents are)
TABLE_CONFIG = {k: v for k, v in config.items() if k != "grid_file"}
CONFIG_HASH = hashlib.sha256(canonical_json({"config": TABLE_CONFIG, "grids": GRIDS}).encode()).hexdigest()[:16]

try:
    POINTS = {name: expand_grid(name, grid, config["model"], RESULT_NUMERICS)
              for name, grid in GRIDS["grids"].items()}
except ValueError as exc:  # unknown parameter, axis and fixed naming one key, repeated points
    raise WorkflowError(f"invalid config: {exc} [{GRID_FILE}]") from None
validate_grid_points(POINTS, GRIDS["grids"], GRID_FILE)
CHUNKS = {name: chunk_points(pts, NUMERICS.chunk_size) for name, pts in POINTS.items()}
#: integrators of the reference runs (compile_kernels builds just these)
SIMULATION_METHODS = sorted({integrator(NUMERICS.method, p.params)
                             for pts in POINTS.values() for p in pts})


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


def mode_key() -> str:
    """Cache key of the default model geometry with config['modes']['n_modes'] modes."""
    return model_cache_key(config["model"], config["modes"]["n_modes"])
