rule compute_modes:
    output:
        table="results/modes/{geometry}/modes.parquet",
    log:
        "logs/modes/{geometry}/compute_modes.log",
    conda:
        "../envs/beamsim.yaml"
    wildcard_constraints:
        geometry=r"alpha[^/]+_beta[^/]+_[a-z-]+_n[0-9]+",
    script:
        "../scripts/compute_modes.py"


rule plot_modes:
    input:
        table="results/modes/{geometry}/modes.parquet",
    output:
        determinant="results/modes/{geometry}/characteristic_function.png",
        shapes="results/modes/{geometry}/mode_shapes.png",
    log:
        "logs/modes/{geometry}/plot_modes.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/plot_modes.py"


rule modes:
    input:
        expand(
            "results/modes/{geometry}/{name}",
            geometry=mode_key(),
            name=["modes.parquet", "characteristic_function.png", "mode_shapes.png"],
        ),
