# Stick-slip regime maps of curved two-layer beams.  Rules live in workflow/rules/.
from snakemake.utils import min_version

from analysis.pipeline.convergence import REFINEMENTS
from analysis.pipeline.local_cores import hold_local_cores
from analysis.pipeline.plan import check_config_files

min_version("9.0")

# Snakemake >= 9.10 lets jobs exceed --cores after a job that ran alone (snakemake#3913)
hold_local_cores()


# each config file a YAML mapping, no key twice (one-line errors; Snakemake's loader is silent)
check_config_files(workflow.overwrite_configfiles or ["config/config.yaml"])


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


wildcard_constraints:
    grid=r"[A-Za-z0-9_-]+",  # grid names (workflow/schemas/grid.schema.yaml)
    chunk=r"[0-9]{3}",
    stage=r"simulate|lyapunov",
    line=r"[A-Za-z0-9_-]+",  # continuation lines of a grid (grids.<grid>.lines)
    refinement="|".join(REFINEMENTS),  # refinements and controls of the convergence runs


include: "workflow/rules/common.smk"
include: "workflow/rules/modes.smk"
include: "workflow/rules/regimes.smk"
include: "workflow/rules/paper.smk"


rule all:
    default_target: True
    input:
        rules.regimes.input,
