"""docs/scenarios.md keeps in step with the scenario schema it is written from."""

from enn_traffic.config.reference import DOCUMENT, rewritten, tables, undocumented


def test_every_scenario_key_is_described():
    assert undocumented() == []


def test_the_reference_is_the_schema_as_it_is():
    text = DOCUMENT.read_text()
    assert text == rewritten(text), (
        "docs/scenarios.md is out of step: run python -m enn_traffic.config.reference")
    assert "`[traffic] warmup_states` | `0` |" in tables()["scenario"]
