"""SUMO scenarios as a gymnasium environment: the same lives as the GA's SUMO world (replay
and closed loop) for the same actions, and one live SUMO per process."""

import pytest

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import keys
from enn_traffic.envs.rangefinder import action_of
from enn_traffic.envs.sumo import SumoEnv
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.world import OUTCOMES


@pytest.mark.parametrize("mode", ["replay", "closed-loop"])
def test_a_saved_controller_lives_as_long_in_the_env_as_in_the_sumo_world(root, mode):
    controller = Controller.load(root / "results/paper/controllers/sumo/table1/strategy1.npz")
    scenario = controller.fit(shipped_scenario("sumo_strategy1"))
    scenario = scenario.model_copy(update={
        "traffic": scenario.traffic.model_copy(update={"mode": mode})})
    env = SumoEnv(scenario, observation_dtype="float64")  # the GA's readings, unrounded
    world, key = env.world, keys.VALIDATION.start
    expected = world.evaluate(controller.chromosome[None], key)
    for situation in range(expected.steps.shape[1]):
        observation, _ = env.reset(options={"key": key, "situation": situation})
        total = 0.0
        while True:
            action = action_of(world.spec.forward(controller.chromosome, observation)[0])
            observation, reward, terminated, truncated, info = env.step(action)
            total += reward
            if terminated or truncated:
                break
        assert info["steps"] == expected.steps[0, situation] > 500
        assert info["outcome"] == OUTCOMES[expected.outcome[0, situation]]
        assert info["suffered"] == expected.suffered[0, situation]
        assert total == info["fitness"] == (0 if info["outcome"] == "spin" else info["steps"])
    env.close()


def test_a_second_live_sumo_in_one_process_is_refused_clearly():
    scenario = shipped_scenario("sumo_strategy1")
    scenario = scenario.model_copy(update={
        "traffic": scenario.traffic.model_copy(update={"mode": "closed-loop"})})
    first, second = SumoEnv(scenario), SumoEnv(scenario)
    first.reset(seed=0)
    try:
        with pytest.raises(RuntimeError, match="already running"):
            second.reset(seed=0)
    finally:
        first.close()
    second.reset(seed=0)  # the first one closed: room again
    second.close()
