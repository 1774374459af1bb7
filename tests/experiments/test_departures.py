"""The crowds' last departures from the authors' rules, each measured against ours (issue 61)."""

import numpy as np
import pandas as pd
import pytest

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments.ablation import AuthorsRules, start_poses
from enn_traffic.experiments.departures import MEASURES, VARIANTS, departures_table
from enn_traffic.experiments.families import ARENA
from enn_traffic.sim.arena import ArenaWorld


def test_vehicle_0s_drawn_heading_is_the_only_change_to_the_start_poses():
    world = ArenaWorld(shipped_scenario(ARENA.name(1)))

    def poses(key: int, drawn: bool) -> np.ndarray:
        return start_poses(world, world.situations(key)[0], key,
                           AuthorsRules(vehicle0_heading_drawn=drawn))

    ours, drawn = poses(123, False), poses(123, True)
    assert ours[0, 2] == pytest.approx(np.pi / 2)
    low, high = np.radians(world.scenario.traffic.start_heading_deg)
    assert low <= drawn[0, 2] <= high and drawn[0, 2] != ours[0, 2]
    np.testing.assert_array_equal(drawn[0, :2], ours[0, :2])
    np.testing.assert_array_equal(drawn[1:], ours[1:])
    again = poses(124, True)
    assert again[0, 2] != drawn[0, 2]  # drawn per situation


def test_each_departure_is_paired_with_ours_situation_by_situation():
    """The authors' blame adds 0.01 in every situation of every measure: its differences are
    0.01 with an interval of width 0; the other variants equal ours (0, spanning nothing).
    Breeding has no initial-drivers row."""
    rng = np.random.default_rng(0)
    base = {measure: rng.uniform(0, 0.1, 6) for measure in MEASURES}
    rows = []
    for name in VARIANTS:
        shift = 0.01 if name == "blame after a respawn" else 0.0
        rows += [{"situation": s, "variant": name}
                 | {measure: base[measure][s] + shift for measure in MEASURES}
                 for s in range(6)]
    table = departures_table(pd.DataFrame(rows))
    assert len(table) == 4 * len(MEASURES) - 1
    breeding = table[table["departure"] == "breeding from the best 180"]
    assert "initial_first" not in set(breeding["measure"])
    blame = table[table["departure"] == "blame after a respawn"]
    assert blame["difference"].tolist() == pytest.approx([0.01] * len(MEASURES))
    assert (blame["difference_low"] == blame["difference"]).all()
    others = table[table["departure"] != "blame after a respawn"]
    assert (others[["difference", "difference_low", "difference_high"]] == 0).all().all()
