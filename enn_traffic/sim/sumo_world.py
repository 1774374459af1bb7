"""Worlds with SUMO traffic: the learner on a SUMO network among SUMO's vehicles, in replay or
closed-loop mode (docs/sumo.md).

- replay: SUMO runs once per traffic situation without the learner; the recording is replayed
  to all P worlds of a generation in one compiled call (the traffic ignores the learner, as in
  the paper: "the dynamic objects do not cooperate").
- closed-loop: one SUMO per chromosome and situation, with the learner in it every step, so
  SUMO's drivers brake and change lanes for it. Sequential and slower: for validation. Each
  situation's warm-up is simulated once and loaded from a SUMO state file by every chromosome.

A traffic situation is a SUMO seed and a start drawn from (traffic seed, generation, episode),
so every chromosome of a generation meets the same traffic, whatever the number of workers.
With ``traffic.warmup_states = N``, situations share N warm-ups (simulated once, then loaded)
and differ by their own seed from the learner's start on.
"""

from __future__ import annotations

import os
import tempfile
from collections import OrderedDict
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from enn_traffic.roads import Track
from enn_traffic.scenario import Scenario
from enn_traffic.sim.arena import ArenaWorld
from enn_traffic.sim.replay import (
    RUNNING,
    clear_start,
    compiled_step,
    learner_state,
    run_replay_episode,
    run_replay_population,
    with_slots,
)
from enn_traffic.sim.rules import Physics
from enn_traffic.sim.world import EpisodeResults
from enn_traffic.traffic import sumo


class ClosedLoopLife(NamedTuple):
    """One life in a live SUMO: steps moved, outcome, collisions suffered, vehicle-steps
    within sensor range, most within range at once, vehicles on the network at the start, and
    the conflicts its SSM device recorded."""

    steps: int
    outcome: int
    suffered: int
    near_steps: int
    near_max: int
    at_start: int
    conflicts: sumo.Conflicts


RECORDINGS_KEPT = 24  # a test world holds 10 test and 10 validation situations
WARMUP_STREAM = 7  # the key of the shared warm-ups' seeds (traffic.warmup_states)


