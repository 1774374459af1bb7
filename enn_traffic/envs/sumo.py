"""SUMO scenarios as a gymnasium environment: the learner among SUMO's traffic, replayed or
live, shipped or the user's own ``.sumocfg`` (docs/envs.md, "SUMO").

The world is :class:`~enn_traffic.sim.sumo.world.SumoWorld`'s and the step its own
(:func:`~enn_traffic.sim.sumo.replay.learner_step`), in its two halves: the learner senses
(:func:`~enn_traffic.sim.sumo.replay.learner_sense`, after the blame rule, exits, spin test and
step cap), the action steers, the learner moves (:func:`~enn_traffic.sim.sumo.replay.learner_move`).
In replay mode the traffic is the situation's recorded SUMO run; in closed-loop mode a live
SUMO per episode, the learner in it (:class:`~enn_traffic.sim.sumo.live.LiveTraffic`), so
SUMO's drivers react to it. Observation, action and reward are those of
:mod:`enn_traffic.envs.rangefinder`; reaching an exit of the network ends the episode too
(``terminated``, outcome ``left network``: its steps count, as in the GA's fitness).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded
from pettingzoo import ParallelEnv

from enn_traffic.config import MAX_LEARNERS, Scenario, load_scenario
from enn_traffic.envs.batch import compiled
from enn_traffic.envs.child import InChild
from enn_traffic.envs.rangefinder import (
    TRAINING_KEYS,
    checked_actions,
    checked_options,
    checked_render_mode,
    observation_of,
    picture,
    spaces_of,
    steering_of,
)
from enn_traffic.sim.crowd import ALIVE
from enn_traffic.sim.readings import reading_count, unseen_readings
from enn_traffic.sim.sumo import world as recordings
from enn_traffic.sim.sumo.crowd import SumoCrowd, check_room
from enn_traffic.sim.sumo.crowd_rules import move_once as move_learners
from enn_traffic.sim.sumo.crowd_rules import observe
from enn_traffic.sim.sumo.live import LiveTraffic
from enn_traffic.sim.sumo.replay import (
    clear_start,
    learner_state,
    move_once,
    sense_once,
    with_slots,
)
from enn_traffic.sim.sumo.world import SumoWorld
from enn_traffic.sim.world import CAPPED, OUTCOMES, RUNNING, SPUN
from enn_traffic.sumo.simulation import Simulation


def sumo_world(scenario: str | Path | Scenario) -> SumoWorld:
    """The SUMO world of a scenario (file or loaded); a clear error for the others."""
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    if not scenario.traffic.is_sumo:
        raise ValueError(f"{scenario.name}: not a SUMO scenario")
    scenario = scenario.single_track()
    return SumoWorld(scenario)


class ReplayTraffic:
    """A recorded SUMO run as the learner's traffic, in :class:`LiveTraffic`'s terms: step
    ``t`` reads rows ``t - 1`` (``before``) and ``t`` (``now``) of the recording."""

    def __init__(self, world: SumoWorld, seed: int, warmup: int | None, start: np.ndarray):
        self.world, self.seed, self.warmup = world, seed, warmup
        self._use(world.recording(seed, warmup, recordings.FIRST_RECORDING))
        self.state = learner_state(start, self.physics, world.geometry,
                                   world.layer_sizes, self.ids.shape[1])
        clear_start(self.state.learner.centres, self.ids[0], self.centres[0], self.state.gone,
                    self.physics.clearance)
        self.t = self.before = self.now = 0

    def _use(self, record) -> None:
        self.ids, self.corners, self.centres = record.ids, record.corners, record.centres
        self.names, self.types = record.names, record.types
        self.physics = self.world._learner_physics(record.radius)

    def advance(self) -> None:
        """The next step; past the end of the recording, a recording
        :data:`~enn_traffic.sim.sumo.world.RECORDING_GROWTH` times longer (which begins with
        this one: the life goes on unchanged), up to the step cap."""
        self.t += 1
        self.before, self.now = self.t - 1, self.t
        if self.t >= self.ids.shape[0] and self.t <= self.world.max_steps:
            steps = (self.ids.shape[0] - 1) * recordings.RECORDING_GROWTH
            self._use(self.world.recording(self.seed, self.warmup, steps))
            self.state = with_slots(self.state, self.ids.shape[1])

    def vehicle(self, hit: int) -> tuple[str, str] | None:
        return (self.names[hit], self.types[hit]) if hit >= 0 and self.names else None

    def close(self) -> None:
        pass


class SumoEnv(gym.Env):
    """One learner among a SUMO scenario's traffic. ``reset(options={"key": k,
    "situation": e})`` starts situation ``e`` of traffic key ``k`` (its SUMO seed, warm-up
    and start, as the GA's); without them both are drawn from the reset's seed. Call
    :meth:`close` to end a live SUMO."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, scenario: str | Path | Scenario, render_mode: str | None = None,
                 observation_dtype: str = "float32"):
        self.render_mode = checked_render_mode(render_mode, self.metadata)
        self.world = sumo_world(scenario)
        self.observation_space, self.action_space = spaces_of(self.world, observation_dtype)
        self.traffic: LiveTraffic | ReplayTraffic | None = None
        self._sense = self._move = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options, world = checked_options(options), self.world
        key = options.get("key")
        key = int(self.np_random.integers(TRAINING_KEYS) if key is None else key)
        situations = world.scenario.traffic.episodes
        situation = options.get("situation")
        situation = int(self.np_random.integers(situations) if situation is None
                        else situation)
        if not 0 <= situation < situations:
            raise ValueError(f"situation {situation}: key {key} has {situations}")
        sumo_seed = world.seeds(key)[situation]
        start = world.situation_starts(key)[situation]
        warmup = world.warmups(key)[situation]
        self.close()
        if world.scenario.traffic.mode == "closed-loop":
            self.traffic = world.live(sumo_seed, start, warmup)
        else:
            self.traffic = ReplayTraffic(world, sumo_seed, warmup, start)
        self.outcome = self._sensed()
        if self.outcome != RUNNING:  # a life that ends where it starts sensed nothing
            self.traffic.state.work.readings[:] = unseen_readings(world.geometry)
        self.started = {"key": key, "situation": situation}
        readings = observation_of(self.traffic.state.work.readings, self.observation_space)
        return readings, dict(self.started)

    def _sensed(self) -> int:
        """The learner's outcome at this step, or ``RUNNING`` and its readings."""
        traffic = self.traffic
        args = (traffic.t, traffic.physics, self.world.geometry, traffic.ids, traffic.corners,
                traffic.centres, traffic.before, traffic.now, self.world.max_steps,
                traffic.state)
        if self._sense is None:
            self._sense = compiled(sense_once, *args)
        return int(self._sense(*args))

    def step(self, action):
        traffic = self.traffic
        if traffic is None:
            raise ResetNeeded("call reset() before step()")
        if self.outcome == RUNNING:  # else the life ended where it started
            traffic.state.work.steering[0] = steering_of(action, self.world.physics.gain)
            if self._move is None:
                self._move = compiled(move_once, traffic.physics, traffic.state)
            self._move(traffic.physics, traffic.state)
            traffic.advance()
            self.outcome = self._sensed()
        outcome, steps, state = self.outcome, traffic.t, traffic.state
        readings = observation_of(state.work.readings, self.observation_space)
        if outcome == RUNNING:
            return readings, 1.0, False, False, {}
        hit = int(state.hit[0])
        info = {"steps": steps, "outcome": OUTCOMES[outcome],
                "fitness": 0.0 if outcome == SPUN else float(steps),
                "suffered": int(state.suffered[0]), "hit": hit,
                "hit_vehicle": traffic.vehicle(hit), **self.started}
        reward = 1.0 - steps if outcome == SPUN else 1.0
        return readings, reward, outcome != CAPPED, outcome == CAPPED, info

    def render(self):
        if self.render_mode != "rgb_array" or self.traffic is None:
            return None

        traffic, state = self.traffic, self.traffic.state
        present = traffic.ids[traffic.now] >= 0
        corners = np.concatenate([state.learner.corners, traffic.corners[traffic.now][present]])
        reach = 2.0 * self.world.physics.max_range  # a network can be a city: show the learner's
        return picture(self.world, corners, state.learner.pose, state.work.readings[None],
                       around=(*state.learner.pose[0, :2], reach))

    def close(self):
        if self.traffic is not None:
            self.traffic.close()
            self.traffic = None


