import hashlib
import json
from pathlib import Path

import jsonschema
import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

from analysis.grid import canonical_json, chunk_points, expand_grid
from analysis.regime_pipeline import integrator
from analysis.regimes import CLASSIFIER_VERSION
from beamsim.mode_cache import cache_key


SCHEMAS = Path(workflow.basedir) / "workflow" / "schemas"


def _allowed(schema: dict) -> str:
    """Human-readable allowed range/values of one JSON-Schema node."""
    if "enum" in schema:
        return "one of " + ", ".join(map(str, schema["enum"]))
    lo = (f"> {schema['exclusiveMinimum']}" if "exclusiveMinimum" in schema
          else f">= {schema['minimum']}" if "minimum" in schema else "")
    hi = (f"< {schema['exclusiveMaximum']}" if "exclusiveMaximum" in schema
          else f"<= {schema['maximum']}" if "maximum" in schema else "")
    kind = schema.get("type", "value")
    return " and ".join(x for x in (f"{kind}", lo, hi) if x)


def _one_line(err, prefix: str = "") -> str:
    key = ".".join(map(str, [*([prefix] if prefix else []), *err.absolute_path])) or "(top level)"
    if err.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "type"):
        what = err.schema.get("description", "")
        return f"{key} = {err.instance!r} ({what}); allowed: {_allowed(err.schema)}"
    if err.validator == "additionalProperties":
        allowed = sorted(err.schema.get("properties", {}))
        return f"{key}: {err.message}" + (f"; allowed keys: {', '.join(allowed)}" if allowed else "")
    return f"{key}: {err.message}"


def validate_config(cfg: dict, schema_file: Path, what: str) -> None:
    """snakemake.utils.validate, with a failure reduced to one line naming the key."""
    try:
        validate(cfg, str(schema_file))
    except WorkflowError:
        schema = yaml.safe_load(schema_file.read_text())
        err = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(cfg))
        raise WorkflowError(f"invalid config: {_one_line(err)} [{what}]") from None


def validate_grid_values(grids: dict, model_schema: dict) -> None:
    """Each axis value and fixed override must be a valid model parameter value."""
    props = model_schema["properties"]
    for name, grid in grids.items():
        entries = [(f"fixed.{k}", k, v) for k, v in grid.get("fixed", {}).items()]
        for axis, spec in grid["axes"].items():
            if isinstance(spec, dict) and "range" in spec:
                vals = spec["range"]
            else:
                vals = spec["values"] if isinstance(spec, dict) else spec
            entries += [(f"axes.{axis}", axis, v) for v in vals]
        for where, key, value in entries:
            if key not in props:
                raise WorkflowError(f"invalid config: grids.{name}.{where}: unknown model parameter "
                                    f"{key!r}; allowed: {', '.join(sorted(props))} [{GRID_FILE}]")
            errs = list(jsonschema.Draft202012Validator(props[key]).iter_errors(value))
            if errs:
                raise WorkflowError(f"invalid config: grids.{name}.{where} = {value!r} "
                                    f"({props[key].get('description', '')}); allowed: "
                                    f"{_allowed(props[key])} [{GRID_FILE}]")


validate_config(config, SCHEMAS / "config.schema.yaml", "config")
GRID_FILE = config.get("grid_file", "config/grid.yaml")
try:
    GRIDS = yaml.safe_load(Path(GRID_FILE).read_text())
except FileNotFoundError:
    raise WorkflowError(f"invalid config: grid_file {GRID_FILE!r} not found")
validate_config(GRIDS, SCHEMAS / "grid.schema.yaml", GRID_FILE)
validate_grid_values(GRIDS["grids"], yaml.safe_load((SCHEMAS / "config.schema.yaml").read_text())["$defs"]["model"])

#: numerics that change results enter every point id
RESULT_NUMERICS = {k: v for k, v in config["numerics"].items() if k != "chunk_size"}
#: the config as stored with every table and hashed: contents only (the grid file's location
#: is not part of the result; its contents are)
TABLE_CONFIG = {k: v for k, v in config.items() if k != "grid_file"}
CONFIG_HASH = hashlib.sha256(canonical_json({"config": TABLE_CONFIG, "grids": GRIDS}).encode()).hexdigest()[:16]

POINTS = {name: expand_grid(name, grid, config["model"], RESULT_NUMERICS)
          for name, grid in GRIDS["grids"].items()}
CHUNKS = {name: chunk_points(pts, config["numerics"]["chunk_size"]) for name, pts in POINTS.items()}
#: integrators of the reference runs (compile_kernels builds just these)
SIMULATION_METHODS = sorted({integrator(config["numerics"]["method"], p.params)
                             for pts in POINTS.values() for p in pts})


def chunk_ids(grid: str) -> list[str]:
    return [f"{k:03d}" for k in range(len(CHUNKS[grid]))]


def chunk_files(grid: str, stage: str) -> list[str]:
    return [f"results/regimes/{grid}/chunks/{c}.{stage}.parquet" for c in chunk_ids(grid)]


def chunk_payload(wildcards) -> list[dict]:
    """Points of one chunk, as the stage functions take them (also a params: rerun trigger)."""
    return [{"point_id": p.point_id, "params": p.params} for p in CHUNKS[wildcards.grid][int(wildcards.chunk)]]


def _mode_key(params: dict, n_modes: int | None = None) -> str:
    alpha = params.get("alpha_modes") or 0.5 * (params["alpha1"] + params.get("alpha2", params["alpha1"]))
    return cache_key(alpha, params["beta"], params.get("bc", "clamped-free"),
                     n_modes if n_modes is not None else params["n_modes"])


def chunk_mode_files(wildcards) -> list[str]:
    """The cached modes (one file per geometry) the points of a chunk need."""
    keys = sorted({_mode_key(p.params) for p in CHUNKS[wildcards.grid][int(wildcards.chunk)]})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def grid_mode_files(wildcards) -> list[str]:
    """The cached modes every point of a grid needs."""
    keys = sorted({_mode_key(p.params) for p in POINTS[wildcards.grid]})
    return [f"results/modes/{k}/modes.parquet" for k in keys]


def mode_key() -> str:
    """Cache key of the default model geometry with config['modes']['n_modes'] modes."""
    return _mode_key(config["model"], config["modes"]["n_modes"])
