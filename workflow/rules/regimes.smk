rule compile_kernels:
    input:
        # one stage after the other: a kernel's machine code (and so its last bits) depends on
        # which of its callees the compiling process loaded from numba's cache and which it
        # compiled itself, so the two jobs side by side made the Lyapunov kernels' bits depend
        # on the jobs' timing (docs/reliability.md, "Compiled kernels"); the simulate stage's
        # first, so that its chunks run on the other core while the Lyapunov stage's compiles
        before=lambda wildcards: ["results/kernels/simulate.done"] if wildcards.stage == "lyapunov" else [],
    output:
        stamp="results/kernels/{stage}.done",
    params:
        methods=lambda wildcards: STAGE_METHODS[wildcards.stage],
        rigid=PLAN.rigid_stick,
    threads: 1
    # before the chunks that are ready with it: the Lyapunov stage's compilation is on the
    # critical path, a simulate chunk is not
    priority: 10
    log:
        "logs/kernels/{stage}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/compile_kernels.py"


rule simulate_chunk:
    input:
        modes=chunk_mode_files,
        kernels=ancient("results/kernels/simulate.done"),
    output:
        table="results/regimes/{grid}/chunks/{chunk}.simulate.parquet",
    params:
        points=chunk_payload,
        numerics=RESULT_NUMERICS,
        store=STORE_ROOT,
    # one thread per job, as every computing rule here: the scheduler keeps the cores busy
    # with whole jobs (their serial parts and last points' tails left one core idle at two
    # threads a job: docs/pipeline.md); results do not depend on it (--set-threads RULE=N)
    threads: 1
    log:
        "logs/regimes/{grid}/simulate_{chunk}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/simulate_chunk.py"


rule lyapunov_chunk:
    input:
        simulate="results/regimes/{grid}/chunks/{chunk}.simulate.parquet",
        modes=chunk_mode_files,
        kernels=ancient("results/kernels/lyapunov.done"),
    output:
        table="results/regimes/{grid}/chunks/{chunk}.lyapunov.parquet",
    params:
        points=chunk_payload,
        numerics=RESULT_NUMERICS,
        store=STORE_ROOT,
    threads: 1
    log:
        "logs/regimes/{grid}/lyapunov_{chunk}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/lyapunov_chunk.py"


rule classify_chunk:
    input:
        simulate="results/regimes/{grid}/chunks/{chunk}.simulate.parquet",
        lyapunov="results/regimes/{grid}/chunks/{chunk}.lyapunov.parquet",
    output:
        table="results/regimes/{grid}/chunks/{chunk}.classify.parquet",
    params:
        numerics=RESULT_NUMERICS,
        classifier=CLASSIFIER_VERSION,
    log:
        "logs/regimes/{grid}/classify_{chunk}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/classify_chunk.py"


rule regime_table:
    input:
        simulate=lambda wc: chunk_files(wc.grid, "simulate"),
        lyapunov=lambda wc: chunk_files(wc.grid, "lyapunov"),
        classified=lambda wc: chunk_files(wc.grid, "classify"),
        modes=grid_mode_files,
    output:
        table="results/regimes/{grid}.parquet",
    params:
        grid=lambda wc: GRIDS["grids"][wc.grid],
        points=lambda wc: [
            {"point_id": p.point_id, "index": list(p.index), "params": p.params}
            for p in POINTS[wc.grid]
        ],
        config_hash=CONFIG_HASH,
        config=TABLE_CONFIG,
    log:
        "logs/regimes/{grid}/regime_table.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/regime_table.py"


rule convergence_runs:
    input:
        table="results/regimes/{grid}.parquet",
        modes=convergence_mode_files,
        kernels=ancient(["results/kernels/simulate.done", "results/kernels/lyapunov.done"]),
    output:
        table="results/regimes/{grid}/convergence/{refinement}.parquet",
    params:
        numerics=RESULT_NUMERICS,
        # sample, seed and census (the refinement is the wildcard): a change of the list does
        # not rerun the refinements that stay
        settings=CONVERGENCE.as_dict(),
        axes=lambda wc: list(GRIDS["grids"][wc.grid]["axes"]),
        store=STORE_ROOT,
    threads: 1
    log:
        "logs/regimes/{grid}/convergence_{refinement}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/convergence_runs.py"


rule cell_attractors:
    input:
        table="results/regimes/{grid}.parquet",
        simulate=lambda wc: chunk_files(wc.grid, "simulate"),
        modes=grid_mode_files,
        kernels=ancient(["results/kernels/simulate.done", "results/kernels/lyapunov.done"]),
    output:
        table="results/regimes/{grid}/attractors.parquet",
    params:
        numerics=RESULT_NUMERICS,
        settings=MULTISTABILITY_SETTINGS,
        axes=lambda wc: list(GRIDS["grids"][wc.grid]["axes"]),
        store=STORE_ROOT,
        config_hash=CONFIG_HASH,
    threads: 1
    # the longest job after the map: started before the convergence runs, which then fill the
    # other core around it (Snakemake's priority is per rule; among equal priorities its
    # scheduler picks in no fixed order, and a late start left a core idle for up to a minute)
    priority: 1
    log:
        "logs/regimes/{grid}/cell_attractors.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/cell_attractors.py"


