"""The paper target's config (``config/paper.yaml``): loaded and checked in the workflow's
parse pass, before any job, like the grid file (one-line errors naming the key)."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

from snakemake.exceptions import WorkflowError

from analysis.paper.runs import model_defaults
from analysis.pipeline.config import Numerics
from analysis.pipeline.validation import load_yaml_mapping, validate_config, validate_model

__all__ = ["PaperPlan", "build_paper_plan"]


@dataclass(frozen=True)
class PaperPlan:
    """paper : the paper config (validated); model : the paper runs' model defaults (config's
    model with the paper's overrides); numerics, result_numerics : the config's numerics with the
    paper's overrides (all, and those that enter point ids)."""

    paper: dict
    model: dict
    numerics: Numerics
    result_numerics: dict


def build_paper_plan(config: dict, paper_file: str, schemas: Path) -> PaperPlan:
    """Check ``paper_file`` against ``schemas/paper.schema.yaml``, and the model and numerics it
    gives (merged into ``config``'s) against the config schema and the model's rules."""
    paper = load_yaml_mapping(paper_file, "paper_file", "'mapping:', 'fig8:', 'fig10:' ... mappings")
    validate_config(paper, schemas / "paper.schema.yaml", paper_file)
    merged = copy.deepcopy({k: config[k] for k in ("model", "numerics", "modes")})
    merged["model"] = model_defaults(config["model"], paper)
    numerics = dict(config["numerics"])
    for k, v in (paper.get("numerics") or {}).items():
        numerics[k] = dict(numerics.get(k) or {}, **v) if k == "lyapunov" else v
    merged["numerics"] = numerics
    validate_config(merged, schemas / "config.schema.yaml", paper_file)
    validate_model(merged["model"], paper_file)
    f8 = paper["fig8"]
    if len(f8["lam_f"]) != len(f8["p"]):
        raise WorkflowError(f"invalid config: fig8.p has {len(f8['p'])} values, fig8.lam_f "
                            f"{len(f8['lam_f'])}: give one p per lambda [{paper_file}]")
    nm = Numerics.from_dict(numerics)
    return PaperPlan(paper, merged["model"], nm, nm.result_dict())
