"""Run a saved controller on any scenario and report lifetimes (``enn-traffic evaluate``)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from enn_traffic.controller import Controller
from enn_traffic.scenario import Scenario
from enn_traffic.sim import make_world
from enn_traffic.sim.world import (
    CAPPED,
    HELD_OUT_KEYS,
    MET_NEAR_MAX,
    MET_NEAR_STEPS,
    MET_START,
    OUTCOMES,
    EpisodeResults,
)

# Evaluation episodes draw held-out traffic, so a controller is never deployed on the traffic
# it was trained on, whether its training drew new traffic every generation or kept one set.
EVALUATION_KEY = HELD_OUT_KEYS
MAX_LABELLED = 9  # vehicles drawn with a legend entry each


def evaluate_controller(controller: Controller, scenario: Scenario, episodes: int = 1
                        ) -> pd.DataFrame:
    """One row per traffic strategy and episode: lifetime in steps and seconds, distance, how
    it ended, and the collisions the controller suffered without causing them.

    Episodes draw their traffic from the evaluation stream, never from training's; scenarios
    without traffic are deterministic, so their episodes repeat one another.
    """
    world = make_world(evaluation_scenario(controller, scenario, episodes))
    vehicle = scenario.vehicle
    results = world.evaluate(controller.chromosome[None, :], EVALUATION_KEY)
    steps, outcome = results.steps[0], results.outcome[0]
    fitness = EpisodeResults.lifetime_fitness(steps, outcome)
    traffic = results.traffic[0]
    rows = []
    for column, strategy in enumerate(world.episode_labels()):
        rows.append({
            "scenario": scenario.name,
            "track": world.track.name,
            "strategy": strategy,
            "episode": column % episodes,
            "lifetime_steps": int(steps[column]),
            "lifetime_s": steps[column] * vehicle.dt,
            "distance_m": steps[column] * vehicle.speed * vehicle.dt,
            "fitness": fitness[column],
            "outcome": OUTCOMES[int(outcome[column])],
            "capped": bool(outcome[column] == CAPPED),
            "suffered_collisions": int(results.suffered[0, column]),
            "traffic_at_start": int(traffic[column, MET_START]),
            "traffic_near_mean": traffic[column, MET_NEAR_STEPS] / (steps[column] + 1),
            "traffic_near_max": int(traffic[column, MET_NEAR_MAX]),
        })  # fmt: skip
    return pd.DataFrame(rows)


def evaluation_scenario(controller: Controller, scenario: Scenario, episodes: int) -> Scenario:
    """``scenario`` fitted to the controller, with ``episodes`` traffic situations."""
    return controller.fit(scenario).with_overrides(traffic={"episodes": episodes})


def controller_trace(
    controller: Controller, scenario: Scenario, max_steps: int | None = None, episode: int = 0
):
    """The world, every vehicle's poses (n, V, 3) in one episode, and the learner's outcome."""
    world = make_world(evaluation_scenario(controller, scenario, episode + 1))
    poses, outcome = world.trace(
        controller.chromosome, EVALUATION_KEY, episode, max_steps=max_steps
    )
    return world, poses, outcome


def render(
    controller: Controller, scenario: Scenario, out: str | Path, max_steps: int | None = None
) -> dict:
    """Draw the controller's path on the track (PNG) or animate it (GIF)."""
    from enn_traffic.report.animate import animate_run
    from enn_traffic.report.plots import trajectories

    world, poses, outcome = controller_trace(controller, scenario, max_steps)
    out = Path(out)
    steps = len(poses) - 1
    title = f"{scenario.name}: {steps} steps, {OUTCOMES[outcome]}"
    if out.suffix.lower() == ".gif":
        animate_run(world, poses, out, title)
    else:
        paths = [poses[:, v] for v in range(poses.shape[1])]
        labels, colors = ["learner"] + [f"vehicle {v}" for v in range(1, len(paths))], None
        if len(paths) > MAX_LABELLED:  # SUMO traffic: the learner in red among grey traffic
            labels = ["learner", "traffic"] + [None] * (len(paths) - 2)
            colors = ["C3"] + ["0.6"] * (len(paths) - 1)
        trajectories(world.track.walls, paths, out, title=title, start=world.start,
                     labels=labels if len(paths) > 1 else None, colors=colors)
    return {"steps": steps, "outcome": OUTCOMES[outcome], "file": str(out)}

