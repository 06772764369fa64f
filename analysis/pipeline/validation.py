"""Config and grid checks of the workflow, each failure reduced to one line that names the key,
the value and the allowed range (``workflow/schemas`` holds the rules)."""

from __future__ import annotations

from pathlib import Path

import jsonschema
import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

__all__ = ["allowed", "validate_config", "validate_grid_values"]


def allowed(schema: dict) -> str:
    """Human-readable allowed range/values of one JSON-Schema node."""
    if "enum" in schema:
        return "one of " + ", ".join(map(str, schema["enum"]))
    lo = (f"> {schema['exclusiveMinimum']}" if "exclusiveMinimum" in schema
          else f">= {schema['minimum']}" if "minimum" in schema else "")
    hi = (f"< {schema['exclusiveMaximum']}" if "exclusiveMaximum" in schema
          else f"<= {schema['maximum']}" if "maximum" in schema else "")
    kind = schema.get("type", "value")
    return " and ".join(x for x in (f"{kind}", lo, hi) if x)


def _one_line(err) -> str:
    key = ".".join(map(str, err.absolute_path)) or "(top level)"
    if err.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "type"):
        what = err.schema.get("description", "")
        return f"{key} = {err.instance!r} ({what}); allowed: {allowed(err.schema)}"
    if err.validator == "additionalProperties":
        keys = sorted(err.schema.get("properties", {}))
        return f"{key}: {err.message}" + (f"; allowed keys: {', '.join(keys)}" if keys else "")
    return f"{key}: {err.message}"


def validate_config(cfg: dict, schema_file: Path, what: str) -> None:
    """``snakemake.utils.validate``, with a failure reduced to one line naming the key; ``what``
    (the file checked) ends the message."""
    try:
        validate(cfg, str(schema_file))
    except WorkflowError:
        schema = yaml.safe_load(Path(schema_file).read_text())
        err = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(cfg))
        raise WorkflowError(f"invalid config: {_one_line(err)} [{what}]") from None


def validate_grid_values(grids: dict, model_schema: dict, grid_file: str) -> None:
    """Each axis value and fixed override of every grid must be a valid model parameter value
    (``model_schema``: the config schema's model section)."""
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
                                    f"{key!r}; allowed: {', '.join(sorted(props))} [{grid_file}]")
            if list(jsonschema.Draft202012Validator(props[key]).iter_errors(value)):
                raise WorkflowError(f"invalid config: grids.{name}.{where} = {value!r} "
                                    f"({props[key].get('description', '')}); allowed: "
                                    f"{allowed(props[key])} [{grid_file}]")
