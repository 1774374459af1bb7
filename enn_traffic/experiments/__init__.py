"""One module per paper experiment; each writes its tables and figures into the reproduce folder.

``EXPERIMENTS`` maps the names that ``enn-traffic reproduce --only`` takes to functions
``(study: Study) -> list[str]`` that return summary lines
(:class:`~enn_traffic.experiments.study.Study`: the folder, the settings, the executor and
what experiments compute once and share). The
dynamic-traffic experiments share their protocol (:mod:`~enn_traffic.experiments.protocol`) and
the statistics of choosing controllers (:mod:`~enn_traffic.experiments.choosing`).
"""

from enn_traffic.experiments import (
    fig11,
    lanekeeping,
    navigation,
    regime,
    simultaneous,
    sumo_family,
    table1,
    table2,
)

EXPERIMENTS = {
    "fig7": navigation.fig7,
    "fig8": navigation.fig8,
    "fig9": navigation.fig9,
    "generalization": navigation.generalization,
    "fig11": fig11.fig11,
    "table1": table1.table1,
    "table2": table2.table2,
    "table3": simultaneous.table3,
    "table4": simultaneous.table4,
    "regime": regime.regime,
    "sumo": sumo_family.sumo,
    "city": sumo_family.city,
    "lane_keeping": lanekeeping.lane_keeping,
}
