"""Worlds with SUMO traffic: the learner on a SUMO network among SUMO's vehicles, in replay or
closed-loop mode (docs/sumo.md).

- replay: SUMO runs once per traffic situation without the learner; the recording is replayed
  to all P worlds of a generation in one compiled call (the traffic ignores the learner, as in
  the paper: "the dynamic objects do not cooperate").
- closed-loop: one SUMO per chromosome and situation, with the learner in it every step, so
  SUMO's drivers brake and change lanes for it. Sequential and slower: for validation. Each
  situation's warm-up is simulated once and loaded from a SUMO state file by every chromosome.

A traffic situation is a SUMO seed and a start drawn from (traffic seed, generation, index),
so every chromosome of a generation meets the same traffic, whatever the number of workers.
With ``traffic.warmup_states = N``, situations share N warm-ups (simulated once, then loaded)
and differ by their own seed from the learner's start on (:func:`shared_warmup`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
from collections import OrderedDict
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from enn_traffic.config import Scenario, episode_steps
from enn_traffic.core.progress import slow_step
from enn_traffic.roads.network import lane_spots
from enn_traffic.sim.arena import LearnerWorld
from enn_traffic.sim.rules import Physics
from enn_traffic.sim.safety import CONFLICT_TTC, least_time_to_contact
from enn_traffic.sim.sumo.live import LiveTraffic
from enn_traffic.sim.sumo.replay import (
    RUNNING,
    compiled_step,
    run_replay_life,
    run_replay_population,
)
from enn_traffic.sim.sumo.situations import (
    WARMUP_STREAM,
    first_alike,
    shared_warmup,
    situation_seed,
)
from enn_traffic.sim.world import CAPPED, SituationResults
from enn_traffic.sumo import recording, ssm, states
from enn_traffic.sumo.fresh import WORKERS, fresh, fresh_calls, fresh_shares
from enn_traffic.sumo.simulation import Simulation


class ClosedLoopLife(NamedTuple):
    """One life in a live SUMO: steps moved, outcome, collisions suffered, vehicle-steps
    within sensor range, most within range at once, what it ran into (``NO_HIT``, ``HIT_WALL``
    or the vehicle's number), vehicles on the network at the start, the conflicts its SSM
    device recorded, the SUMO id and type of the vehicle it ran into (or None), its pose
    (x, y, heading) as the life ended, and the two-dimensional time to collision over the
    bodies' footprints (:mod:`~enn_traffic.sim.safety`): its least over the life (s) and the
    steps it was below SSM's TTC threshold."""

    steps: int
    outcome: int
    suffered: int
    near_steps: int
    near_max: int
    hit: int
    at_start: int
    conflicts: ssm.Conflicts
    hit_vehicle: tuple[str, str] | None = None
    end: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    min_ttc_2d: float = math.inf
    ttc_2d_steps: int = 0


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


# Replay recordings are kept in the process for every world of the same traffic: a family's
# experiments meet the same situations again (Fig. 11's runs of every GA seed and Table 2's
# iterations evolve on the same traffic keys; Table 1 measures on the same test keys), so a
# situation is simulated once. At most this many bytes, the least recently used dropped first.
RECORDINGS_BYTES = 1 << 30
_recordings: OrderedDict[tuple, recording.Recording] = OrderedDict()


def _recording_bytes(record: recording.Recording) -> int:
    return record.ids.nbytes + record.corners.nbytes + record.centres.nbytes


def forget_recordings() -> None:
    """Drop every kept replay recording (SUMO records each situation again)."""
    _recordings.clear()


# Replay records SUMO as far as the lives reach: this many steps first, then this many times
# longer while a life outlives the recording (SumoWorld.replay).
FIRST_RECORDING, RECORDING_GROWTH = 256, 4


class SumoWorld(LearnerWorld):
    """A scenario whose traffic is SUMO's: evaluate populations, trace one life."""

    def __init__(self, scenario: Scenario):
        super().__init__(scenario)
        self._traffic_seen: list[float] = []  # the last replay's mean SUMO vehicles
        self.max_steps = episode_steps(scenario)  # or where the .sumocfg ends
        self._checked = False  # closed loop: has some traffic been seen on the network?
        self._states: dict[tuple, Path] = {}  # closed loop: each situation's saved warm-up
        self._steps: dict = {}  # closed loop: the compiled step, by the genes' numba type

    @functools.cached_property
    def lane_spots(self) -> np.ndarray:
        """Where learners of a SUMO crowd re-enter: spots along the lanes
        (:func:`~enn_traffic.roads.network.lane_spots`)."""
        return lane_spots(self.scenario.track.net, self.scenario.track.surface)

    @property
    def vehicles(self) -> int:
        """Vehicles simulated per world: the learner and the mean of the SUMO vehicles the
        last replayed situations held (the learner alone before any, or in closed loop)."""
        return 1 + round(float(np.mean(self._traffic_seen))) if self._traffic_seen else 1

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

    def first_alike(self, key: int) -> list[int]:
        """For each traffic situation of a traffic key, the first that starts alike
        (:func:`~enn_traffic.sim.sumo.situations.first_alike`)."""
        return first_alike(self.situation_starts(key), self.warmups(key))

    def warm_state(self, seed: int, index: int | None = None) -> Path | None:
        """The SUMO state a situation of ``seed`` starts from: shared warm-up ``index`` (by
        default drawn by the seed, as a held-out situation's), or None for the situation's own
        warm-up (no shared warm-ups)."""
        warm_seed = self._shared_warmup_seed(seed, index)
        return None if warm_seed is None else states.warm_state(self.scenario, warm_seed,
                                                              keep_rng=False)

    def _shared_warmup_seed(self, seed: int, index: int | None) -> int | None:
        """The SUMO seed of the shared warm-up :meth:`warm_state` loads (None: none)."""
        shared = self.scenario.traffic.warmup_states
        if not shared:
            return None
        index = seed % shared if index is None else index
        return int(np.random.SeedSequence(
            [self.scenario.traffic.seed, WARMUP_STREAM, index]).generate_state(1)[0] % 2**31)

    def situation_labels(self) -> list[str]:
        return [f"sumo ({self.scenario.traffic.mode})"] * self.scenario.traffic.episodes

    def recording(self, seed: int, warmup: int | None = None,
                  steps: int | None = None) -> recording.Recording:
        """The SUMO run of ``seed`` without the learner, from shared warm-up ``warmup`` (see
        :meth:`warm_state`), at least ``steps`` steps long (the step cap by default): one
        situation of :meth:`recordings`."""
        return self.recordings([(seed, warmup, steps)])[0]

    def recordings(self, situations: list[tuple[int, int | None, int | None]]
                   ) -> list[recording.Recording]:
        """The recording of each situation (SUMO seed, shared warm-up, at least this many
        steps; None: the step cap): recorded once and kept, and recorded again, longer, when a
        life needs more. SUMO runs the same way every time from the same seed and state, so a
        longer recording begins with the shorter one. The missing ones are simulated side by
        side, each in a fresh process (:data:`~enn_traffic.sumo.fresh.WORKERS` at once):
        a recording never depends on what this process simulated before (docs/sumo.md, "One
        SUMO start, one process")."""
        wanted = [(seed, warmup, self.max_steps if steps is None else min(steps, self.max_steps))
                  for seed, warmup, steps in situations]
        missing: dict[tuple, int] = {}
        for seed, warmup, steps in wanted:
            kept = _recordings.get((self._traffic, seed, warmup))
            if kept is None or kept.ids.shape[0] - 1 < steps:
                missing[seed, warmup] = max(steps, missing.get((seed, warmup), 0))
        if missing:
            what = (f"{len(missing)} situations" if len(missing) > 1
                    else f"seed {next(iter(missing))[0]}")
            own = "" if self.scenario.traffic.warmup_states else (
                f"{self.scenario.traffic.warmup_s:g} s of warm-up, then ")
            with slow_step(f"simulating SUMO traffic ({own}{max(missing.values())} steps, "
                           f"{what})"):
                records = fresh_calls([(recorded, self.scenario, seed,
                                        self._shared_warmup_seed(seed, warmup), steps,
                                        steps < self.max_steps)
                                       for (seed, warmup), steps in missing.items()],
                                      workers=WORKERS)
            for ((seed, warmup), steps), record in zip(missing.items(), records, strict=True):
                if steps < self.max_steps and not (record.ids >= 0).any():
                    # no vehicle yet: refuse traffic that never reaches the network within
                    # the cap
                    fresh(states.first_traffic, self.scenario, seed,
                          self.warm_state(seed, warmup), self.max_steps)
                _recordings[self._traffic, seed, warmup] = record
        found = []
        for seed, warmup, _ in wanted:  # the most recently used, so the last dropped
            _recordings.move_to_end((self._traffic, seed, warmup))
            found.append(_recordings[self._traffic, seed, warmup])
        kept = sum(map(_recording_bytes, _recordings.values()))
        while len(_recordings) > 1 and kept > RECORDINGS_BYTES:
            kept -= _recording_bytes(_recordings.popitem(last=False)[1])
        return found

    @functools.cached_property
    def _traffic(self) -> str:
        """What a recording depends on: the road network, the traffic and the step length
        (and, where SUMO writes outputs, the folder they go to); and the step cap, within
        which a recording of the first steps without a vehicle was checked for traffic."""
        scenario = self.scenario
        decides = scenario.model_dump(mode="json", include={"track", "traffic", "vehicle"})
        where = str(scenario.sumo_folder) if scenario.traffic.outputs else ""
        return hashlib.sha256(json.dumps([decides, where, self.max_steps],
                                         sort_keys=True).encode()).hexdigest()

    def replay(self, genes: np.ndarray, seed: int, start: np.ndarray, warmup: int | None,
               cap: int | None = None) -> tuple[tuple[np.ndarray, ...], recording.Recording]:
        """Every chromosome (source-layout genes) through the recorded traffic of ``seed``:
        one situation of :meth:`replays`."""
        return self.replays(genes, [(seed, start, warmup)], cap)[0]

    def replays(self, genes: np.ndarray, situations: list[tuple[int, np.ndarray, int | None]],
                cap: int | None = None) -> list[tuple[tuple[np.ndarray, ...], recording.Recording]]:
        """Every chromosome (source-layout genes) through the recorded traffic of each
        situation (SUMO seed, start, shared warm-up): the life columns of
        :func:`run_replay_population` and the recording. SUMO is recorded only as far as the
        lives reach (docs/sumo.md, "Replay"): first :data:`FIRST_RECORDING` steps, then
        :data:`RECORDING_GROWTH` times longer while a life outlives the recording, up to the
        step cap (``cap``, at most the scenario's), every situation's recordings of a round
        side by side (:meth:`recordings`). A life's result is the same as on a recording of
        the whole cap, which it never reads past its end."""
        cap = self.max_steps if cap is None else min(cap, self.max_steps)
        steps = dict.fromkeys(range(len(situations)), min(cap, FIRST_RECORDING))
        done = {}
        while steps:
            records = self.recordings([(situations[i][0], situations[i][2], reach)
                                       for i, reach in steps.items()])
            longer = {}
            for i, record in zip(steps, records, strict=True):
                reach = min(record.ids.shape[0] - 1, cap)
                with numba.parallel_chunksize(1):
                    runs = run_replay_population(
                        genes, self.layer_sizes, self._learner_physics(record.radius),
                        self.geometry, situations[i][1], record.ids, record.corners,
                        record.centres, reach)
                if reach >= cap or not (runs[1] == CAPPED).any():
                    done[i] = (runs, record)
                else:
                    longer[i] = reach * RECORDING_GROWTH
            steps = longer
        return [done[i] for i in range(len(situations))]

    def _learner_physics(self, radius: float) -> Physics:
        """The constants, with bodies as large as the traffic's largest (``radius``)."""
        return self.physics._replace(radius=max(radius, self.physics.radius))

    def evaluate(self, population: np.ndarray, key: int = 0) -> SituationResults:
        """Fitness of every chromosome: steps survived (0 for a spin), averaged over the
        traffic situations of ``key``."""
        genes = self.spec.in_source_layout(population)
        closed = self.scenario.traffic.mode == "closed-loop"
        runs, vehicles, at_start, safety, hit_vehicle, ends = [], [], [], [], [], []
        situations = list(zip(self.seeds(key), self.situation_starts(key), self.warmups(key),
                              strict=True))
        if not closed:  # every situation's recordings side by side
            replayed = self.replays(genes, situations)
        else:  # in fresh processes, a share of the situations each
            self._save_warm_ups(situations)
            closed_lives = fresh_shares(closed_loop_lives, situations, self.scenario, genes)
        for index in range(len(situations)):
            if closed:
                lives = closed_lives[index]
                runs.append([np.array([life[i] for life in lives], dtype=np.int64)
                             for i in range(6)])
                at_start.append(np.array([life.at_start for life in lives]))
                safety.append(np.array([[life.conflicts.min_ttc, life.conflicts.ttc,
                                         life.conflicts.drac, life.conflicts.pet,
                                         life.min_ttc_2d, life.ttc_2d_steps]
                                        for life in lives], dtype=np.float64).reshape(-1, 6))
                hit_vehicle.append(objects([life.hit_vehicle for life in lives]))
                ends.append(np.array([life.end for life in lives], dtype=np.float64))
                continue
            (*lives, end), record = replayed[index]
            runs.append(lives)
            ends.append(end)
            vehicles.append(record.mean_vehicles)
            at_start.append(int((record.ids[0] >= 0).sum()))
            hit_vehicle.append(named(runs[-1][5], record.names, record.types))
        if vehicles:
            self._traffic_seen = vehicles
        return SituationResults.of_situations(runs, self.vehicles, at_start,
                                            np.stack(safety, axis=1) if safety else None,
                                            np.stack(hit_vehicle, axis=1),
                                            np.stack(ends, axis=1))

    def _save_warm_ups(self, situations: list[tuple[int, np.ndarray, int | None]]) -> None:
        """Each closed-loop situation's warm-up saved before its lives run, each simulated
        in a fresh process: a life's process then always loads its state. On an empty
        cache the warm-up was simulated in the life's own process, just before it, and
        libsumo's leftovers changed the life (docs/sumo.md, "One SUMO start, one
        process"): 3 of 10 lifetimes of the crossing flows differed from a warm cache's."""
        missing = {(seed, warmup) for seed, _, warmup in situations
                   if not states.kept_state(self._state_of(seed, warmup))}
        fresh_calls([(situation_state, self.scenario, seed, warmup)
                     for seed, warmup in sorted(missing, key=repr)],
                    workers=WORKERS)

    def _state_of(self, seed: int, warmup: int | None) -> Path:
        """Where the state a closed-loop situation loads is kept (:meth:`live`)."""
        warm_seed = self._shared_warmup_seed(seed, warmup)
        if warm_seed is None:
            return states.state_path(self.scenario, seed, keep_rng=True)
        return states.state_path(self.scenario, warm_seed, keep_rng=False)

    def live(self, seed: int, start: np.ndarray | None = None, warmup: int | None = None,
             max_steps: int | None = None) -> LiveTraffic:
        """A live SUMO of situation ``seed`` with the learner in it at ``start`` (the world's
        first start by default), its SSM device recording conflicts. The situation's warm-up
        is simulated once and loaded from a SUMO state file by every later call."""
        limit = self.max_steps if max_steps is None else max_steps
        if (seed, warmup) not in self._states:  # found (or simulated) once, not per chromosome
            self._states[seed, warmup] = situation_state(self.scenario, seed, warmup, self)
        state = self._states[seed, warmup]
        if not self._checked:  # refuse traffic that never reaches the network
            states.first_traffic(self.scenario, seed, state, limit)
            self._checked = True
        start = np.asarray(self.start if start is None else start, dtype=np.float64)
        return LiveTraffic(self, Simulation(self.scenario, seed, state,
                                            extra=ssm.ssm_options()), start)

    def closed_loop(self, genes: np.ndarray, seed: int, max_steps: int | None = None,
                    frames: list | None = None, start: np.ndarray | None = None,
                    warmup: int | None = None) -> ClosedLoopLife:
        """One chromosome (source-layout genes) in a live SUMO (:meth:`live`); ``frames``
        receives (learner pose, ids, corners) of every step when given. A vehicle that leaves
        the learner's world (``gone``) stays in SUMO, unseen by the learner, as it does in a
        replay."""
        limit = self.max_steps if max_steps is None else max_steps
        live = self.live(seed, start, warmup, limit)
        try:
            kind = numba.typeof(genes)  # the other arguments' types are the world's own
            if kind not in self._steps:
                self._steps[kind] = compiled_step(0, genes, self.layer_sizes, live.physics,
                                                  self.geometry, live.ids, live.corners,
                                                  live.centres, live.before, live.now, limit,
                                                  live.state)
            step = self._steps[kind]
            least, below = math.inf, 0
            speed, dt = self.scenario.vehicle.speed, self.scenario.vehicle.dt
            while True:
                if frames is not None:
                    frames.append((live.state.learner.pose[0].copy(), live.ids[live.now].copy(),
                                   live.corners[live.now].copy()))
                heading = live.state.learner.pose[0, 2]
                ttc = least_time_to_contact(
                    live.state.learner.corners[0], speed * math.cos(heading),
                    speed * math.sin(heading), live.ids, live.state.gone, live.corners,
                    live.centres, live.before, live.now, dt, live.followed)
                least, below = min(least, ttc), below + (ttc < CONFLICT_TTC)
                outcome = step(live.t, genes, self.layer_sizes, live.physics, self.geometry,
                               live.ids, live.corners, live.centres, live.before, live.now,
                               limit, live.state)
                if outcome != RUNNING:
                    break
                live.advance()
        finally:
            conflicts = live.close()
        state, hit = live.state, int(live.state.hit[0])
        return ClosedLoopLife(live.t, int(outcome), int(state.suffered[0]), int(state.met[0]),
                              int(state.met[1]), hit, live.at_start, conflicts,
                              live.vehicle(hit), tuple(state.learner.pose[0].tolist()),
                              least, below)

    def trace(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
              max_steps: int | None = None) -> tuple[np.ndarray, int]:
        """Poses (n, 1 + S, 3) of the learner and of every SUMO vehicle slot (NaN where a
        slot is empty) in one life, and the learner's outcome code."""
        life = self.trace_life(chromosome, key, situation, max_steps)
        return life.poses, life.outcome

    def trace_life(self, chromosome: np.ndarray, key: int = 0, situation: int = 0,
                   max_steps: int | None = None) -> TracedLife:
        """:meth:`trace`, with what the learner ran into."""
        limit = self.max_steps if max_steps is None else max_steps
        seed = self.seeds(key)[situation]
        start = self.situation_starts(key)[situation]
        warmup = self.warmups(key)[situation]
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
            record = self.replay(genes[None], seed, start, warmup, limit)[1]  # as far as
            # this life reaches
            limit = min(limit, record.ids.shape[0] - 1)  # a replay ends with its recording
            learner = np.full((limit + 1, 3), np.nan)
            steps, outcome, *_, hit = run_replay_life(
                genes, self.layer_sizes, self._learner_physics(record.radius), self.geometry,
                start, record.ids, record.corners, record.centres, limit, learner, np.empty(3))
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


def recorded(scenario: Scenario, seed: int, warm_seed: int | None, steps: int,
             empty: bool) -> recording.Recording:
    """The SUMO run of ``seed`` from the shared warm-up of ``warm_seed`` (None: its own
    warm-up), ``steps`` steps (:func:`~enn_traffic.sumo.recording.record`): what
    :meth:`SumoWorld.recordings` runs in a fresh process."""
    state = None if warm_seed is None else states.warm_state(scenario, warm_seed, keep_rng=False)
    return recording.record(scenario, seed, steps, state, empty=empty)


def situation_state(scenario: Scenario, seed: int, warmup: int | None,
                    world: SumoWorld | None = None) -> Path:
    """The saved warm-up a closed-loop situation loads (:meth:`SumoWorld.live`; ``world``:
    the scenario's, made if not given), simulated if it is not on disk: also what
    :meth:`SumoWorld._save_warm_ups` runs in a fresh process."""
    world = SumoWorld(scenario) if world is None else world
    return world.warm_state(seed, warmup) or states.warm_state(scenario, seed, keep_rng=True)


def closed_loop_lives(scenario: Scenario, genes: np.ndarray,
                      situations: list[tuple[int, np.ndarray, int | None]]
                      ) -> list[list[ClosedLoopLife]]:
    """Every chromosome's closed-loop life (source-layout ``genes``) in each situation (SUMO
    seed, start, shared warm-up), one SUMO start after another in this process: what
    :meth:`SumoWorld.evaluate` runs in a fresh process (:mod:`enn_traffic.sumo.fresh`).
    Starts of one scenario in a row give what each gives in a process of its own; a start of
    another scenario before them would not (docs/sumo.md, "One SUMO start, one process")."""
    world = SumoWorld(scenario)
    return [[world.closed_loop(row, seed, start=start, warmup=warmup) for row in genes]
            for seed, start, warmup in situations]
