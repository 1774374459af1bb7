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
and differ by their own seed from the learner's start on (:func:`shared_warmup`).
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from enn_traffic import keys
from enn_traffic.progress import slow_step
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
    within sensor range, most within range at once, what it ran into (``NO_HIT``, ``HIT_WALL``
    or the vehicle's number), vehicles on the network at the start, the conflicts its SSM
    device recorded, and the SUMO id and type of the vehicle it ran into (or None)."""

    steps: int
    outcome: int
    suffered: int
    near_steps: int
    near_max: int
    hit: int
    at_start: int
    conflicts: sumo.Conflicts
    hit_vehicle: tuple[str, str] | None = None


class TracedLife(NamedTuple):
    """One situation's poses (n, 1 + S, 3: the learner, then every SUMO vehicle slot), how
    the learner's life ended, what it ran into (``NO_HIT``, ``HIT_WALL`` or the vehicle's
    number), that vehicle's SUMO id and type, and its body (4, 2) as the learner hit it."""

    poses: np.ndarray
    outcome: int
    hit: int
    hit_vehicle: tuple[str, str] | None
    hit_body: np.ndarray | None


def objects(values: list) -> np.ndarray:
    """A 1-D object array of ``values`` (tuples stay whole)."""
    column = np.empty(len(values), dtype=object)
    for index, value in enumerate(values):
        column[index] = value
    return column


def named(hit: np.ndarray, names: tuple[str, ...], types: tuple[str, ...]) -> np.ndarray:
    """The (SUMO id, type) of each vehicle number in ``hit`` (None where it is no vehicle)."""
    return objects([(names[h], types[h]) if h >= 0 else None for h in hit.tolist()])


RECORDINGS_KEPT = 24  # a test world holds 10 test and 10 validation situations
WARMUP_STREAM = 7  # the key of the shared warm-ups' seeds (traffic.warmup_states)


def situation_seed(scenario: Scenario, key: int, episode: int) -> int:
    """The SUMO seed of situation ``episode`` of traffic key ``key`` (as the world draws it:
    after ``traffic.vary``)."""
    sequence = np.random.SeedSequence([scenario.traffic.seed, key, 0, episode])
    return int(sequence.generate_state(1)[0] % 2**31)


def shared_warmup(scenario: Scenario, key: int, episode: int) -> int | None:
    """Which of the ``traffic.warmup_states`` shared warm-ups situation ``episode`` of traffic
    key ``key`` loads (None: none are shared). A training generation's situations take them in
    turn, (generation × episodes + episode) mod N, so that consecutive generations meet every
    warm-up equally often; a held-out situation, one of a sample, draws one by its seed."""
    shared = scenario.traffic.warmup_states
    if not shared:
        return None
    if keys.is_training(key):
        return (key * scenario.traffic.episodes + episode) % shared
    return situation_seed(scenario, key, episode) % shared


def warmups_used(scenario: Scenario, key: int) -> str:
    """The shared warm-ups the situations of a training ``key`` load, in order (``"0 1"``), a
    track's after another's (``"0 1; 2 3"``); empty without shared warm-ups."""
    parts = ([scenario.on_track(i) for i in range(len(scenario.tracks))]
             if isinstance(scenario.track, list) else [scenario])
    used = []
    for part in parts:
        traffic_key = 0 if part.traffic.vary == "fixed" and keys.is_training(key) else key
        indices = [shared_warmup(part, traffic_key, e) for e in range(part.traffic.episodes)]
        if part.traffic.is_sumo and part.traffic.warmup_states:
            used.append(" ".join(str(i) for i in indices))
    return "; ".join(used)


