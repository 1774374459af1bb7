"""docs/sumo.md's crowd section holds what the committed crowd run's files give."""

import shutil

import pandas as pd


def test_the_crowd_section_of_sumo_md_is_the_committed_run(root):
    from enn_traffic.report import generated
    from enn_traffic.report.crowd_doc import SECTIONS

    doc = (root / "docs" / "sumo.md").read_text()
    for name in SECTIONS:
        assert generated.section(name, root / "results" / "crowd_brunswick", SECTIONS) in doc


def test_a_changed_table_changes_the_text(root, tmp_path):
    """A higher rate of the winner in table3.csv reads in the rewritten section."""
    from enn_traffic.report import generated
    from enn_traffic.report.crowd_doc import SECTIONS

    folder = tmp_path / "crowd"
    shutil.copytree(root / "results" / "crowd_brunswick", folder)
    table = pd.read_csv(folder / "table3.csv")
    table["winner_collisions_per_s"] = 9.8765
    table.to_csv(folder / "table3.csv", index=False)
    doc = tmp_path / "sumo.md"
    shutil.copy(root / "docs" / "sumo.md", doc)
    generated.rewrite(doc, folder, SECTIONS)
    assert "| the winner for all | 9.8765 |" in doc.read_text()
    assert "9.8765" not in (root / "docs" / "sumo.md").read_text()
