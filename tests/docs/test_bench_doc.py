"""docs/bench.md, and the README's timings and city example, say what the committed tables
give (docs/_generate/README.md): a changed table changes the document as rendered over it."""

import shutil
from pathlib import Path

import pandas as pd


def copied(root: Path, tmp_path: Path) -> Path:
    """A root holding copies of the tables the bench and README contexts read."""
    for folder in ("bench", "readme_example"):
        shutil.copytree(root / "results" / folder, tmp_path / "results" / folder)
    (tmp_path / "results" / "paper").mkdir()
    shutil.copy(root / "results" / "paper" / "summary.json", tmp_path / "results" / "paper")
    return tmp_path


def test_a_changed_bench_table_changes_bench_md(render, root, tmp_path):
    """A slower step with eight learners in the CSV reads in docs/bench.md as rendered."""
    folder = copied(root, tmp_path) / "results" / "bench"
    table = pd.read_csv(folder / "sumo_step_issue60.csv")
    table.loc[table["implementation"] == "8 learners", "ms_per_step"] = 987.65
    table.to_csv(folder / "sumo_step_issue60.csv", index=False)
    text = render.render(tmp_path, only=["docs/bench.md"])["docs/bench.md"]
    assert "| 8 learners | 5 × 300 | 987.65 (" in text
    assert "987.65" not in (root / "docs" / "bench.md").read_text()


def test_every_committed_bench_table_is_read(render, root, monkeypatch):
    """No table in results/bench lies beside docs/bench.md unread."""
    from contexts import bench

    read = []
    original = pd.read_csv

    def reading(path, *args, **kwargs):
        read.append(Path(path).name)
        return original(path, *args, **kwargs)

    monkeypatch.setattr(bench.pd, "read_csv", reading)
    bench.context(root)
    assert sorted(read) == sorted(p.name for p in (root / "results" / "bench").glob("*.csv"))


def test_the_readme_says_what_its_tables_give(render, root, tmp_path):
    """The README's first-run time and its city example's closed-loop steps, changed in their
    tables, read in the README as rendered over them."""
    from contexts import DOCUMENTS, bench, readme

    copied(root, tmp_path)
    first = tmp_path / "results" / "bench" / "first_run_issue62.csv"
    table = pd.read_csv(first)
    table.loc[0, "seconds"] = 98765.0
    table.to_csv(first, index=False)
    closed = tmp_path / "results" / "readme_example" / "city_closed.csv"
    table = pd.read_csv(closed)
    table["steps"] = 4321
    table.to_csv(closed, index=False)
    template, parts = DOCUMENTS["README.md"]
    values = render.context(root, tuple(p for p in parts if p not in (bench, readme)))
    values |= bench.context(tmp_path) | readme.context(tmp_path)
    text = render.environment().get_template(template).render(**values)
    assert "numba compiles the simulator first, 98765 s on" in text
    assert "| closed loop | 4321 |" in text
    committed = (root / "README.md").read_text()
    assert "98765" not in committed and "4321" not in committed
