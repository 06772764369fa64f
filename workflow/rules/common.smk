from pathlib import Path

import jsonschema
import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

from beamsim.mode_cache import cache_key


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


def validate_config(cfg: dict, schema_file: Path) -> None:
    """snakemake.utils.validate, with a failure reduced to one line naming the key."""
    try:
        validate(cfg, str(schema_file))
    except WorkflowError:
        schema = yaml.safe_load(schema_file.read_text())
        err = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(cfg))
        key = ".".join(map(str, err.absolute_path)) or "(top level)"
        what = err.schema.get("description", "")
        raise WorkflowError(
            f"invalid config: {key} = {err.instance!r} ({what}); allowed: {_allowed(err.schema)}"
            if err.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "type")
            else f"invalid config: {key}: {err.message}"
        ) from None


SCHEMAS = Path(workflow.basedir) / "workflow" / "schemas"
validate_config(config, SCHEMAS / "config.schema.yaml")


def mode_key() -> str:
    """Cache key of the configured geometry: modes rerun only when it changes."""
    g = config["geometry"]
    return cache_key(g["alpha"], g["beta"], g["bc"], config["modes"]["n_modes"])
