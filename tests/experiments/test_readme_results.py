"""The README's results table is written from the committed tables (issue 42): what it says is
what the CSVs in results/paper hold."""

import shutil

import pandas as pd

from enn_traffic.report.readme_results import results_table, rewrite


def test_the_readme_results_table_is_the_committed_tables(root):
    readme = (root / "README.md").read_text()
    assert results_table(root / "results" / "paper") in readme


def test_a_changed_table_changes_the_readme_row(root, tmp_path):
    """Fig. 9's 10-beam runs all failing: the README row rewritten from the tables says 0/5
    and drops their median."""
    paper = tmp_path / "paper"
    shutil.copytree(root / "results" / "paper", paper,
                    ignore=shutil.ignore_patterns("controllers", "*.png", "sumo", "city"))
    fig9 = pd.read_csv(paper / "fig9.csv")
    ten = fig9["beams"] == 10
    fig9.loc[ten, "runs_accepted"] = 0
    fig9.loc[ten, "median_generations_to_accepted"] = float("nan")
    fig9.to_csv(paper / "fig9.csv", index=False)
    readme = tmp_path / "README.md"
    shutil.copy(root / "README.md", readme)
    rewrite(readme, paper)
    text = readme.read_text()
    assert "10 beams: 0/5;" in text and "10 beams: 5/5" not in text
    assert text.replace("10 beams: 0/5;", "10 beams: 5/5 (median 3 generations);") == (
        root / "README.md").read_text()
