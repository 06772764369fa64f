"""Config and grid checks of the workflow, each failure reduced to one line that names the key,
the value and the allowed range (``workflow/schemas`` holds the rules)."""

from __future__ import annotations

import difflib
import math
from pathlib import Path

import jsonschema
import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

__all__ = ["allowed", "load_yaml_mapping", "validate_config", "validate_grid_points", "validate_grid_values",
           "validate_integrators", "validate_lyapunov_laws", "validate_model"]


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


def key_text(key) -> str:
    """A config key as text on one line: itself, or its ``repr`` where it would not print as
    itself (a newline or other control character, blanks around it, empty), so that an error
    message naming it stays one line."""
    text = str(key)
    return text if text and text.isprintable() and text == text.strip() else repr(key)


def _one_line(err) -> str:
    key = ".".join(map(key_text, err.absolute_path)) or "(top level)"
    alt = err if err.validator in ("oneOf", "anyOf") else err.parent
    scalar = ("integer", "number", "string", "boolean")
    if (alt is not None and alt.validator in ("oneOf", "anyOf")  # scalar alternatives: integer or "all"
            and all(s.get("type") in scalar for s in alt.schema[alt.validator])):
        what = " ".join(str(alt.schema.get("description", "")).split())
        options = " or ".join(allowed(s) for s in alt.schema[alt.validator])
        return f"{key} = {alt.instance!r} ({what}); allowed: {options}"
    if err.validator in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum", "type"):
        what = " ".join(str(err.schema.get("description", "")).split())  # a folded YAML text: one line
        return f"{key} = {err.instance!r} ({what}); allowed: {allowed(err.schema)}"
    if err.validator == "additionalProperties":
        keys = sorted(err.schema.get("properties", {}))
        extra = sorted(set(err.instance) - set(keys)) if isinstance(err.instance, dict) else []
        hint = "".join(_did_you_mean(k, keys) for k in extra)
        return f"{key}: {err.message}{hint}" + (f"; allowed keys: {', '.join(keys)}" if keys else "")
    return f"{key}: {err.message}"


def _did_you_mean(word: str, choices) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class _UniqueKeyLoader(yaml.SafeLoader):
    """A YAML loader that refuses a key given twice in one mapping (PyYAML keeps the last)."""


def _unique_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            hash(key)
        except TypeError:
            continue  # construct_mapping reports the unhashable key
        if key in seen:
            raise yaml.constructor.ConstructorError(None, None, f"key {key!r} given twice",
                                                    key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _unique_mapping)


