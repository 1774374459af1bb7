"""The arena crowd as a PettingZoo ParallelEnv: PettingZoo's API test, seeding, and the same
trajectories as the crowd of paper §5.5 (:class:`~enn_traffic.sim.crowd.Crowd`) for the same
actions."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.envs.crowd import ArenaCrowdEnv
from enn_traffic.envs.rangefinder import action_of
from enn_traffic.sim.crowd import Crowd
from enn_traffic.sim.strategies import NETWORK


def test_the_arena_crowd_passes_pettingzoos_parallel_api_test():
    env = ArenaCrowdEnv(shipped_scenario("arena_strategy1"), render_mode="rgb_array")
    parallel_api_test(env, num_cycles=300)
    first, _ = env.reset(seed=4)
    again, _ = env.reset(seed=4)
    assert list(first) == env.possible_agents == [f"vehicle_{v}" for v in range(8)]
    for agent in first:
        np.testing.assert_array_equal(first[agent], again[agent])
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3


class Lives:
    """A crowd's learning that keeps one chromosome and records every life that ends."""

    life_cap = 0  # no cap: a life ends only by a collision, a spin or an exit

    def __init__(self, learners, genes):
        self.learners, self.genes, self.ended = learners, genes, []

    def learns(self, vehicle):
        return vehicle < self.learners

    def current(self, vehicle):
        return self.genes

    def life_ended(self, vehicle, steps, unseen_steps, spun):
        self.ended.append((vehicle, steps, spun))
        return self.genes

    def still_driving(self, vehicle, unseen_steps, life_steps):
        pass


@pytest.mark.parametrize("name", ["arena_strategy2", "arena_strategy3"])
def test_learners_driven_by_actions_move_as_the_crowds_networks_do(name):
    """Until the first learner's life ends (the env then takes its body away, the crowd
    respawns it) every vehicle follows the crowd's trajectory, and that life ends at the
    same step, the same way."""
    learners = 4
    env = ArenaCrowdEnv(shipped_scenario(name), learners=learners, observation_dtype="float64")
    world, key, situation = env.world, keys.VALIDATION.start + 2, 1
    chromosome = np.random.default_rng(7).uniform(-1, 1, world.spec.chromosome_length)
    episode = world.situations(key)[situation]
    kinds = np.asarray(episode.kinds).copy()
    kinds[:learners] = NETWORK
    genes = episode.traffic_genes.copy()
    genes[:learners] = world.spec.in_source_layout(chromosome[None])[0]
    lives = Lives(learners, genes[0])
    run = Crowd(world, episode.start, kinds, int(episode.seed)).run(20.0, genes, lives)
    vehicle, life, spun = next(ended for ended in lives.ended if ended[1] > 0)  # the first

    observations, _ = env.reset(options={"key": key, "situation": situation})
    for t in range(1, life + 1):
        np.testing.assert_array_equal(env.crowd.pose, run.trace[t - 1])
        actions = {agent: action_of(world.spec.forward(chromosome, observation)[0])
                   for agent, observation in observations.items()}
        observations, rewards, terminated, _, infos = env.step(actions)
        ended = [agent for agent, done in terminated.items() if done]
        assert ended == ([] if t < life else [f"vehicle_{vehicle}"])
    assert infos[ended[0]]["steps"] == life
    assert infos[ended[0]]["outcome"] == ("spin" if spun else "collision")
    assert ended[0] not in env.agents and len(env.crowd.pose) == len(kinds) - 1


def test_a_crowd_of_more_learners_than_vehicles_is_refused():
    with pytest.raises(ValueError, match="learners must be 1 to 8"):
        ArenaCrowdEnv(shipped_scenario("arena_strategy1"), learners=9)
