"""The documents are their templates rendered over the committed facts
(docs/_generate/README.md), and every committed facts file is what its tables give."""


import pytest


def test_every_document_is_its_template_rendered(render, root):
    found = render.differences(root)
    assert not found, "\n".join(found.values())


def test_an_undefined_name_in_a_template_is_an_error(render):
    import jinja2

    with pytest.raises(jinja2.UndefinedError):
        render.environment().from_string("{{ no_such_fact }}").render()


def test_every_committed_facts_file_is_what_its_tables_give(root):
    from enn_traffic.experiments import facts

    assert facts.differences(root / "results") == []


def test_a_changed_table_changes_the_document(render, root, tmp_path):
    """A higher rate of the crowd run's winner in its table3.csv reads in docs/sumo.md as
    rendered over the changed table, and the committed document does not say it."""
    import shutil

    import pandas as pd

    folder = tmp_path / "results" / "crowd_brunswick"
    shutil.copytree(root / "results" / "crowd_brunswick", folder,
                    ignore=shutil.ignore_patterns("*.npz", "*.gif", "*.png"))
    shutil.copytree(root / "results" / "safety", tmp_path / "results" / "safety")
    table = pd.read_csv(folder / "table3.csv")
    table["winner_collisions_per_s"] = 9.8765
    table.to_csv(folder / "table3.csv", index=False)
    text = render.render(tmp_path, only=["docs/sumo.md"])["docs/sumo.md"]
    assert "| the winner for all | 9.8765 |" in text
    assert "9.8765" not in (root / "docs" / "sumo.md").read_text()
