"""`snakemake paper` (and `--report`) on a fresh working directory at test size
(tests/workflow/data/paper_tiny.yaml): every item's figures and verdict rows exist, every verdict
comes from the fixed vocabulary, the tables carry the config hash, and the HTML report holds the
paper items with their captions."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest
from workflow_run import GRID, ROOT, setup_workdir, snakemake

from analysis.paper.drawing import FIGURES
from analysis.paper.runs import ITEMS, RUN_ITEMS
from analysis.paper.tables import read_paper_metadata
from analysis.paper.verdicts import VERDICTS

# slow; one run shared by the module (make test hands whole files to a worker: --dist loadfile)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    work = setup_workdir(tmp_path_factory.mktemp("paper"), GRID)
    shutil.copy(ROOT / "tests" / "workflow" / "data" / "paper_tiny.yaml", work / "paper.yaml")
    res = snakemake(work, "paper", "--config", f"paper_file={work / 'paper.yaml'}")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-5000:]
    return work


def test_every_item_has_its_figures_and_verdicts(paper_run):
    for item, files in FIGURES.items():
        for f in files:
            path = paper_run / "results" / "paper" / item / f
            assert path.stat().st_size > 10_000, path  # a drawn PNG, not an empty canvas
    table = pd.read_parquet(paper_run / "results" / "paper" / "verdicts.parquet")
    assert list(table.columns) == ["item", "claim", "measured", "verdict"]
    assert set(table["item"]) == set(ITEMS)
    # every claim has its row (fig8: one per lambda; fig13: one per load and the trend)
    counts = table["item"].value_counts().to_dict()
    assert counts == {"modes": 1, "fig8": 1, "fig9": 3, "fig10": 5, "fig11": 1, "fig12": 1, "fig13": 2}
    assert set(table["verdict"]) <= set(VERDICTS)  # as read back from the file
    assert table["measured"].str.len().min() > 20  # numbers, not a placeholder
    tsv = pd.read_csv(paper_run / "results" / "paper" / "verdicts.tsv", sep="\t")
    pd.testing.assert_frame_equal(tsv, table)


def test_tables_carry_the_config_hash(paper_run):
    meta = read_paper_metadata(paper_run / "results" / "paper" / "verdicts.parquet")
    assert len(meta["config_hash"]) == 16 and meta["paper"]["mapping"]["f0_anchors"] == [0.75]
    for item in RUN_ITEMS:
        m = read_paper_metadata(paper_run / "results" / "paper" / item / "measured.parquet")
        # an item's hash covers what its runs depend on: its config section, model and numerics
        assert len(m["config_hash"]) == 16 and m["item"] == item and m["model"]["n_modes"] == 1


def test_report_holds_the_paper_items_with_captions(paper_run):
    """The HTML report of the paper target (the report of the regime maps:
    tests/workflow/test_workflow_regimes.py)."""
    res = snakemake(paper_run, "paper", "--config", f"paper_file={paper_run / 'paper.yaml'}",
                    "--report", str(paper_run / "report.html"))
    assert res.returncode == 0, res.stderr[-3000:]
    html = (paper_run / "report.html").read_text(errors="replace")
    for caption in ("Paper Fig 8", "Paper Fig 12", "Every claim of the paper", "Paper Table 1"):
        assert caption in html, caption


def test_a_bad_paper_file_is_one_line_before_any_job(tmp_path):
    work = setup_workdir(tmp_path / "w", GRID)
    bad = (ROOT / "tests" / "workflow" / "data" / "paper_tiny.yaml").read_text().replace(
        "f0_anchors: [0.75]", "f0_anchors: [0.4]")
    (work / "paper.yaml").write_text(bad)
    res = snakemake(work, "paper", "--config", f"paper_file={work / 'paper.yaml'}")
    assert res.returncode != 0
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if "invalid config:" in ln]
    assert lines and "mapping.f0_anchors.0 = 0.4" in lines[0] and "> 0.5" in lines[0], lines
    assert not (work / "results").exists()