rule chaos_lifetime:
    input:
        table="results/regimes/{grid}.parquet",
        simulate=lambda wc: chunk_files(wc.grid, "simulate"),
        modes=grid_mode_files,
        kernels=ancient("results/kernels/simulate.done"),
    output:
        table="results/regimes/{grid}/lifetimes.parquet",
    params:
        numerics=RESULT_NUMERICS,
        settings=LIFETIME_SETTINGS,
        axes=lambda wc: list(GRIDS["grids"][wc.grid]["axes"]),
        config_hash=CONFIG_HASH,
    threads: 1
    # about as long as the multistability job: started beside it after the map, so that the
    # short convergence runs fill the cores around both (docs/performance.md, "The lifetime runs")
    priority: 1
    log:
        "logs/regimes/{grid}/chaos_lifetime.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/chaos_lifetime.py"


rule convergence_table:
    input:
        runs=convergence_files,
    output:
        table="results/regimes/{grid}/convergence.parquet",
    params:
        config_hash=CONFIG_HASH,
        # the refinements that ran on this grid (the knobs of its law)
        settings=lambda wc: CONVERGENCE_SETTINGS | {"refinements": list(GRID_REFINEMENTS[wc.grid])},
    log:
        "logs/regimes/{grid}/convergence_table.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/convergence_table.py"


rule convergence_figure:
    input:
        table="results/regimes/{grid}/convergence.parquet",
    output:
        figure=report(
            "results/regimes/{grid}/convergence.png",
            caption="../report/convergence.rst",
            category="Regime maps",
            subcategory="{grid}",
        ),
    params:
        axes=lambda wc: list(GRIDS["grids"][wc.grid]["axes"]),
        dpi=config.get("figures", {}).get("dpi", 130),
    log:
        "logs/regimes/{grid}/convergence_figure.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/convergence_figure.py"


rule continuation_line:
    input:
        modes=line_mode_files,
        kernels=ancient(["results/kernels/simulate.done", "results/kernels/lyapunov.done"]),
    output:
        table="results/regimes/{grid}/lines/{line}.parquet",
    params:
        points=line_points,
        axis=line_axis,
        version=RESULTS_VERSION,  # a code change that alters results reruns the line
        line=lambda wc: GRIDS["grids"][wc.grid]["lines"][wc.line],
        numerics=RESULT_NUMERICS,
    threads: 1
    log:
        "logs/regimes/{grid}/line_{line}.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/continuation_line.py"


rule continuation_figure:
    input:
        table="results/regimes/{grid}/lines/{line}.parquet",
    output:
        figure=report(
            "results/regimes/{grid}/lines/{line}.png",
            caption="../report/continuation.rst",
            category="Regime maps",
            subcategory="{grid}",
        ),
    params:
        axis=line_axis,
        line=lambda wc: GRIDS["grids"][wc.grid]["lines"][wc.line],
        numerics=RESULT_NUMERICS,
        dpi=config.get("figures", {}).get("dpi", 130),
    log:
        "logs/regimes/{grid}/line_{line}_figure.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/continuation_figure.py"


rule regime_figures:
    input:
        table="results/regimes/{grid}.parquet",
        convergence=convergence_table,
        attractors=attractor_table,
        lifetimes=lifetime_table,
    output:
        regimes=report(
            "results/regimes/{grid}/regimes.png",
            caption="../report/regimes.rst",
            category="Regime maps",
            subcategory="{grid}",
        ),
        lle=report(
            "results/regimes/{grid}/lle.png",
            caption="../report/lle.rst",
            category="Regime maps",
            subcategory="{grid}",
        ),
    params:
        grid=lambda wc: GRIDS["grids"][wc.grid],
        numerics=RESULT_NUMERICS,
        dpi=config.get("figures", {}).get("dpi", 130),
        # why a grid without convergence runs has none (its map's title says it)
        unchecked=lambda wc: unchecked_reason(CONVERGENCE.active, [p.params for p in POINTS[wc.grid]]),
        # the labels whose every cell the convergence runs hold (the title counts them apart)
        census=list(CONVERGENCE.census),
    log:
        "logs/regimes/{grid}/regime_figures.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/regime_figures.py"


rule portraits:
    input:
        table="results/regimes/{grid}.parquet",
        modes=grid_mode_files,
    output:
        figure=report(
            "results/regimes/{grid}/portraits.png",
            caption="../report/portraits.rst",
            category="Regime maps",
            subcategory="{grid}",
        ),
    params:
        grid=lambda wc: GRIDS["grids"][wc.grid],
        numerics=RESULT_NUMERICS,
        dpi=config.get("figures", {}).get("dpi", 130),
    log:
        "logs/regimes/{grid}/portraits.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/portraits.py"


rule regimes:
    input:
        expand("results/regimes/{grid}.parquet", grid=list(GRIDS["grids"])),
        expand("results/regimes/{grid}/regimes.png", grid=list(GRIDS["grids"])),
        expand("results/regimes/{grid}/lle.png", grid=list(GRIDS["grids"])),
        expand("results/regimes/{grid}/portraits.png", grid=list(GRIDS["grids"])),
        expand("results/regimes/{grid}/convergence.png",
               grid=[g for g in GRIDS["grids"] if GRID_REFINEMENTS[g]]),
        expand("results/regimes/{grid}/attractors.parquet",
               grid=list(GRIDS["grids"]) if MULTISTABILITY.active else []),
        expand("results/regimes/{grid}/lifetimes.parquet",
               grid=list(GRIDS["grids"]) if LIFETIMES.active else []),
        line_files(".parquet"),
        line_files(".png"),
