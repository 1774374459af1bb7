"""The SUMO crowd as a PettingZoo ParallelEnv, through the real libsumo: PettingZoo's API
test, seeding, and the same trajectories as the SUMO crowd of the GA
(:class:`~enn_traffic.sim.sumo.crowd.SumoCrowd`) for the same actions."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.envs import parallel_env
from enn_traffic.envs.rangefinder import action_of
from enn_traffic.envs.sumo import SumoCrowdEnv
from enn_traffic.sim.sumo.crowd import SumoCrowd


@pytest.fixture
def env():
    env = SumoCrowdEnv(shipped_scenario("sumo_strategy1"), learners=3,
                       observation_dtype="float64")  # the crowd's readings, unrounded
    yield env
    env.close()


def test_the_sumo_crowd_passes_pettingzoos_parallel_api_test(env):
    """Random steering ends lives within the test's cycles: the leavers go out of SUMO and
    SUMO steps on without them."""
    parallel_api_test(env, num_cycles=200)
    first, _ = env.reset(seed=4)
    first = {agent: observation.copy() for agent, observation in first.items()}
    again, _ = env.reset(seed=4)
    assert list(first) == env.possible_agents == ["vehicle_0", "vehicle_1", "vehicle_2"]
    for agent in first:
        np.testing.assert_array_equal(first[agent], again[agent])


def test_every_agent_ends_and_leaves_sumo(env):
    env.reset(seed=2)
    rng = np.random.default_rng(0)
    ended = {}
    while env.agents:
        _, _, terminated, truncated, infos = env.step(
            {agent: rng.uniform(0, 1, 2) for agent in env.agents})
        ended |= {agent: infos[agent] for agent in terminated
                  if terminated[agent] or truncated[agent]}
    assert sorted(ended) == env.possible_agents
    assert not env.crowd.lives.learners.active.any()
    assert all(info["steps"] >= 1 for info in ended.values())


class Lives:
    """A crowd's learning that keeps one chromosome and records every life that ends."""

    life_cap = 0  # no cap: a life ends only by a collision, a spin or an exit

    def __init__(self, genes):
        self.genes, self.ended = genes, []

    def learns(self, vehicle):
        return True

    def current(self, vehicle):
        return self.genes

    def life_ended(self, vehicle, steps, unseen_steps, spun):
        self.ended.append((vehicle, steps, spun))
        return self.genes

    def still_driving(self, vehicle, unseen_steps, life_steps):
        pass


def test_learners_driven_by_actions_move_as_the_crowds_networks_do(env):
    """Until the first learner's life ends every learner follows the SUMO crowd's
    trajectory, and that life ends at the same step, the same way."""
    world, key, situation = env.world, keys.VALIDATION.start + 1, 0
    chromosome = np.random.default_rng(3).uniform(-1, 1, world.spec.chromosome_length)
    genes = world.spec.in_source_layout(chromosome[None])[0]
    lives = Lives(genes)
    with SumoCrowd(world, world.seeds(key)[situation]) as crowd:
        run = crowd.run(10.0, np.tile(genes, (crowd.count, 1)), lives)
    vehicle, life, spun = lives.ended[0]

    observations, _ = env.reset(options={"key": key, "situation": situation})
    for t in range(1, life + 1):
        np.testing.assert_array_equal(env.crowd.lives.pose, run.trace[t - 1])
        actions = {agent: action_of(world.spec.forward(chromosome, observation)[0])
                   for agent, observation in observations.items()}
        observations, _, terminated, _, infos = env.step(actions)
        ended = [agent for agent, done in terminated.items() if done]
        assert ended == ([] if t < life else [f"vehicle_{vehicle}"])
    assert infos[ended[0]]["steps"] == life
    assert infos[ended[0]]["outcome"] == ("spin" if spun else "collision")
    assert ended[0] not in env.agents


def test_parallel_env_gives_the_sumo_crowd_for_a_sumo_scenario():
    env = parallel_env(shipped_scenario("sumo_strategy2"), learners=2)
    try:
        assert isinstance(env, SumoCrowdEnv) and len(env.possible_agents) == 2
    finally:
        env.close()
    with pytest.raises(ValueError, match="learners must be from 1 to 3,000, not 0"):
        SumoCrowdEnv(shipped_scenario("sumo_strategy1"), learners=0)


def test_two_sumo_crowds_in_one_process_pass_pettingzoos_seed_test():
    """libsumo runs one SUMO per process: the second crowd runs its own in a child process,
    and the two give the same run for the same seed."""
    made = []

    def make():
        made.append(SumoCrowdEnv(shipped_scenario("sumo_strategy1"), learners=2))
        return made[-1]

    parallel_seed_test(make, num_cycles=60)
    first, second = made
    assert first._child is None and second._child is not None
    observations, _ = second.reset(seed=5)  # the child's crowd, reset again
    assert sorted(observations) == ["vehicle_0", "vehicle_1"]
    second.close()


def test_learners_read_the_closing_speed_of_sumos_vehicles_and_of_each_other():
    """With ``[sensor] channels`` = distance and closing speed, six learners among SUMO's
    traffic read the plain scenario's distances bit for bit, then closing speeds: 0 where a
    beam meets nothing, the learner's own speed along the beam where it meets a wall, and
    other values where it meets a moving SUMO vehicle or learner (the motion of both groups
    of bodies reaches the channel), within what a car's speed allows. (One crowd at a time:
    libsumo runs one SUMO per process.)"""
    plain = shipped_scenario("sumo_strategy1")
    both = plain.with_overrides(sensor={"channels": ["distance", "closing_speed"]})
    beams, reach = plain.sensor.beams, plain.sensor.range
    along = plain.vehicle.speed * np.cos(np.array(plain.beam_angles))
    runs = []
    for scenario in (plain, both):
        crowd = SumoCrowdEnv(scenario, learners=6, observation_dtype="float64")
        try:
            observations, _ = crowd.reset(options={"key": 0, "situation": 0})
            run = [observations]
            for _ in range(40):
                observations, *_ = crowd.step({agent: np.zeros(2, np.float32)
                                               for agent in crowd.agents})
                run.append(observations)
            runs.append(run)
        finally:
            crowd.close()
    moving = 0
    for first, second in zip(*runs, strict=True):
        assert first.keys() == second.keys()
        for agent, distances in first.items():
            np.testing.assert_array_equal(second[agent][:beams], distances)
            closing = second[agent][beams:]
            assert np.all(closing[distances >= reach] == 0.0)
            other = np.abs(closing - along)[distances < reach]
            assert np.all(other < 60.0)
            moving += int((other > 0.5).sum())
    assert moving > 10, moving


def test_a_learner_count_given_as_an_argument_is_checked_as_the_files_key_is():
    """``learners`` beyond the schema's cap, or more than the ring's lanes take at the
    respawn clearance, is refused at once, naming the argument, before SUMO starts."""
    from enn_traffic.config import MAX_LEARNERS
    from enn_traffic.core.errors import InputError
    from enn_traffic.sumo.simulation import Simulation

    scenario = shipped_scenario("sumo_strategy1")
    with pytest.raises(ValueError, match=f"learners must be from 1 to {MAX_LEARNERS:,}"):
        SumoCrowdEnv(scenario, learners=MAX_LEARNERS + 1)
    with pytest.raises(InputError, match="^learners: 2000 learners do not fit"):
        SumoCrowdEnv(scenario, learners=2000)
    assert Simulation.running is None
