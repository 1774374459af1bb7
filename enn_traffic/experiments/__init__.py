"""One module per paper experiment; each writes its tables and figures into the reproduce folder.

``EXPERIMENTS`` maps the names that ``enn-traffic reproduce --only`` takes to functions
``(out: Path, quick: bool, progress: bool) -> list[str]`` that return summary lines.
"""

from enn_traffic.experiments import dynamic, lanekeeping, navigation, simultaneous

EXPERIMENTS = {
    "fig7": navigation.fig7,
    "fig8": navigation.fig8,
    "fig9": navigation.fig9,
    "generalization": navigation.generalization,
    "fig11": dynamic.fig11,
    "table1": dynamic.table1,
    "table2": dynamic.table2,
    "table3": simultaneous.table3,
    "table4": simultaneous.table4,
    "sumo": dynamic.sumo,
    "lane_keeping": lanekeeping.lane_keeping,
}