def load_yaml_mapping(path: str, what: str, expected: str) -> dict:
    """The YAML file ``path`` as a mapping; a missing, unreadable, non-YAML, empty or non-mapping
    file, or a key given twice, is one line naming the file (``what``: its role, e.g.
    ``grid_file``; ``expected``: what it must hold) and the line of the YAML error."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise WorkflowError(f"invalid config: {what} {path!r} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise WorkflowError(f"invalid config: {what} {path!r} cannot be read: {exc}") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise WorkflowError(f"invalid config: {path} is not valid YAML{where}: {problem} [{path}]") from None
    if not isinstance(data, dict):
        kind = "empty" if data is None else f"a {type(data).__name__}, not a mapping"
        raise WorkflowError(f"invalid config: {path} is {kind}; it must hold {expected} [{path}]")
    return data


def _non_finite(obj, path: str = ""):
    """The first ``(key path, value)`` of a NaN or infinite number in a nested config, or None
    (JSON Schema's ``number`` admits both, and every range comparison with NaN is false)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return path or "(top level)", obj
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        found = _non_finite(v, f"{path}.{k}" if path else str(k))
        if found:
            return found
    return None


def validate_config(cfg: dict, schema_file: Path, what: str) -> None:
    """``snakemake.utils.validate``, with a failure reduced to one line naming the key; ``what``
    (the file checked) ends the message.  NaN and infinite numbers are refused everywhere."""
    bad = _non_finite(cfg)
    if bad:
        raise WorkflowError(f"invalid config: {bad[0]} = {bad[1]!r}: must be a finite number [{what}]")
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
        entries = [(f"fixed.{key_text(k)}", k, v) for k, v in grid.get("fixed", {}).items()]
        for axis, spec in grid["axes"].items():
            if isinstance(spec, dict) and "range" in spec:
                vals = spec["range"]
            else:
                vals = spec["values"] if isinstance(spec, dict) else spec
            entries += [(f"axes.{key_text(axis)}", axis, v) for v in vals]
        for where, key, value in entries:
            if key not in props:
                raise WorkflowError(f"invalid config: grids.{name}.{where}: unknown model parameter "
                                    f"{key!r}{_did_you_mean(key, props)}; allowed: "
                                    f"{', '.join(sorted(props))} [{grid_file}]")
            if list(jsonschema.Draft202012Validator(props[key]).iter_errors(value)):
                raise WorkflowError(f"invalid config: grids.{name}.{where} = {value!r} "
                                    f"({' '.join(str(props[key].get('description', '')).split())}); allowed: "
                                    f"{allowed(props[key])} [{grid_file}]")


def validate_grid_points(points: dict, grids: dict, grid_file: str) -> None:
    """Every point of every grid (``points``: grid name -> its ``GridPoint`` list) must pass the
    model's own parameter rules (:func:`beamsim.point.check_point`: the same rules the Python
    API applies, e.g. ``mu_k <= mu_s``, one of ``f0`` / ``f0_rel``), checked before any job; the
    message names the grid, the point's axis values and the rule."""
    from analysis.pipeline.grid import canonical_json
    from beamsim.point import check_point

    seen = set()
    for name, pts in points.items():
        axes = list(grids[name].get("axes", {}))
        for p in pts:
            key = canonical_json(p.params)
            if key in seen:
                continue
            seen.add(key)
            try:
                check_point(dict(p.params))
            except ValueError as exc:
                where = ", ".join(f"{a}={p.params[a]!r}" for a in axes)
                raise WorkflowError(f"invalid config: grids.{name} (point {where}): {exc} "
                                    f"[{grid_file}]") from None


def validate_lyapunov_laws(points: dict, grid_file: str) -> None:
    """Every point's largest Lyapunov exponent must exist: the rigid stick with ``mu_s > mu_k``
    has none (Benettin's estimate grows as the initial separation shrinks, docs/lyapunov.md
    section 11), so a map of it is refused."""
    from beamsim.friction import Friction

    for name, pts in points.items():
        for p in pts:
            if p.params.get("law") != "rigid-stick":
                continue
            mu_s = p.params.get("mu_s", Friction.mu_s)
            mu_k = p.params.get("mu_k")
            if mu_k is not None and float(mu_s) > float(mu_k):
                raise WorkflowError(
                    f"invalid config: grids.{name}: law = 'rigid-stick' with mu_s = {mu_s} > "
                    f"mu_k = {mu_k}: the largest Lyapunov exponent of the rigid stick with a "
                    "break-away drop is not defined (docs/lyapunov.md section 11); allowed: "
                    f"mu_k = mu_s with rigid-stick, or law: stick-slip [{grid_file}]")


def validate_integrators(points: dict, numerics, grid_file: str) -> None:
    """The reference runs' integrator (``numerics.method``) and the Lyapunov stage's free copy
    (``numerics.lyapunov.method``), ``auto`` resolved per point, must support every point's
    friction law (``expo`` and ``newmark``: stick-slip only)."""
    from analysis.pipeline.stages import expo_copy_supported, free_copy_integrator, integrator
    from beamsim.point import check_method_law

    for key, method, resolve in (("numerics.method", numerics.method, integrator),
                                 ("numerics.lyapunov.method", numerics.lyapunov.method,
                                  free_copy_integrator)):
        for name, pts in points.items():
            for p in pts:
                try:
                    check_method_law(resolve(method, p.params), p.params.get("law", "stick-slip"))
                except ValueError as exc:
                    raise WorkflowError(f"invalid config: {key} = {method!r} (grids.{name}): "
                                        f"{exc}; use method: auto or rk4 [{grid_file}]") from None
                if (resolve is free_copy_integrator and resolve(method, p.params) == "expo"
                        and not expo_copy_supported(p.params)):
                    raise WorkflowError(
                        f"invalid config: {key} = 'expo' (grids.{name}) needs mu_s > mu_k "
                        f"(mu_s = {p.params.get('mu_s')!r}, mu_k = {p.params.get('mu_k')!r}: a "
                        f"stuck element starting at its slip limit can make the expo copy "
                        f"chatter, docs/lyapunov.md section 12); use method: auto or rk4 "
                        f"[{grid_file}]")


def validate_model(model: dict, what: str) -> None:
    """The config's model defaults are a parameter point too: they must pass the model's rules
    (:func:`beamsim.point.check_point`) even where every grid overrides the offending value."""
    from beamsim.point import check_point

    try:
        check_point({k: v for k, v in model.items() if v is not None})
    except ValueError as exc:
        raise WorkflowError(f"invalid config: model: {exc} [{what}]") from None
