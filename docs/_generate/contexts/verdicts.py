"""The verdict table that opens docs/results.md and is the README's results: one row per
experiment of the paper and the GA against gradient RL, from the facts files the
experiments wrote (``results/paper/facts/verdicts.json``,
``results/baseline/facts/verdict.json``; the rule: :mod:`enn_traffic.experiments.verdicts`)."""

from __future__ import annotations

from pathlib import Path

from enn_traffic.experiments.facts import read as read_facts
from enn_traffic.experiments.verdicts import VERDICTS


def context(root: Path) -> dict:
    paper = read_facts(root / "results" / "paper", "verdicts")
    baseline = read_facts(root / "results" / "baseline", "verdict")
    rows = paper["rows"] + [baseline]
    counts = {word: sum(row["verdict"] == word for row in rows) for word in VERDICTS}
    return {"verdicts": {"rows": {row["name"]: row for row in rows},
                         "order": [row["name"] for row in rows], "level": paper["level"],
                         "words": list(VERDICTS), "counts": counts}}
