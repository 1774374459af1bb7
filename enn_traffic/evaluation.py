"""Run a saved controller on any scenario and report lifetimes (``enn-traffic evaluate``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.controller import Controller
from enn_traffic.scenario import Scenario
from enn_traffic.sim.world import OUTCOMES, NavigationWorld


def evaluate_controller(
    controller: Controller, scenario: Scenario, episodes: int = 1
) -> pd.DataFrame:
    """One row per episode: lifetime in steps and seconds, distance driven, how it ended.

    Navigation scenarios are deterministic, so their episodes repeat one another; scenarios
    with traffic draw a new traffic seed per episode.
    """
    world = NavigationWorld(controller.fit(scenario))
    population = np.repeat(controller.chromosome[None, :], episodes, axis=0)
    results = world.evaluate(population)
    vehicle = scenario.vehicle
    return pd.DataFrame({
        "scenario": scenario.name,
        "track": world.track.name,
        "episode": np.arange(episodes),
        "lifetime_steps": results.steps,
        "lifetime_s": results.steps * vehicle.dt,
        "distance_m": results.steps * vehicle.speed * vehicle.dt,
        "fitness": results.fitness,
        "outcome": [OUTCOMES[int(code)] for code in results.outcome],
        "capped": results.outcome == 0,
    })  # fmt: skip


def controller_trace(controller: Controller, scenario: Scenario, max_steps: int | None = None):
    """The world and the poses of one episode of ``controller`` on ``scenario``."""
    world = NavigationWorld(controller.fit(scenario))
    poses, outcome = world.trace(controller.chromosome, max_steps)
    return world, poses, outcome


def render(
    controller: Controller, scenario: Scenario, out: str | Path, max_steps: int | None = None
) -> dict:
    """Draw the controller's path on the track (PNG) or animate it (GIF)."""
    from enn_traffic.report.animate import animate_run
    from enn_traffic.report.plots import trajectories

    world, poses, outcome = controller_trace(controller, scenario, max_steps)
    out = Path(out)
    title = f"{scenario.name}: {len(poses) - 1} steps, {OUTCOMES[outcome]}"
    if out.suffix.lower() == ".gif":
        animate_run(world, poses, out, title)
    else:
        trajectories(world.track.walls, [poses], out, title=title, start=world.start)
    return {"steps": len(poses) - 1, "outcome": OUTCOMES[outcome], "file": str(out)}