class SumoWorld(ArenaWorld):
    """A scenario whose traffic is SUMO's: evaluate populations, trace one episode."""

    def __init__(self, scenario: Scenario, track: Track | None = None):
        super().__init__(scenario, track)
        self._recordings: OrderedDict[tuple, sumo.Recording] = OrderedDict()
        self.vehicles = 1
        self.max_steps = sumo.episode_steps(scenario)  # or where the .sumocfg ends
        self._checked = False  # closed loop: has some traffic been seen on the network?
        self._states: dict[tuple, Path] = {}  # closed loop: each situation's saved warm-up
        self._steps: dict = {}  # closed loop: the compiled step, by the genes' numba type

    def seeds(self, key: int) -> list[int]:
        """The SUMO seed of each traffic situation of a traffic key."""
        key = self.traffic_key(key)
        return [situation_seed(self.scenario, key, e)
                for e in range(self.scenario.traffic.episodes)]

    def warmups(self, key: int) -> list[int | None]:
        """The shared warm-up each traffic situation of a traffic key loads
        (:func:`shared_warmup`; None: its own)."""
        key = self.traffic_key(key)
        return [shared_warmup(self.scenario, key, e)
                for e in range(self.scenario.traffic.episodes)]

    def situation_starts(self, key: int) -> list[np.ndarray]:
        """The learner's start pose in each traffic situation of a traffic key."""
        key = self.traffic_key(key)
        return [np.asarray(self.start_of(key, 0, e), dtype=np.float64)
                for e in range(self.scenario.traffic.episodes)]

    def warm_state(self, seed: int, index: int | None = None) -> Path | None:
        """The SUMO state a situation of ``seed`` starts from: shared warm-up ``index`` (by
        default drawn by the seed, as a held-out situation's), or None for the situation's own
        warm-up (no shared warm-ups)."""
        shared = self.scenario.traffic.warmup_states
        if not shared:
            return None
        index = seed % shared if index is None else index
        warm_seed = int(np.random.SeedSequence(
            [self.scenario.traffic.seed, WARMUP_STREAM, index]).generate_state(1)[0] % 2**31)
        return sumo.warm_state(self.scenario, warm_seed, keep_rng=False)

    def episode_labels(self) -> list[str]:
        return [f"sumo ({self.scenario.traffic.mode})"] * self.scenario.traffic.episodes

    def recording(self, seed: int, warmup: int | None = None) -> sumo.Recording:
        """The SUMO run of ``seed`` without the learner, from shared warm-up ``warmup`` (see
        :meth:`warm_state`; recorded once, then kept)."""
        if (seed, warmup) not in self._recordings:
            state = self.warm_state(seed, warmup)
            own = "" if state else f"{self.scenario.traffic.warmup_s:g} s of warm-up, then "
            with slow_step(f"simulating SUMO traffic ({own}{self.max_steps} steps, "
                           f"seed {seed})"):
                self._recordings[seed, warmup] = sumo.record(self.scenario, seed,
                                                             self.max_steps, state)
            while len(self._recordings) > RECORDINGS_KEPT:
                self._recordings.popitem(last=False)
        self._recordings.move_to_end((seed, warmup))
        return self._recordings[seed, warmup]

    def _learner_physics(self, radius: float) -> Physics:
        """The constants, with bodies as large as the traffic's largest (``radius``)."""
        return self.physics._replace(radius=max(radius, self.physics.radius))

    def evaluate(self, population: np.ndarray, key: int = 0) -> EpisodeResults:
        """Fitness of every chromosome: steps survived (0 for a spin), averaged over the
        traffic situations of ``key``."""
        genes = self.spec.in_source_layout(population)
        closed = self.scenario.traffic.mode == "closed-loop"
        runs, vehicles, at_start, safety, hit_vehicle = [], [], [], [], []
        for seed, start, warmup in zip(self.seeds(key), self.situation_starts(key),
                                       self.warmups(key), strict=True):
            if closed:
                lives = [self.closed_loop(row, seed, start=start, warmup=warmup)
                         for row in genes]
                runs.append([np.array([life[i] for life in lives], dtype=np.int64)
                             for i in range(6)])
                at_start.append(np.array([life.at_start for life in lives]))
                safety.append(np.array([[life.conflicts.min_ttc, life.conflicts.ttc,
                                         life.conflicts.drac, life.conflicts.pet]
                                        for life in lives], dtype=np.float64).reshape(-1, 4))
                hit_vehicle.append(objects([life.hit_vehicle for life in lives]))
                continue
            record = self.recording(seed, warmup)
            vehicles.append(record.mean_vehicles)
            at_start.append(int((record.ids[0] >= 0).sum()))
            with numba.parallel_chunksize(1):
                runs.append(run_replay_population(
                    genes, self.layer_sizes, self._learner_physics(record.radius), self.geometry,
                    start, record.ids, record.corners, record.centres, self.max_steps))
            hit_vehicle.append(named(runs[-1][5], record.names, record.types))
        self.vehicles = 1 + round(float(np.mean(vehicles))) if vehicles else self.vehicles
        return EpisodeResults.of_situations(runs, self.vehicles, at_start,
                                            np.stack(safety, axis=1) if safety else None,
                                            np.stack(hit_vehicle, axis=1))

    def closed_loop(self, genes: np.ndarray, seed: int, max_steps: int | None = None,
                    frames: list | None = None, start: np.ndarray | None = None,
                    warmup: int | None = None) -> ClosedLoopLife:
        """One chromosome (source-layout genes) in a live SUMO with the learner in it, from
        ``start`` (the world's first start by default), its SSM device recording conflicts;
        ``frames`` receives (learner pose, ids, corners) of every step when given. A vehicle
        that leaves the learner's world (``gone``) stays in SUMO, unseen by the learner, as it
        does in a replay. The situation's warm-up is simulated once and loaded from a SUMO
        state file by every later call."""
        limit = self.max_steps if max_steps is None else max_steps
        start = np.asarray(self.start if start is None else start, dtype=np.float64)
        vehicle = self.scenario.vehicle
        if (seed, warmup) not in self._states:  # found (or simulated) once, not per chromosome
            self._states[seed, warmup] = (self.warm_state(seed, warmup)
                                          or sumo.warm_state(self.scenario, seed, keep_rng=True))
        state = self._states[seed, warmup]
        if not self._checked:  # refuse traffic that never reaches the network
            sumo.first_traffic(self.scenario, seed, state, limit)
            self._checked = True
        simulation = sumo.Simulation(self.scenario, seed, state, extra=sumo.ssm_options())
        ssm_output = b""
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
        finally:  # SUMO writes the SSM file as it closes
            ssm_output = simulation.close(read=(sumo.SSM_FILE,))[sumo.SSM_FILE]
        conflicts = sumo.read_conflicts(ssm_output)
        hit = int(state.hit[0])
        return ClosedLoopLife(t, int(outcome), int(state.suffered[0]), int(state.met[0]),
                              int(state.met[1]), hit, at_start, conflicts,
                              (simulation.names[hit], simulation.types[hit]) if hit >= 0
                              else None)

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
        life = self.trace_life(chromosome, key, episode, max_steps)
        return life.poses, life.outcome

    def trace_life(self, chromosome: np.ndarray, key: int = 0, episode: int = 0,
                   max_steps: int | None = None) -> TracedLife:
        """:meth:`trace`, with what the learner ran into."""
        limit = self.max_steps if max_steps is None else max_steps
        seed = self.seeds(key)[episode]
        start = self.situation_starts(key)[episode]
        warmup = self.warmups(key)[episode]
        genes = self.spec.in_source_layout(chromosome)[0]
        if self.scenario.traffic.mode == "closed-loop":
            frames: list = []
            life = self.closed_loop(genes, seed, limit, frames, start, warmup)
            outcome, hit, hit_vehicle = life.outcome, life.hit, life.hit_vehicle
            slots = max(len(f[1]) for f in frames)
            ids = np.full((len(frames), slots), -1, dtype=np.int64)
            corners = np.zeros((len(frames), slots, 4, 2))
            learner = np.array([f[0] for f in frames])
            for t, (_, frame_ids, frame_corners) in enumerate(frames):
                ids[t, : len(frame_ids)], corners[t, : len(frame_ids)] = frame_ids, frame_corners
        else:
            record = self.recording(seed, warmup)
            limit = min(limit, record.ids.shape[0] - 1)  # a replay ends with its recording
            learner = np.full((limit + 1, 3), np.nan)
            steps, outcome, *_, hit = run_replay_episode(
                genes, self.layer_sizes, self._learner_physics(record.radius), self.geometry,
                start, record.ids, record.corners, record.centres, limit, learner)
            hit_vehicle = named(np.array([hit]), record.names, record.types)[0]
            ids, corners = record.ids[: steps + 1], record.corners[: steps + 1]
            learner = learner[: steps + 1]
        front = 0.5 * (corners[:, :, 0] + corners[:, :, 1])
        rear = 0.5 * (corners[:, :, 2] + corners[:, :, 3])
        heading = np.arctan2(front[..., 1] - rear[..., 1], front[..., 0] - rear[..., 0])
        traffic = np.where((ids >= 0)[..., None], np.dstack([front, heading[..., None]]),
                           np.nan)
        body = None
        before = max(len(ids) - 2, 0)  # the learner runs into bodies from before the step
        if hit >= 0 and (ids[before] == hit).any():
            body = corners[before, int(np.flatnonzero(ids[before] == hit)[0])].copy()
        return TracedLife(np.concatenate([learner[:, None, :], traffic], axis=1), int(outcome),
                          int(hit), hit_vehicle, body)