class SumoCrowdEnv(ParallelEnv):
    """Several learners at once in a live SUMO (paper §5.5 among SUMO traffic), one agent per
    learning vehicle: the :class:`~enn_traffic.sim.sumo.crowd.SumoCrowd` of the scenario's
    ``traffic.learners`` (or ``learners``), stepped by its own rules with the learners'
    steering given as actions. A learner whose life ends (collision, spin, an exit reached)
    is terminated and leaves SUMO, where the crowd of the SUMO tables re-enters it; all are
    truncated at ``episode.max_steps``. ``reset(options={"key": k, "situation": e})`` as
    :class:`SumoEnv`; the learners enter at free spots drawn from the situation's seed. Call
    :meth:`close` to end SUMO. A crowd reset while another SUMO runs in this process runs its
    own in a child process (:mod:`enn_traffic.envs.child`), so that two crowds (PettingZoo's
    seed test) step side by side."""

    metadata = {"name": "enn_traffic_sumo_crowd_v0", "render_modes": []}

    def __init__(self, scenario: str | Path | Scenario, learners: int | None = None,
                 render_mode: str | None = None, observation_dtype: str = "float32"):
        world = sumo_world(scenario)
        if render_mode is not None:
            raise ValueError(f"{world.scenario.name}: the SUMO crowd does not render")
        if learners is not None:  # checked as the scenario file's key is, named as given
            if not 1 <= int(learners) <= MAX_LEARNERS:
                raise ValueError(f"{world.scenario.name}: learners must be from 1 to "
                                 f"{MAX_LEARNERS:,}, not {learners}")
            world = SumoWorld(world.scenario.with_overrides(traffic={"learners": int(learners)}))
        check_room(world, "traffic.learners" if learners is None else "learners")
        self.world = world
        self.possible_agents = [f"vehicle_{k}"
                                for k in range(world.scenario.traffic.learners)]
        self.agents: list[str] = []
        self._observation_space, self._action_space = spaces_of(world, observation_dtype)
        self.render_mode = None
        self.crowd: SumoCrowd | None = None
        self._rng = np.random.default_rng()
        self._observe = self._move = None
        self._observation_dtype = observation_dtype
        self._child: InChild | None = None

    def _in_child(self) -> InChild | None:
        """The child process this crowd runs in, started when another SUMO runs here."""
        running = Simulation.running
        own = self.crowd is not None and running is self.crowd.simulation
        if self._child is None and running is not None and not own:
            self._child = InChild(self, SumoCrowdEnv, (self.world.scenario,),
                                  {"observation_dtype": self._observation_dtype})
        return self._child

    def observation_space(self, agent: str):
        return self._observation_space

    def action_space(self, agent: str):
        return self._action_space

    def reset(self, seed: int | None = None, options: dict | None = None):
        if self._in_child() is not None:
            result, self.agents = self._child.call("reset", seed, options)
            return result
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        options, world = checked_options(options, others="warn"), self.world
        key = options.get("key")
        key = int(self._rng.integers(TRAINING_KEYS) if key is None else key)
        situations = world.scenario.traffic.episodes
        situation = options.get("situation")
        situation = int(self._rng.integers(situations) if situation is None else situation)
        if not 0 <= situation < situations:
            raise ValueError(f"situation {situation}: key {key} has {situations}")
        self.close()
        self.crowd = crowd = SumoCrowd(world, world.seeds(key)[situation])
        crowd.start()
        if crowd.detect():  # a learner whose entry is taken enters again
            crowd.reenter(np.flatnonzero(crowd.lives.learners.events != ALIVE))
        self.agents = self.possible_agents[:]
        self.steps = 0
        readings = self._readings()
        self.started = {"key": key, "situation": situation}
        space = self._observation_space
        return ({agent: observation_of(readings[k], space) for k, agent in enumerate(self.agents)},
                {agent: dict(self.started) for agent in self.agents})

    def _readings(self) -> np.ndarray:
        """Every learner still on the network senses (K, B)."""
        crowd, lives = self.crowd, self.crowd.lives
        out = np.zeros((len(self.possible_agents), reading_count(self.world.geometry)))
        args = (crowd.physics, self.world.geometry, crowd.slots, crowd.now, lives.vehicles,
                lives.learners, out)
        if self._observe is None:
            self._observe = compiled(observe, *args)
        self._observe(*args)
        return out

    def step(self, actions: dict):
        if self._child is not None:
            result, self.agents = self._child.call("step", actions)
            return result
        if self.crowd is None:
            raise ResetNeeded("call reset() before step()")
        crowd, lives, gain = self.crowd, self.crowd.lives, self.world.physics.gain
        for agent, action in checked_actions(actions, self.agents).items():
            lives.work.steering[int(agent.rpartition("_")[2])] = steering_of(action, gain)
        args = (lives.work.steering, crowd.physics, lives.vehicles, lives.learners)
        if self._move is None:
            self._move = compiled(move_learners, *args)
        self._move(*args)
        crowd.advance()
        self.steps += 1
        crowd.detect()
        readings = self._readings()
        capped = self.steps >= self.world.max_steps
        observations, rewards, terminated, truncated, infos = {}, {}, {}, {}, {}
        for agent in self.agents:
            k = int(agent.rpartition("_")[2])
            outcome, life = int(lives.learners.events[k]), int(lives.learners.life[k])
            observations[agent] = observation_of(readings[k], self._observation_space)
            rewards[agent] = 1.0
            terminated[agent], truncated[agent] = outcome != ALIVE, capped and outcome == ALIVE
            infos[agent] = {}
            if outcome != ALIVE:
                if outcome == SPUN:
                    rewards[agent] = 1.0 - life
                infos[agent] = {"steps": life, "outcome": OUTCOMES[outcome],
                                "fitness": 0.0 if outcome == SPUN else float(life),
                                **self.started}
                crowd.leave(k)
            elif capped:
                infos[agent] = {"steps": life, "outcome": OUTCOMES[CAPPED],
                                "fitness": float(life), **self.started}
        self.agents = [] if capped else [a for a in self.agents if not terminated[a]]
        return observations, rewards, terminated, truncated, infos

    def close(self):
        if self._child is not None:
            self._child.call("close")
            self.agents = []
        if self.crowd is not None:
            self.crowd.close()
            self.crowd = None
