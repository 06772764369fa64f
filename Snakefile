# Stick-slip regime maps of curved two-layer beams.  Rules live in workflow/rules/.
from snakemake.utils import min_version

min_version("9.0")


configfile: "config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/modes.smk"
include: "workflow/rules/regimes.smk"


rule all:
    default_target: True
    input:
        rules.regimes.input,
