"""Every kind of world a scenario can describe is a :class:`World`, with outcomes named for
what happened."""

import pytest

from enn_traffic.config import load_scenario
from enn_traffic.sim.world import OUTCOMES, World, make_world


@pytest.mark.parametrize("name, kind", [("navigation_narrow", "ArenaWorld"),
                                        ("arena_strategy1", "ArenaWorld"),
                                        ("sumo_strategy1", "SumoWorld"),
                                        ("lane_keeping", "LaneKeepingWorld")])
def test_every_scenario_gives_a_world(root, name, kind):
    world = make_world(load_scenario(root / "scenarios" / f"{name}.toml"))
    assert type(world).__name__ == kind
    assert isinstance(world, World)
    assert world.track.name and world.track.walls.ndim == 2 and world.track.walls.shape[1] == 4
    # one label per situation a chromosome is driven in, and an evaluation reports each
    scenario = world.scenario
    if kind == "LaneKeepingWorld":
        count = scenario.lane_keeping.episodes
    elif kind == "SumoWorld":
        count = scenario.traffic.episodes
    else:
        count = scenario.traffic.episodes * len(scenario.traffic.strategy_list)
        assert world.vehicles == 1 + len(scenario.traffic.starts_xy)
    assert len(world.situation_labels()) == count
    hidden, outputs = scenario.network.hidden, 2
    inputs = world.spec.layer_sizes[0]
    assert world.spec.chromosome_length == (inputs + 1) * hidden[0] + (hidden[0] + 1) * outputs


def test_a_world_of_several_tracks_names_and_draws_its_first(root):
    world = make_world(load_scenario(root / "scenarios" / "navigation_mixed.toml"))
    assert isinstance(world, World) and type(world).__name__ == "TracksWorld"
    assert world.track is world.worlds[0].track
    assert world.situation_labels()[0].startswith(f"{world.track.name}: ")


def test_outcome_names_are_distinct():
    assert len(set(OUTCOMES.values())) == len(OUTCOMES)
    assert OUTCOMES[4] == "left lane" and OUTCOMES[1] == "collision"
