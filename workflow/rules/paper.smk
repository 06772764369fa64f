# The paper target: the seed paper's section 4 item by item (docs/paper-reproduction.md).
# Runs of each item -> results/paper/<item>/measured.parquet; figures; verdicts.parquet.


rule paper_item:
    input:
        chaos=paper_chaos_input,
    output:
        table="results/paper/{item}/measured.parquet",
    params:
        paper=paper_section,
        model=PAPER.model,
        numerics=PAPER.result_numerics,
        figures=paper_figure_settings,
        store=STORE_ROOT,
    threads: 2
    log:
        "logs/paper/{item}.log",
    wildcard_constraints:
        item="|".join(PAPER_RUN_ITEMS),
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/paper_item.py"


for _item, _files in PAPER_FIGURES.items():

    rule:
        name:
            f"paper_figures_{_item}"
        input:
            table=paper_table_input(_item),
        output:
            **{
                Path(f).stem: report(
                    f"results/paper/{_item}/{f}",
                    caption=f"../report/paper_{_item}.rst",
                    category="Paper reproduction",
                    subcategory=_item,
                )
                for f in _files
            },
        params:
            item=_item,
            stribeck=PAPER_STRIBECK if _item == "fig12" else {},
            numerics=PAPER.result_numerics,
            dpi=config.get("figures", {}).get("dpi", 130),
        log:
            f"logs/paper/figures_{_item}.log",
        conda:
            "../envs/beamsim.yaml"
        script:
            "../scripts/paper_figures.py"


rule paper_verdicts:
    input:
        tables=expand("results/paper/{item}/measured.parquet", item=PAPER_RUN_ITEMS),
    output:
        table="results/paper/verdicts.parquet",
        tsv=report(
            "results/paper/verdicts.tsv",
            caption="../report/paper_verdicts.rst",
            category="Paper reproduction",
            subcategory="verdicts",
        ),
    params:
        run_items=PAPER_RUN_ITEMS,
        paper=PAPER.paper,
        stribeck=PAPER_STRIBECK,
        numerics=PAPER.result_numerics,
        config_hash=PAPER_HASH,
    log:
        "logs/paper/verdicts.log",
    conda:
        "../envs/beamsim.yaml"
    script:
        "../scripts/paper_verdicts.py"


rule paper:
    input:
        rules.paper_verdicts.output,
        [f"results/paper/{item}/{f}" for item, files in PAPER_FIGURES.items() for f in files],
