"""The paper's experiments, each writing its tables, figures and facts into the reproduce
folder; the crowds (:mod:`enn_traffic.experiments.crowds`) and the GA against gradient RL
(:mod:`enn_traffic.experiments.gradient_rl`).

``EXPERIMENTS`` maps the names that ``enn-traffic reproduce --only`` takes to functions
``(study: Study) -> list[str]`` that return summary lines
(:class:`~enn_traffic.experiments.study.Study`: the folder, the settings, the executor and
what experiments compute once and share). The
dynamic-traffic experiments share their protocol (:mod:`~enn_traffic.experiments.families`) and
the statistics of choosing controllers (:mod:`~enn_traffic.experiments.choosing`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from enn_traffic.core.registry import Registry

if TYPE_CHECKING:
    from enn_traffic.experiments.study import Study

# Imported when first run: an arena experiment does not load SUMO.
EXPERIMENTS = Registry("experiment", {
    "fig7": "enn_traffic.experiments.navigation:fig7",
    "fig8": "enn_traffic.experiments.navigation:fig8",
    "fig9": "enn_traffic.experiments.navigation:fig9",
    "generalization": "enn_traffic.experiments.navigation:generalization",
    "fig11": "enn_traffic.experiments.fig11:fig11",
    "table1": "enn_traffic.experiments.table1:table1",
    "table2": "enn_traffic.experiments.table2:table2",
    "table3": "enn_traffic.experiments.crowds.arena:table3",
    "table4": "enn_traffic.experiments.crowds.arena:table4",
    "table4_ablation": "enn_traffic.experiments.ablation:table4_ablation",
    "regime": "enn_traffic.experiments.regime:regime",
    "departures": "enn_traffic.experiments.departures:departures",
    "authors_rules": "enn_traffic.experiments.authors_rules:authors_rules",
    "sumo": "enn_traffic.experiments.sumo_family:sumo",
    "city": "enn_traffic.experiments.sumo_family:city",
    "sumo_ablation": "enn_traffic.experiments.ablation_sumo:table4_ablation_sumo",
    "lane_keeping": "enn_traffic.experiments.lanekeeping:lane_keeping",
})


# Each experiment's summary.md lines, from the tables it wrote: the function named as the
# experiment's with ``_lines`` (``fig7`` -> ``fig7_lines``), so a changed table changes its line.
SUMMARY_LINES = Registry("summary lines", {name: f"{EXPERIMENTS.target(name)}_lines"
                                           for name in EXPERIMENTS})


def summary_lines(name: str, study: Study) -> list[str]:
    """Experiment ``name``'s lines of ``summary.md``, from the tables it wrote into the
    study's folder (:data:`SUMMARY_LINES`)."""
    return SUMMARY_LINES[name](study)
