"""The arena crowd (paper §5.5) as a PettingZoo ``ParallelEnv``: several learners in one arena,
one agent per learning vehicle (docs/envs.md, "Several learners at once").

The world is :class:`~enn_traffic.sim.crowd.Crowd`'s, stepped by its own step
(:func:`~enn_traffic.sim.crowd.step`), with the learners' steering given as actions: the first
``learners`` vehicles of a situation are the agents ``vehicle_0``, ``vehicle_1``, ..., the
others drive the scenario's strategy. Observation, action and reward are the single
environment's (:mod:`enn_traffic.envs.rangefinder`): an agent's return is the paper's fitness
of its life.

A learner responsible for a collision, or spinning in place, is terminated and leaves the
arena (its body with it: PettingZoo's agents are not revived); a scripted vehicle responsible
for a collision respawns at a free spot, as in the crowd. All agents are truncated at the
scenario's ``episode.max_steps``. At reset, a vehicle whose start pose is taken (the blame
rule at step 0) respawns before the agents' first step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from gymnasium.error import ResetNeeded
from numba import njit
from pettingzoo import ParallelEnv

from enn_traffic.config import Scenario
from enn_traffic.config.traffic import ACTION
from enn_traffic.envs.batch import compiled
from enn_traffic.envs.rangefinder import (
    TRAINING_KEYS,
    checked_actions,
    checked_options,
    checked_render_mode,
    observation_of,
    picture,
    rangefinder_world,
    spaces_of,
    steering_of,
)
from enn_traffic.sim.crowd import ALIVE, Crowd, crowd_events, step_once
from enn_traffic.sim.readings import reading_count, seen_for
from enn_traffic.sim.rules import wall_arrays
from enn_traffic.sim.sensors import sense
from enn_traffic.sim.world import OUTCOMES, SPUN


@njit(cache=True)
def observe(learners, vehicles, physics, geometry, out) -> None:
    """The first ``learners`` vehicles sense walls and the other bodies into ``out`` (L, B)."""
    pose = vehicles.pose
    walls, cell_start, cell_walls, all_walls = wall_arrays(geometry)
    seen = seen_for(geometry.beams, geometry.channels)
    for v in range(learners):
        sense(v, pose, physics, geometry.beams, geometry.channels, walls, cell_start,
              cell_walls, all_walls, pose.shape[0] > 1, vehicles.corners, vehicles.centres,
              vehicles.previous_centres, v, out[v], seen)


class ArenaCrowdEnv(ParallelEnv):
    """``learners`` agents (all the arena's vehicles by default) among the rest of a
    scenario's traffic. ``reset(options={"key": k, "situation": e})`` starts situation ``e``
    of traffic key ``k``; without them both are drawn from the reset's seed."""

    metadata = {"name": "enn_traffic_arena_crowd_v0", "render_modes": ["rgb_array"],
                "render_fps": 10}

    def __init__(self, scenario: str | Path | Scenario, learners: int | None = None,
                 render_mode: str | None = None, observation_dtype: str = "float32"):
        self.world = world = rangefinder_world(scenario)
        learners = world.vehicles if learners is None else int(learners)
        if not 1 <= learners <= world.vehicles:
            raise ValueError(f"{world.scenario.name}: learners must be 1 to {world.vehicles} "
                             f"(the arena's vehicles), not {learners}")
        self.learners = learners
        self.possible_agents = [f"vehicle_{v}" for v in range(learners)]
        self.agents: list[str] = []
        self._observation_space, self._action_space = spaces_of(world, observation_dtype)
        self.render_mode = checked_render_mode(render_mode, self.metadata)
        self.max_steps = world.max_steps
        self._rng = np.random.default_rng()
        self._step = None
        self.crowd = None  # until reset

    def observation_space(self, agent: str):
        return self._observation_space

    def action_space(self, agent: str):
        return self._action_space

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        options = checked_options(options, others="warn")
        world = self.world
        key = options.get("key")
        key = int(self._rng.integers(TRAINING_KEYS) if key is None else key)
        situations = world.situations(key)
        situation = options.get("situation")
        situation = int(self._rng.integers(len(situations)) if situation is None else situation)
        if not 0 <= situation < len(situations):
            raise ValueError(f"situation {situation}: key {key} has {len(situations)}")
        chosen = situations[situation]
        kinds = np.asarray(chosen.kinds, dtype=np.int64).copy()
        kinds[: self.learners] = ACTION
        self.crowd = crowd = Crowd(world, chosen.start, kinds, int(chosen.seed))
        self.genes = np.ascontiguousarray(chosen.traffic_genes, dtype=np.float64)
        crowd.lives.spin_checked[:] = kinds == ACTION
        crowd_events(crowd.vehicles, crowd.lives, crowd.physics, crowd.geometry)
        for v in np.flatnonzero(crowd.lives.events != ALIVE):
            crowd.respawn(v)
        self.agents = self.possible_agents[:]
        self.steps = 0
        self.started = {"key": key, "situation": situation}
        return (dict(zip(self.agents, self._observe(), strict=True)),
                {agent: dict(self.started) for agent in self.agents})

    def _observe(self) -> np.ndarray:
        """The live learners' readings (L, B): rows 0..L-1 of the crowd are the learners."""
        crowd = self.crowd
        out = np.empty((len(self.agents), reading_count(crowd.geometry)))
        observe(len(self.agents), crowd.vehicles, crowd.physics, crowd.geometry, out)
        return observation_of(out, self._observation_space)

    def step(self, actions: dict):
        if self.crowd is None:
            raise ResetNeeded("call reset() before step()")
        crowd, gain = self.crowd, self.world.physics.gain
        steering = crowd.work.steering
        actions = checked_actions(actions, self.agents)
        for row, agent in enumerate(self.agents):
            steering[row] = steering_of(actions[agent], gain)
        args = (crowd.kinds, self.genes, self.world.layer_sizes, crowd.physics, crowd.geometry,
                crowd.vehicles, crowd.lives, crowd.rng, crowd.work, False)
        if self._step is None:
            self._step = compiled(step_once, *args)
        self._step(*args)
        self.steps += 1
        rewards = dict.fromkeys(self.agents, 1.0)
        terminated = dict.fromkeys(self.agents, False)
        capped = self.steps >= self.max_steps
        infos = {agent: {} for agent in self.agents}
        lives = crowd.lives
        ended = np.flatnonzero(lives.events != ALIVE)
        if len(ended) == 0:
            observations = dict(zip(self.agents, self._observe(), strict=True))
        else:
            leaving = [int(v) for v in ended if v < len(self.agents)]
            final = {self.agents[v]: row for v, row in enumerate(self._observe())
                     if v in leaving}
            for v in leaving:
                agent, outcome, life = self.agents[v], int(lives.events[v]), int(lives.life[v])
                terminated[agent] = True
                if outcome == SPUN:
                    rewards[agent] = 1.0 - life
                infos[agent] = {"steps": life, "outcome": OUTCOMES[outcome],
                                "fitness": 0.0 if outcome == SPUN else float(life),
                                **self.started}
            for v in ended[len(leaving):]:  # a scripted vehicle respawns
                crowd.respawn(v)
            if leaving:  # a learner leaves the arena, its body with it
                crowd.remove(leaving)
                self.genes = np.delete(self.genes, leaving, axis=0)
                self.agents = [a for v, a in enumerate(self.agents) if v not in leaving]
            observations = dict(zip(self.agents, self._observe(), strict=True)) | final
        truncated = {agent: capped and not done for agent, done in terminated.items()}
        if capped:
            for v, agent in enumerate(self.agents):
                life = int(crowd.lives.life[v])  # the lives after any learner left
                infos[agent] = {"steps": life, "outcome": "capped", "fitness": float(life),
                                **self.started}
            self.agents = []
        return observations, rewards, terminated, truncated, infos

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        crowd = self.crowd
        return picture(self.world, crowd.corners, crowd.pose, self._observe())
