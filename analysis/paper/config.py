"""The paper target's config (``config/paper.yaml``): loaded and checked in the workflow's
parse pass, before any job, like the grid file (one-line errors naming the key)."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

from snakemake.exceptions import WorkflowError

from analysis.paper.runs import RUN_ITEMS, item_runs, model_defaults
from analysis.pipeline.config import Numerics
from analysis.pipeline.validation import load_yaml_mapping, validate_config, validate_model

__all__ = ["PaperPlan", "build_paper_plan", "paper_file"]


@dataclass(frozen=True)
class PaperPlan:
    """paper : the paper config (validated); model : the paper runs' model defaults (config's
    model with the paper's overrides); result_numerics : the config's numerics with the paper's
    overrides, resolved (what enters point ids)."""

    paper: dict
    model: dict
    result_numerics: dict


def paper_file(config: dict, workflow_dir: Path) -> str:
    """The paper config to use: ``config['paper_file']`` if given; else ``config/paper.yaml`` of
    the working directory if there is one; else the one shipped with the workflow (a working
    directory made for a regime grid need not copy it)."""
    if config.get("paper_file"):
        return str(config["paper_file"])
    local = Path("config/paper.yaml")
    return str(local if local.exists() else workflow_dir / "config" / "paper.yaml")


def _check_runs(paper: dict, model: dict, paper_file: str) -> None:
    """Every run the items can plan must be a valid parameter point (each ``mu_s / mu_k`` of the
    mapping stands in for the chaos ratio, which is only known after the ``chaos_ratio`` runs)."""
    from beamsim.point import check_point

    for ratio in sorted(set(paper["mapping"]["mu_ratios"])):
        for item in RUN_ITEMS:
            for run in item_runs(item, paper, model, chaos_ratio=float(ratio)):
                try:
                    check_point(run.params)
                except ValueError as exc:
                    raise WorkflowError(f"invalid config: {item} ({run.case}, {run.law}): {exc} "
                                        f"[{paper_file}]") from None


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
    _check_runs(paper, merged["model"], paper_file)
    return PaperPlan(paper, merged["model"], Numerics.from_dict(numerics).result_dict())
