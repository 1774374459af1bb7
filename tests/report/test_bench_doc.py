"""docs/bench.md's generated sections hold what the committed bench tables give."""

import shutil

import pandas as pd


def test_the_generated_sections_of_bench_md_are_the_committed_tables(root):
    from enn_traffic.report.bench_doc import SECTIONS, section

    doc = (root / "docs" / "bench.md").read_text()
    for name in SECTIONS:
        assert section(name, root / "results" / "bench") in doc, name


def test_a_changed_bench_table_changes_the_text(root, tmp_path):
    """A slower step with eight learners in the CSV reads in the rewritten section."""
    from enn_traffic.report.bench_doc import rewrite

    folder = tmp_path / "bench"
    shutil.copytree(root / "results" / "bench", folder)
    table = pd.read_csv(folder / "sumo_step_issue60.csv")
    table.loc[table["implementation"] == "8 learners", "ms_per_step"] = 987.65
    table.to_csv(folder / "sumo_step_issue60.csv", index=False)
    doc = tmp_path / "bench.md"
    shutil.copy(root / "docs" / "bench.md", doc)
    rewrite(doc, folder)
    assert "| 987.65 (" in doc.read_text()
    assert "| 987.65 (" not in (root / "docs" / "bench.md").read_text()
