"""The README's results table is written from the committed tables (issue 42): what it says is
what the CSVs in results/paper hold."""

import shutil

import pandas as pd

from enn_traffic.experiments.readme_results import results_table, rewrite


def test_the_readme_results_table_is_the_committed_tables(root):
    readme = (root / "README.md").read_text()
    assert results_table(root / "results" / "paper") in readme


def test_a_changed_table_changes_the_readme_row(root, tmp_path):
    """Fig. 9's 10-beam runs all failing: the README row rewritten from the tables says 0/5
    and drops their median."""
    paper = tmp_path / "paper"
    shutil.copytree(root / "results" / "paper", paper,
                    ignore=shutil.ignore_patterns("controllers", "*.png", "runs", "crowds"))
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


def test_the_generated_sections_of_results_md_are_the_committed_tables(root):
    from enn_traffic.experiments.results_doc import SECTIONS, section

    doc = (root / "docs" / "results.md").read_text()
    for name in SECTIONS:
        assert section(name, root / "results" / "paper") in doc, name


def test_a_changed_crowd_table_changes_the_results_md_text(root, tmp_path):
    """One learner of strategy 1 breeding 9 generations: the generated section's range for
    strategy 1 reads 4–9, and nothing else of it changes."""
    from enn_traffic.experiments.results_doc import rewrite

    paper = tmp_path / "paper"
    shutil.copytree(root / "results" / "paper", paper,
                    ignore=shutil.ignore_patterns("controllers", "*.png", "runs", "crowds"))
    shutil.copytree(root / "results" / "paper" / "controllers" / "table4",
                    paper / "controllers" / "table4")
    for comparison in ("baseline", "baseline_round2"):
        shutil.copytree(root / "results" / comparison, tmp_path / comparison,
                        ignore=shutil.ignore_patterns("*.png", "controllers"))
    learners = pd.read_csv(paper / "table4_learners.csv")
    learners.loc[learners["strategy"] == 1, "generations_bred"] = learners.loc[
        learners["strategy"] == 1, "generations_bred"].clip(upper=4)
    doc = tmp_path / "results.md"
    shutil.copy(root / "docs" / "results.md", doc)
    learners.to_csv(paper / "table4_learners.csv", index=False)
    rewrite(doc, paper)
    before = doc.read_text()
    learners.loc[0, "generations_bred"] = 9
    learners.to_csv(paper / "table4_learners.csv", index=False)
    rewrite(doc, paper)
    after = doc.read_text()
    assert "| 1 | 4 (4–4) |" in before and "| 1 | 4 (4–9) |" in after
    assert after.replace("| 1 | 4 (4–9) |", "| 1 | 4 (4–4) |") == before