class SumoWorld(ArenaWorld):
    """A scenario whose traffic is SUMO's: evaluate populations, trace one episode."""

    def __init__(self, scenario: Scenario, track: Track | None = None):
        super().__init__(scenario, track)
        self._recordings: OrderedDict[int, sumo.Recording] = OrderedDict()
        self.vehicles = 1
        self.max_steps = sumo.episode_steps(scenario)  # or where the .sumocfg ends
        self._checked = False  # closed loop: has some traffic been seen on the network?
        self._states: dict[int, Path] = {}  # closed loop: each situation's saved warm-up
        self._steps: dict = {}  # closed loop: the compiled step, by the genes' numba type

    def seeds(self, key: int) -> list[int]:
        """The SUMO seed of each traffic situation of a traffic key."""
        traffic = self.scenario.traffic
        key = self.traffic_key(key)
        return [int(np.random.SeedSequence([traffic.seed, key, 0, e]).generate_state(1)[0]
                    % 2**31) for e in range(traffic.episodes)]

    def situation_starts(self, key: int) -> list[np.ndarray]:
        """The learner's start pose in each traffic situation of a traffic key."""
        key = self.traffic_key(key)
        return [np.asarray(self.start_of(key, 0, e), dtype=np.float64)
                for e in range(self.scenario.traffic.episodes)]

    def warm_state(self, seed: int) -> Path | None:
        """The SUMO state a situation of ``seed`` starts from: one of the shared warm-ups
        (``traffic.warmup_states``), or None for the situation's own warm-up."""
        shared = self.scenario.traffic.warmup_states
        if not shared:
            return None
        index = seed % shared
        warm_seed = int(np.random.SeedSequence(
            [self.scenario.traffic.seed, WARMUP_STREAM, index]).generate_state(1)[0] % 2**31)
        return sumo.warm_state(self.scenario, warm_seed, keep_rng=False)

    def episode_labels(self) -> list[str]:
        return [f"sumo ({self.scenario.traffic.mode})"] * self.scenario.traffic.episodes

    def recording(self, seed: int) -> sumo.Recording:
        """The SUMO run of ``seed`` without the learner (recorded once, then kept)."""
        if seed not in self._recordings:
            self._recordings[seed] = sumo.record(self.scenario, seed, self.max_steps,
                                                 self.warm_state(seed))
            while len(self._recordings) > RECORDINGS_KEPT:
                self._recordings.popitem(last=False)
        self._recordings.move_to_end(seed)
        return self._recordings[seed]

    def _learner_physics(self, radius: float) -> Physics:
        """The constants, with bodies as large as the traffic's largest (``radius``)."""
        return self.physics._replace(radius=max(radius, self.physics.radius))

    def evaluate(self, population: np.ndarray, key: int = 0) -> EpisodeResults:
        """Fitness of every chromosome: steps survived (0 for a spin), averaged over the
        traffic situations of ``key``."""
        genes = self.spec.in_source_layout(population)
        closed = self.scenario.traffic.mode == "closed-loop"
        runs, vehicles, at_start, safety = [], [], [], []
        for seed, start in zip(self.seeds(key), self.situation_starts(key), strict=True):
            if closed:
                *columns, safety_now = self._closed_loop_population(genes, seed, start)
                runs.append(columns)
                at_start.append(columns[5])
                safety.append(safety_now)
                continue
            record = self.recording(seed)
            vehicles.append(record.mean_vehicles)
            at_start.append(int((record.ids[0] >= 0).sum()))
            with numba.parallel_chunksize(1):
                runs.append(run_replay_population(
                    genes, self.layer_sizes, self._learner_physics(record.radius), self.geometry,
                    start, record.ids, record.corners, record.centres, self.max_steps))
        self.vehicles = 1 + round(float(np.mean(vehicles))) if vehicles else self.vehicles
        return EpisodeResults.of_situations(runs, self.vehicles, at_start,
                                            np.stack(safety, axis=1) if safety else None)

    def _closed_loop_population(self, genes: np.ndarray, seed: int, start: np.ndarray
                                ) -> tuple:
        """Per chromosome: steps, outcome, suffered, vehicle-steps within range, most at once,
        vehicles at the start (arrays), and the safety figures (P, 4)."""
        lives = [self.closed_loop(row, seed, start=start) for row in genes]
        columns = tuple(np.array([life[i] for life in lives], dtype=np.int64) for i in range(6))
        safety = np.array([[life.conflicts.min_ttc, life.conflicts.ttc, life.conflicts.drac,
                            life.conflicts.pet] for life in lives], dtype=np.float64)
        return (*columns, safety.reshape(-1, 4))

    def closed_loop(self, genes: np.ndarray, seed: int, max_steps: int | None = None,
                    frames: list | None = None, start: np.ndarray | None = None
                    ) -> ClosedLoopLife:
        """One chromosome (source-layout genes) in a live SUMO with the learner in it, from
        ``start`` (the world's first start by default), its SSM device recording conflicts;
        ``frames`` receives (learner pose, ids, corners) of every step when given. A vehicle
        that leaves the learner's world (``gone``) stays in SUMO, unseen by the learner, as it
        does in a replay. The situation's warm-up is simulated once and loaded from a SUMO
        state file by every later call."""
        limit = self.max_steps if max_steps is None else max_steps
        start = np.asarray(self.start if start is None else start, dtype=np.float64)
        vehicle = self.scenario.vehicle
        if seed not in self._states:  # found (or simulated) once, not once per chromosome
            self._states[seed] = (self.warm_state(seed)
                                  or sumo.warm_state(self.scenario, seed, keep_rng=True))
        state = self._states[seed]
        if not self._checked:  # refuse traffic that never reaches the network
            sumo.first_traffic(self.scenario, seed, state, limit)
            self._checked = True
        handle, ssm_file = tempfile.mkstemp(suffix=".xml", prefix="enn-ssm-")
        os.close(handle)
        simulation = sumo.Simulation(self.scenario, seed, state,
                                     extra=sumo.ssm_options(Path(ssm_file)))
        try:
            physics = self._learner_physics(simulation.largest_radius())
            ids, corners, centres = sumo.slot_arrays(2, 64)  # rows: the step before, now
            before, now = 0, 1  # they swap roles every step, instead of copying
            state = learner_state(start, physics, len(self.geometry.beam_cos), self.layer_sizes,
                                  ids.shape[1])
            ids, corners, centres, state, radius = self._read(
                simulation, now, ids, corners, centres, state)
            at_start = int((ids[now] >= 0).sum())
            # a body larger than its type said
            physics = physics._replace(radius=max(physics.radius, radius))
            clear_start(state.centre, ids[now], centres[now], state.gone, physics.clearance)
            sumo.add_learner(vehicle.length, vehicle.width, vehicle.speed)
            # Vehicles farther than this from the learner's front bumper can neither be seen
            # nor be hit within a step: the sensor's range, two bodies and two steps of both
            # vehicles' travel.
            travel = (simulation.largest_speed() + vehicle.speed) * vehicle.dt
            reach = self.scenario.sensor.range + 2.0 * travel
            simulation.follow_learner(reach + 4.0 * physics.radius)
            kind = numba.typeof(genes)  # the other arguments' types are the world's own
            if kind not in self._steps:
                self._steps[kind] = compiled_step(0, genes, self.layer_sizes, physics,
                                                  self.geometry, ids, corners, centres, before,
                                                  now, limit, state)
            step = self._steps[kind]
            t = 0
            while True:
                if frames is not None:
                    frames.append((state.pose[0].copy(), ids[now].copy(), corners[now].copy()))
                outcome = step(t, genes, self.layer_sizes, physics, self.geometry, ids, corners,
                               centres, before, now, limit, state)
                if outcome != RUNNING:
                    break
                sumo.move_learner(*state.pose[0])
                simulation.step()
                before, now = now, before
                ids, corners, centres, state, radius = self._read(
                    simulation, now, ids, corners, centres, state)
                if radius > physics.radius:  # a body larger than its type said
                    physics = physics._replace(radius=radius)
                    simulation.follow_learner(reach + 4.0 * physics.radius)
                t += 1
        finally:
            simulation.close()  # SUMO writes the SSM file as it closes
            conflicts = sumo.read_conflicts(Path(ssm_file))
            os.unlink(ssm_file)
        return ClosedLoopLife(t, int(outcome), int(state.suffered[0]), int(state.met[0]),
                              int(state.met[1]), at_start, conflicts)

    @staticmethod
    def _read(simulation: sumo.Simulation, row: int, ids, corners, centres, state):
        """Read SUMO's vehicles into row ``row`` of the slot arrays (:func:`sumo.read_frame`),
        growing the learner state's per-slot arrays with them; also the largest body's half
        diagonal."""
        (ids, corners, centres), radius = sumo.read_frame(simulation, row, (ids, corners, centres))
        if ids.shape[1] > len(state.gone):
            state = with_slots(state, ids.shape[1])
        return ids, corners, centres, state, radius

    def trace(self, chromosome: np.ndarray, key: int = 0, episode: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, 1 + S, 3) of the learner and of every SUMO vehicle slot (NaN where a
        slot is empty) in one episode, and the learner's outcome code."""
        limit = self.max_steps if max_steps is None else max_steps
        seed = self.seeds(key)[episode]
        start = self.situation_starts(key)[episode]
        genes = self.spec.in_source_layout(chromosome)[0]
        if self.scenario.traffic.mode == "closed-loop":
            frames: list = []
            steps, outcome, *_ = self.closed_loop(genes, seed, limit, frames, start)
            slots = max(len(f[1]) for f in frames)
            ids = np.full((len(frames), slots), -1, dtype=np.int64)
            corners = np.zeros((len(frames), slots, 4, 2))
            learner = np.array([f[0] for f in frames])
            for t, (_, frame_ids, frame_corners) in enumerate(frames):
                ids[t, : len(frame_ids)], corners[t, : len(frame_ids)] = frame_ids, frame_corners
        else:
            record = self.recording(seed)
            limit = min(limit, record.ids.shape[0] - 1)  # a replay ends with its recording
            learner = np.full((limit + 1, 3), np.nan)
            steps, outcome, *_ = run_replay_episode(
                genes, self.layer_sizes, self._learner_physics(record.radius), self.geometry,
                start, record.ids, record.corners, record.centres, limit, learner)
            ids, corners = record.ids[: steps + 1], record.corners[: steps + 1]
            learner = learner[: steps + 1]
        front = 0.5 * (corners[:, :, 0] + corners[:, :, 1])
        rear = 0.5 * (corners[:, :, 2] + corners[:, :, 3])
        heading = np.arctan2(front[..., 1] - rear[..., 1], front[..., 0] - rear[..., 0])
        traffic = np.where((ids >= 0)[..., None], np.dstack([front, heading[..., None]]),
                           np.nan)
        return np.concatenate([learner[:, None, :], traffic], axis=1), int(outcome)
