import numpy as np
import pytest

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError

GOOD = """
name = "t"
[track]
net = "{net}"
start_xy = [0.0, 0.0]
start_heading_deg = 90.0
"""


@pytest.fixture
def net(root):
    return root / "sumo_nets" / "track_narrow.net.xml"


def load_text(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return load_scenario(path)


def test_shipped_scenarios_load(root):
    for path in sorted((root / "scenarios").glob("*.toml")):
        scenario = load_scenario(path)
        assert scenario.lane_keeping is not None or scenario.tracks, path
        assert all(track.net.is_file() for track in scenario.tracks), path


def test_defaults_are_the_papers(tmp_path, net):
    scenario = load_text(tmp_path, GOOD.format(net=net))
    assert scenario.ga.population_size == 200 and scenario.ga.tournament_size == 10
    assert scenario.ga.mutation_probability == 0.1 and scenario.ga.crossover_cut_mean == 0.95
    assert scenario.layer_sizes == (19, 3, 2)
    angles = scenario.beam_angles
    assert angles[0] == pytest.approx(-1.5707963) and angles[-1] == pytest.approx(1.5707963)
    assert angles[9] == pytest.approx(0.0)


def test_one_beam_looks_straight_ahead(tmp_path, net):
    scenario = load_text(tmp_path, GOOD.format(net=net) + "[sensor]\nbeams = 1\n")
    assert scenario.beam_angles == [0.0]


def test_network_path_resolves_relative_to_the_scenario_file(tmp_path, net):
    (tmp_path / "nets").mkdir()
    (tmp_path / "nets" / "n.net.xml").write_bytes(net.read_bytes())
    scenario = load_text(tmp_path, GOOD.format(net="nets/n.net.xml"))
    assert scenario.track.net == (tmp_path / "nets" / "n.net.xml").resolve()


@pytest.mark.parametrize(
    "extra, key, message",
    [
        ("[ga]\npopulation_size = 0\n", "ga.population_size", "greater than or equal to 2"),
        ("[ga]\npopulation_sise = 10\n", "ga.population_sise", "unknown key"),
        ("[sensor]\nbeams = 'many'\n", "sensor.beams", "integer"),
        ("[ga]\nmutation_probability = 1.5\n", "ga.mutation_probability", "less than or equal"),
        ("[vehicle]\nspeed = -1\n", "vehicle.speed", "greater than or equal to 0.1"),
        ("[ga]\nelite_count = 500\n", "ga.elite_count", "smaller than population_size"),
        ("colour = 'red'\n", "track.colour", "unknown key"),
        ("[crowd]\ncounting = 'both'\n", "crowd.counting", "'responsible' or 'lives_lost'"),
        # a value no member of a union takes: the key as written, one problem, the choices
        ("[traffic]\nstrategy = 'sumoo'\n", "traffic.strategy", "'wander' or 'sumo'"),
        # a list with an unknown item: that item, not the single value the union also takes
        ("[traffic]\nstrategy = ['SUMO', 'wander']\n", "traffic.strategy[0]", "or 'sumo'"),
    ],
)
def test_bad_values_name_file_and_key(tmp_path, net, extra, key, message):
    with pytest.raises(InputError) as info:
        load_text(tmp_path, GOOD.format(net=net) + extra)
    assert info.value.key == key
    assert message in info.value.message and "more problems" not in info.value.message
    assert str(info.value).startswith(str(tmp_path / "s.toml"))


@pytest.mark.parametrize("nesting", ["[" * 100_000 + "]" * 100_000,
                                     "{a = " * 100_000 + "1" + "}" * 100_000],
                         ids=["lists", "inline tables"])
def test_a_scenario_nested_without_end_is_refused_at_once(tmp_path, nesting):
    """Lists or inline tables nested 100,000 deep (tomllib recurses per level) are refused in
    one line naming the file, within a second, not a RecursionError traceback."""
    import time

    started = time.perf_counter()
    with pytest.raises(InputError, match="nested too deeply") as info:
        load_text(tmp_path, f'name = "deep"\nfoo = {nesting}\n')
    assert info.value.file.endswith(".toml") and time.perf_counter() - started < 1.0


def test_missing_network_file(tmp_path):
    with pytest.raises(InputError, match="network file not found") as info:
        load_text(tmp_path, GOOD.format(net="nowhere.net.xml"))
    assert info.value.key == "track.net"


def test_missing_required_key_and_broken_toml(tmp_path):
    with pytest.raises(InputError, match="required key is missing") as info:
        load_text(tmp_path, 'name = "x"\n')
    assert info.value.key == "track"
    with pytest.raises(InputError, match="not valid TOML"):
        load_text(tmp_path, "name = \n")


def test_start_off_the_road_is_refused(tmp_path, net):
    from enn_traffic.sim.arena import ArenaWorld

    scenario = load_text(tmp_path, GOOD.format(net=net).replace("[0.0, 0.0]", "[500.0, 0.0]"))
    with pytest.raises(InputError, match="off the drivable area") as info:
        ArenaWorld(scenario)
    assert info.value.key == "track.start_xy"


TWO_TRACKS = """
name = "t"
[[track]]
net = "{net}"
start_xy = [0.0, 0.0]
start_heading_deg = 90.0
[[track]]
net = "{second_net}"
{second}
"""


def test_several_tracks_each_with_its_own_traffic_keys(tmp_path, net):
    (tmp_path / "nets").mkdir()
    (tmp_path / "nets" / "n.net.xml").write_bytes(net.read_bytes())
    text = TWO_TRACKS.format(net="nets/n.net.xml", second_net="nets/n.net.xml",
                             second="start_xy = [-2.0, 100.0]\n[track.traffic]\n"
                             "starts_xy = [[1, 2]]")
    scenario = load_text(tmp_path, text + "[traffic]\nstrategy = 'straight'\nseed = 7\n")
    assert len(scenario.tracks) == 2
    assert all(t.net == (tmp_path / "nets" / "n.net.xml").resolve() for t in scenario.tracks)
    first, second = scenario.on_track(0), scenario.on_track(1)
    assert first.track.start_xy == (0.0, 0.0) and first.traffic.starts_xy == []
    assert second.track.start_xy == (-2.0, 100.0) and second.traffic.starts_xy == [(1.0, 2.0)]
    assert second.traffic.seed == 7 and second.traffic.strategy == "straight"
    again = load_text(tmp_path, scenario.to_toml())  # what a run folder keeps loads again
    assert again.on_track(1).traffic.starts_xy == [(1.0, 2.0)]


@pytest.mark.parametrize(
    "second, key, message",
    [
        ("", "track[1]", "give exactly one of start_xy"),
        ("start_xy = [-2.0, 100.0]\nlanes = 2", "track[1].lanes", "unknown key"),
        ("start_xy = [-2.0, 100.0]\n[track.traffic]\nstarts = []", "track[1].traffic.starts",
         "unknown key"),
        ("start_xy = [-2.0, 100.0]\n[track.traffic]\nroutes = ['none.rou.xml']",
         "track[1].traffic", 'routes and sumocfg are for strategy = "sumo"'),
        ("start_xy = [-2.0, 100.0]\nfringe = 'exit'", "track[1].fringe", "needs SUMO traffic"),
    ],
)
def test_a_bad_track_among_several_is_named(tmp_path, net, second, key, message):
    with pytest.raises(InputError) as info:
        load_text(tmp_path, TWO_TRACKS.format(net=net, second_net=net, second=second))
    assert info.value.key == key
    assert message in info.value.message


def test_a_missing_network_of_a_second_track_is_named(tmp_path, net):
    text = TWO_TRACKS.format(net=net, second_net="gone.net.xml", second="start_xy = [-2.0, 100.0]")
    with pytest.raises(InputError) as info:
        load_text(tmp_path, text)
    assert info.value.key == "track[1].net" and "network file not found" in info.value.message


def test_traffic_keys_of_a_single_track_belong_in_traffic(tmp_path, net):
    with pytest.raises(InputError) as info:
        load_text(tmp_path, GOOD.format(net=net) + "[track.traffic]\nseed = 3\n")
    assert info.value.key == "track.traffic" and "[traffic]" in info.value.message


@pytest.mark.parametrize("hidden", [[], [2], [8, 8], [5, 4, 3]])
@pytest.mark.parametrize("base", ["navigation_narrow", "arena_strategy2"])
def test_every_network_shape_the_schema_accepts_runs(root, base, hidden):
    """``hidden = [8, 8]`` crashed every run of navigation_narrow: the arena put its (unused)
    random-network traffic, 19-3-2, inside the learner's network, where it does not fit. On
    arena_strategy2 (straight-driving traffic) the same shapes run among traffic."""
    from enn_traffic.sim.world import make_world

    scenario = load_scenario(root / "scenarios" / f"{base}.toml").with_overrides(
        network={"hidden": hidden}, episode={"max_steps": 200})
    world = make_world(scenario)
    population = np.random.default_rng(0).uniform(-1, 1, (6, world.spec.chromosome_length))
    fitness = world.evaluate(population).fitness
    assert fitness.shape == (6,) and (fitness > 0).any()


def test_random_network_traffic_that_does_not_fit_is_refused(root):
    with pytest.raises(InputError, match="traffic.network_hidden"):
        load_scenario(root / "scenarios" / "arena_strategy1.toml").with_overrides(
            network={"hidden": [2]})


def test_every_scenario_key_is_described():
    """docs/scenarios.md is written from the schema's descriptions: none may be missing."""
    from typing import get_args

    from pydantic import BaseModel

    from enn_traffic.config import Scenario

    def models(annotation) -> list[type[BaseModel]]:
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            return [annotation]
        return [model for argument in get_args(annotation) for model in models(argument)]

    def missing(model: type[BaseModel], prefix: str) -> list[str]:
        found = []
        for name, field in model.model_fields.items():
            if field.exclude:
                continue
            sections = models(field.annotation)
            if field.description is None and not sections:
                found.append(prefix + name)
            for section in sections[:1]:
                found += missing(section, f"{prefix}{name}.")
        return found

    assert missing(Scenario, "") == []
