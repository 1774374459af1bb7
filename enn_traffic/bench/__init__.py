"""``enn-traffic bench``: throughput of the evaluation workloads, in vehicle-steps per second.

The navigation workload is the real one: the generations of a GA run on the narrow track
(19 beams, P = 200). It is timed with the compiled batch on all cores and on one core, and
against the plain per-vehicle Python loop of :mod:`enn_traffic.sim.reference` on chromosomes
of the same generations, in the same process, so machine drift cancels out of the ratio.
The arena and SUMO workloads are timed on the generations of GA runs too; SUMO replay counts
the time SUMO takes to record each generation's traffic, and SUMO closed loop is timed on one
process for an evolved controller, without SUMO's start and warm-up. The city workload (the
shipped Cologne scenario) counts everything, warm-ups included, and reports their share of
the wall time: with warm-ups shared and simulated once, and with each situation its own.
The gymnasium workload steps the compiled vector environment (:mod:`enn_traffic.envs`) of
256 and 4,096 narrow-track worlds with random actions, against gymnasium's ``SyncVectorEnv``
of the single environment in the same run. The SB3 workload times Stable-Baselines3's PPO
learning through the adapter of :mod:`enn_traffic.envs.sb3` (the docs/envs.md example)
beside the compiled vector environment of the same worlds. The network workload prepares
large random road networks (SUMO's netgenerate): walls and wall grid the first time and from
the cache, and the grid as it was built until issue 39 (every cell against every wall) in the
same run, with the peak memory of each.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import pickle
import re
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.envs import env_id
from enn_traffic.learning import ga
from enn_traffic.learning.evaluators import Evaluator, LocalEvaluator, ProcessEvaluator
from enn_traffic.roads import load_track
from enn_traffic.runs.run import ga_params
from enn_traffic.sim.reference import reference_life, reference_wall_grid
from enn_traffic.sim.sensors import WallGrid
from enn_traffic.sim.sumo.crowd import SumoCrowd
from enn_traffic.sim.world import World, make_world
from enn_traffic.sumo import command, ssm, states
from enn_traffic.sumo.learners import add_learner, learner_id, move_learner
from enn_traffic.sumo.simulation import Simulation


def _timed_batches(world: World | Evaluator, populations: list[np.ndarray]) -> tuple[int, float]:
    steps, seconds = 0, 0.0
    for population in populations:
        started = time.perf_counter()
        results = world.evaluate(population)
        seconds += time.perf_counter() - started
        steps += results.vehicle_steps
    return steps, seconds


def _workload(name: str):
    """A shipped scenario's world, GA settings, generator and first population, compiled."""
    scenario = shipped_scenario(name)
    world = make_world(scenario)
    rng = np.random.default_rng(scenario.seed)
    params = ga_params(scenario)
    population = ga.initial_population(
        rng, params.population_size, world.spec.chromosome_length, params.init_range
    )
    world.evaluate(population[:2])  # compile outside the timing
    return world, params, rng, population


def navigation_bench(generations: int = 30, reference_seconds: float = 10.0) -> pd.DataFrame:
    world, params, rng, population = _workload("navigation_narrow")
    populations = _ga_generations(world, params, rng, population, generations)
    threads = numba.get_num_threads()
    rows = []
    steps, seconds = _timed_batches(world, populations)
    rows.append(("compiled batch", threads, steps, seconds))
    numba.set_num_threads(1)
    try:
        steps, seconds = _timed_batches(world, populations)
    finally:
        numba.set_num_threads(threads)
    rows.append(("compiled batch", 1, steps, seconds))
    # The reference loop runs chromosomes drawn evenly from every generation until its time is up.
    order = np.random.default_rng(0).permutation(generations * params.population_size)
    pool = np.concatenate(populations)[order]
    steps, seconds, checked = 0, 0.0, []
    for chromosome in pool:
        started = time.perf_counter()
        checked.append(reference_life(world, chromosome))
        seconds += time.perf_counter() - started
        steps += checked[-1][0]
        if seconds > reference_seconds:
            break
    compiled = world.evaluate(pool[: len(checked)])
    pairs = zip(compiled.steps[:, 0].tolist(), compiled.outcome[:, 0].tolist(), strict=True)
    if list(pairs) != checked:
        raise RuntimeError("compiled and reference episodes disagree")
    rows.append(("plain Python reference", 1, steps, seconds))
    table = pd.DataFrame(rows, columns=["implementation", "threads", "vehicle_steps", "seconds"])
    table.insert(0, "workload", "navigation: narrow track, 19 beams, P=200")
    table["vehicle_steps_per_s"] = table["vehicle_steps"] / table["seconds"]
    reference = table["vehicle_steps_per_s"].iloc[-1]
    table["speedup_vs_reference"] = table["vehicle_steps_per_s"] / reference
    table.attrs["reference_chromosomes_checked"] = len(checked)
    return table


def arena_bench(generations: int = 10) -> pd.DataFrame:
    """The arena workload: P = 200 worlds × 8 vehicles (strategy 1, random-network traffic),
    over the generations of a real GA run; every vehicle's steps count."""
    world, params, rng, population = _workload("arena_strategy1")
    threads = numba.get_num_threads()
    steps, _, seconds, _ = _timed_generations(world, params, rng, population,
                                              range(generations))
    table = pd.DataFrame([("compiled batch", threads, steps, seconds)],
                         columns=["implementation", "threads", "vehicle_steps", "seconds"])
    table.insert(0, "workload", f"arena: P=200 worlds x {world.vehicles} vehicles, strategy 1")
    table["vehicle_steps_per_s"] = table["vehicle_steps"] / table["seconds"]
    table["speedup_vs_reference"] = np.nan
    return table


def env_bench(steps: int = 200, sync_seconds: float = 5.0) -> pd.DataFrame:
    """Gymnasium environments on the narrow track with random actions (issue 40): the
    compiled vector environment of 256 and 4,096 worlds against gymnasium's
    ``SyncVectorEnv`` of the single environment (256 of them), in the same run; a step of N
    worlds counts N env-steps (one vehicle each)."""
    import gymnasium as gym

    name = env_id("navigation_narrow")
    rng = np.random.default_rng(0)
    rows = []
    for count, mode in ((256, "vector_entry_point"), (4096, "vector_entry_point"),
                        (256, "sync")):
        env = gym.make_vec(name, num_envs=count, vectorization_mode=mode)
        env.reset(seed=0)
        actions = rng.uniform(-1, 1, (8, count, 2)).astype(np.float32)
        env.step(actions[0])  # compile outside the timing
        done, seconds = 0, 0.0
        while done < steps and (mode != "sync" or seconds < sync_seconds):
            started = time.perf_counter()
            env.step(actions[done % len(actions)])
            seconds += time.perf_counter() - started
            done += 1
        env.close()
        label = ("compiled vector env" if mode != "sync"
                 else "gymnasium SyncVectorEnv of the single env")
        threads = numba.get_num_threads() if mode != "sync" else 1
        rows.append((f"gymnasium env: narrow track, random actions, {count} worlds", label,
                     threads, done * count, done * count, seconds))
    table = _rate_table(rows)
    sync = table["vehicle_steps_per_s"].iloc[-1]
    table["speedup_vs_reference"] = table["vehicle_steps_per_s"] / sync
    return table


def contention_rates(seconds: float, rounds: int, loads: tuple[int, ...]
                     ) -> list[tuple[int, str, int, int, float]]:
    """In this process, for each number of busy processes in ``loads`` (started here once the
    kernels are loaded and warm, so that their start is not slowed by them): ``rounds`` times
    in turn with numba's default threads and with one, the compiled vector environment (256
    narrow-track worlds, zero actions) stepped for ``seconds``, and the navigation batch (the
    first generations of a GA run, P = 200); (load, workload, threads, env- or vehicle-steps,
    seconds) each."""
    import gymnasium as gym

    env = gym.make_vec(env_id("navigation_narrow"), num_envs=256,
                       vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    actions = np.zeros((256, 2), dtype=np.float32)
    env.step(actions)  # compile outside the timing
    world, params, rng, population = _workload("navigation_narrow")
    populations = _ga_generations(world, params, rng, population, 3)
    default = numba.get_num_threads()
    rows = []
    try:
        for load in loads:
            spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                        for _ in range(load)]
            try:
                for _ in range(rounds):
                    for threads in (default, 1):
                        numba.set_num_threads(threads)
                        done, started = 0, time.perf_counter()
                        while time.perf_counter() - started < seconds:
                            env.step(actions)
                            done += 256
                        rows.append((load, "vector env", threads, done,
                                     time.perf_counter() - started))
                        rows.append((load, "navigation batch", threads,
                                     *_timed_batches(world, populations)))
            finally:
                for spinner in spinners:
                    spinner.kill()
                    spinner.wait()
    finally:
        numba.set_num_threads(default)
        env.close()
    return rows


# OpenMP wait policies (libgomp's environment): its default, spelt out (300,000 spins before
# an idle thread sleeps; enn-traffic leaves it alone when GOMP_SPINCOUNT is set), and ours
CONTENTION_POLICIES = {
    "libgomp's default: idle threads spin, then sleep": {"GOMP_SPINCOUNT": "300000"},
    "enn-traffic's: idle threads sleep (OMP_WAIT_POLICY=PASSIVE)": {
        "OMP_WAIT_POLICY": "PASSIVE"}}


def contention_bench(quick: bool = False, busy: int = 2) -> pd.DataFrame:
    """The compiled kernels on a quiet machine and beside ``busy`` busy processes (issue 62:
    as under ``pytest -n 2``, a process pool, or a second user): :func:`contention_rates` in
    a fresh process for each OpenMP wait policy of :data:`CONTENTION_POLICIES`, the default
    threads against one thread in the same process, alternating; the median of the rounds,
    with the slowest and fastest. ``quick``: enn-traffic's policy beside the busy processes
    only, fewer and shorter rounds."""
    from enn_traffic.sumo.fresh import fresh_calls

    seconds, rounds = (0.5, 2) if quick else (2.0, 5)
    loads = (busy,) if quick else (0, busy)
    policies = list(CONTENTION_POLICIES.items())
    measured = []
    saved = {name: os.environ.get(name) for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    try:
        for policy, environment in policies[-1:] if quick else policies:
            for name in saved:
                os.environ.pop(name, None)
            os.environ.update(environment)
            measured += [(load, policy, *row) for load, *row in
                         fresh_calls([(contention_rates, seconds, rounds, loads)])[0]]
    finally:
        for name, value in saved.items():
            os.environ.pop(name, None)
            if value is not None:
                os.environ[name] = value
    runs = pd.DataFrame(measured, columns=["load", "implementation", "workload", "threads",
                                           "steps", "seconds"])
    runs["rate"] = runs["steps"] / runs["seconds"]
    keys = ["load", "workload", "implementation", "threads"]
    table = runs.groupby(keys, sort=False).agg(
        vehicle_steps=("steps", "sum"), seconds=("seconds", "sum"),
        vehicle_steps_per_s=("rate", "median"), steps_per_s_min=("rate", "min"),
        steps_per_s_max=("rate", "max"), runs=("rate", "size")).reset_index()
    one = table[table["threads"] == 1].set_index(keys[:3])["vehicle_steps_per_s"]
    table["vs_one_thread"] = [row.vehicle_steps_per_s / one[(row.load, row.workload,
                                                             row.implementation)]
                              for row in table.itertuples()]
    table["speedup_vs_reference"] = np.nan
    table["workload"] = [f"contention: {row.workload} (narrow track), "
                         + (f"beside {row.load} busy processes" if row.load else "quiet")
                         for row in table.itertuples()]
    return table.drop(columns="load")


def sb3_bench(learn_steps: int = 65_536, steps: int = 500) -> pd.DataFrame:
    """Stable-Baselines3 through :func:`~enn_traffic.envs.sb3.sb3_vec_env` (issue 52): the
    docs/envs.md example's PPO learning on 32 arena worlds, one torch thread, and the adapter
    stepped with random actions, against the compiled vector environment of the same 32
    worlds stepped alone, in the same run. Empty without the ``rl`` extra."""
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.vec_env import VecNormalize

        from enn_traffic.envs import make_vector_env
        from enn_traffic.envs.sb3 import sb3_vec_env
    except ImportError:
        return _rate_table([])
    torch.set_num_threads(1)
    worlds, rng = 32, np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (8, worlds, 2)).astype(np.float32)
    workload = f"SB3: arena strategy 1, {worlds} worlds"
    rows = []
    for label, env in (("compiled vector env, random actions",
                        make_vector_env("arena_strategy1", num_envs=worlds)),
                       ("SB3 VecEnv adapter, random actions",
                        sb3_vec_env(make_vector_env("arena_strategy1", num_envs=worlds)))):
        env.reset()
        for k in range(20):  # compile and warm the threads outside the timing
            env.step(actions[k % len(actions)])
        started = time.perf_counter()
        for k in range(steps):
            env.step(actions[k % len(actions)])
        seconds = time.perf_counter() - started
        rows.append((workload, label, numba.get_num_threads(), steps * worlds,
                     steps * worlds, seconds))
    venv = VecNormalize(sb3_vec_env(make_vector_env("arena_strategy1", num_envs=worlds)),
                        gamma=0.999)
    model = PPO("MlpPolicy", venv, n_steps=256, batch_size=1024, gamma=0.999, seed=1,
                device="cpu")
    started = time.perf_counter()
    model.learn(total_timesteps=learn_steps)
    seconds = time.perf_counter() - started
    rows.append((workload, "SB3 PPO learning (the docs/envs.md example)", 1,
                 model.num_timesteps, model.num_timesteps, seconds))
    table = _rate_table(rows)
    table["speedup_vs_reference"] = (table["vehicle_steps_per_s"]
                                     / table["vehicle_steps_per_s"].iloc[0])
    return table


def sumo_bench(generations: int = 10, closed_loop_steps: int = 10_000) -> pd.DataFrame:
    """SUMO strategy 1 (steady ring traffic): replay mode over the generations of a GA run,
    recording included; then the run's best controller in closed loop, one process, over
    episodes of new traffic until ``closed_loop_steps`` learner steps (SUMO's start and
    warm-up of each situation, timed apart, not counted)."""
    world, params, rng, population = _workload("sumo_strategy1")
    threads = numba.get_num_threads()
    # generation 0's traffic was recorded above
    steps, learner_steps, seconds, best = _timed_generations(world, params, rng, population,
                                                             range(1, generations + 1))
    rows = [(f"sumo replay: P=200 worlds x {world.vehicles} vehicles, strategy 1",
             "compiled batch + SUMO recording", threads, steps, learner_steps, seconds)]
    steps, seconds = _closed_loop(world.scenario, best, generations, closed_loop_steps)
    rows.append(("sumo closed loop: the best controller, strategy 1",
                 "libsumo step by step, 1 process", 1, steps, steps, seconds))
    steps, seconds = _crowd(world.scenario, best, generations, closed_loop_steps)
    learners = world.scenario.traffic.learners
    rows.append((f"sumo crowd: {learners} learners driving the best controller, strategy 1",
                 "libsumo step by step, 1 process", 1, steps, steps, seconds))
    return _rate_table(rows)


def recording_bench(generations: int = 2, cap: int | None = None,
                    before: bool = True) -> pd.DataFrame:
    """A SUMO scenario as docs/sumo.md's template writes it, the step cap left at its default
    (20,000 steps: 33 min of SUMO time; or ``cap``) while lives last seconds (issue 50):
    Cologne, P = 20, ``generations`` generations of a GA run, and a gymnasium environment's
    reset and random-policy life, with the whole cap recorded first (before) and recorded
    only as far as the lives reach (after), in the same run, each arm from no kept
    recording; the after arm alone without ``before``. The shared warm-ups are simulated
    before the timing."""
    from enn_traffic.config import EpisodeConfig
    from enn_traffic.envs.sumo import SumoEnv
    from enn_traffic.sim.sumo import world as sumo_world

    default = EpisodeConfig().max_steps
    cap = default if cap is None else cap
    what = "default cap" if cap == default else f"cap of {cap:,} steps"
    scenario = shipped_scenario("city_cologne3").with_overrides(
        episode={"max_steps": cap}, ga={"population_size": 20})
    rows, saved = [], sumo_world.FIRST_RECORDING
    arms = [(f"the whole cap recorded first ({cap:,} steps)", cap),
            ("recorded as far as the lives reach", saved)]
    for label, first in arms if before else arms[1:]:
        sumo_world.FIRST_RECORDING = first
        sumo_world.forget_recordings()  # the other arm's would serve this one
        try:
            world = make_world(scenario)
            rng = np.random.default_rng(scenario.seed)
            params = ga_params(scenario)
            population = ga.initial_population(rng, params.population_size,
                                               world.spec.chromosome_length, params.init_range)
            world.evaluate(population[:2], 0)  # compile and warm up outside the timing
            steps, learner_steps, seconds, _ = _timed_generations(
                world, params, rng, population, range(1, generations + 1))
            rows.append((f"sumo {what}: Cologne, P=20, {generations} generation"
                         f"{'s' if generations > 1 else ''}", label,
                         numba.get_num_threads(), steps, learner_steps, seconds))
            env = SumoEnv(scenario)
            actions = np.random.default_rng(1)
            started = time.perf_counter()
            env.reset(options={"key": generations + 1, "situation": 0})
            lived = 0
            while True:
                lived += 1
                *_, terminated, truncated, _ = env.step(actions.random(2))
                if terminated or truncated:
                    break
            rows.append((f"sumo env: a reset and a random-policy life, Cologne, {what}",
                         label, 1, lived, lived, time.perf_counter() - started))
            env.close()
        finally:
            sumo_world.FIRST_RECORDING = saved
            sumo_world.forget_recordings()
    table = _rate_table(rows)
    for workload in table["workload"].unique() if before else []:
        rows_of = table["workload"] == workload
        whole_cap = table.loc[rows_of, "seconds"].iloc[0]
        table.loc[rows_of, "speedup_vs_reference"] = whole_cap / table.loc[rows_of, "seconds"]
    return table


def _crowd(scenario, chromosome, generation: int, learner_steps: int) -> tuple[int, float]:
    """Learner steps and seconds of ``chromosome`` driving every learner of a SUMO crowd
    (:mod:`enn_traffic.sim.sumo.crowd`) in the first situation after ``generation`` until
    ``learner_steps`` steps; SUMO's start and the learners' entry are not timed."""
    world = make_world(scenario.with_overrides(traffic={"mode": "closed-loop"}))
    genes = np.tile(world.spec.in_source_layout(chromosome)[0], (scenario.traffic.learners, 1))
    seconds = learner_steps / scenario.traffic.learners * scenario.vehicle.dt
    with SumoCrowd(world, world.seeds(generation + 1)[0]) as crowd:
        crowd.run(scenario.vehicle.dt, genes)  # start SUMO, let the learners enter
        started = time.perf_counter()
        run = crowd.run(seconds, genes)
        elapsed = time.perf_counter() - started
    return (run.trace.shape[0] - 1) * scenario.traffic.learners, elapsed


def _timed_generations(world, params, rng, population, generations: range) -> tuple:
    """A GA run over ``generations``, its evaluations timed: vehicle steps, learner steps,
    seconds, and the best chromosome met."""
    seconds = 0.0

    def timed(population, generation):
        nonlocal seconds
        started = time.perf_counter()
        results = world.evaluate(population, generation)
        seconds += time.perf_counter() - started
        return results

    state = ga.GAState(generation=generations.start, population=population, rng=rng)
    run = ga.generations(state, timed, params)
    steps, learner_steps = 0, 0
    for _ in generations:
        state, _, results = next(run)
        steps += results.vehicle_steps
        learner_steps += int(results.steps.sum())
    best = state.best_chromosome if state.best_chromosome is not None else population[0]
    return steps, learner_steps, seconds, best


def _closed_loop(scenario, chromosome, generation: int, learner_steps: int,
                 count_start: bool = False) -> tuple[int, float]:
    """Learner steps and seconds of ``chromosome`` in closed loop over the traffic of the
    generations after ``generation`` until ``learner_steps`` steps; each situation's warm-up
    is simulated before the timing, and SUMO's start (loading that state) is counted only
    with ``count_start``."""
    closed = make_world(scenario.with_overrides(traffic={"mode": "closed-loop"}))
    genes = closed.spec.in_source_layout(chromosome)[0]
    closed.closed_loop(genes, closed.seeds(0)[0], max_steps=2)  # compile, check the traffic
    steps, seconds, last = 0, 0.0, generation + 100
    seeds: list[int] = []
    while steps < learner_steps and generation < last:
        if not seeds:
            generation += 1
            seeds = list(closed.seeds(generation))
        seed = seeds.pop()
        state = closed.warm_state(seed) or states.warm_state(closed.scenario, seed, keep_rng=True)
        started = time.perf_counter()
        steps += closed.closed_loop(genes, seed)[0]
        total = time.perf_counter() - started
        if not count_start:
            started = time.perf_counter()
            Simulation(closed.scenario, seed, state).close()
            total -= time.perf_counter() - started
        seconds += total
    return steps, seconds


def city_bench(generations: int = 10, closed_loop_steps: int = 5_000,
               own_warmups: bool = True) -> pd.DataFrame:
    """The shipped city scenario (Cologne, its .sumocfg as published, P = 100): replay over the
    generations of a GA run, warm-ups and recordings included, once with the scenario's shared
    warm-ups (simulated in the timing, into an empty state folder) and, with
    ``own_warmups``, once with each traffic situation warming up itself; then the run's best
    controller in closed loop, SUMO's start included. ``warmup_share``: the part of the wall
    time spent simulating warm-ups."""
    scenario = shipped_scenario("city_cologne3")
    saved_folder = os.environ.get(states.STATE_FOLDER_VARIABLE)
    rows = []
    try:
        with tempfile.TemporaryDirectory(prefix="enn-bench-states-") as folder:
            os.environ[states.STATE_FOLDER_VARIABLE] = folder
            arms = [("shared warm-ups", {}),
                    ("each situation its own warm-up", {"warmup_states": 0})]
            for label, settings in arms if own_warmups else arms[:1]:
                world = make_world(scenario.with_overrides(traffic=settings))
                rows.append(_city_replay(world, label, generations))
            best = rows[0][-1]
            # closed loop: its situations' warm-ups are simulated before the timing
            steps, seconds = _closed_loop(scenario, best, generations, closed_loop_steps,
                                          count_start=True)
    finally:
        if saved_folder is None:
            os.environ.pop(states.STATE_FOLDER_VARIABLE, None)
        else:
            os.environ[states.STATE_FOLDER_VARIABLE] = saved_folder
    table = _rate_table([row[:-2] for row in rows] + [
        ("city closed loop: the best controller", "libsumo step by step, 1 process, SUMO "
         "start included", 1, steps, steps, seconds)])
    table["warmup_share"] = [row[-2] for row in rows] + [np.nan]
    return table


def _city_replay(world, label: str, generations: int) -> tuple:
    """Replay generations of a GA run on the city: the rate row, the warm-up share and the
    best chromosome."""
    scenario = world.scenario
    rng = np.random.default_rng(scenario.seed)
    params = ga_params(scenario)
    population = ga.initial_population(rng, params.population_size,
                                       world.spec.chromosome_length, params.init_range)
    started = time.perf_counter()
    if scenario.traffic.warmup_states:
        for seed in range(scenario.traffic.warmup_states):  # every shared warm-up, once
            world.warm_state(seed)
        warmup = time.perf_counter() - started
    else:  # one warm-up alone, timed, prices each situation's own warm-up
        simulation = Simulation(scenario, 1)
        simulation.step(states.warmup_steps(scenario))
        simulation.close()
        warmup = (time.perf_counter() - started) * scenario.traffic.episodes * generations
    world.evaluate(population[:2], generations + 1)  # compile outside the timing
    steps, learner_steps, seconds, best = _timed_generations(world, params, rng, population,
                                                             range(generations))
    total = seconds + (warmup if scenario.traffic.warmup_states else 0.0)
    return (f"city replay: Cologne, P={params.population_size}", label, numba.get_num_threads(),
            steps, learner_steps, total, warmup / total, best)


def _rate_table(rows: list[tuple]) -> pd.DataFrame:
    """Rows (workload, implementation, threads, vehicle steps, learner steps, seconds), with
    steps per second."""
    table = pd.DataFrame(rows, columns=["workload", "implementation", "threads",
                                        "vehicle_steps", "learner_steps", "seconds"])
    table["vehicle_steps_per_s"] = table["vehicle_steps"] / table["seconds"]
    table["learner_steps_per_s"] = table["learner_steps"] / table["seconds"]
    table["speedup_vs_reference"] = np.nan
    return table


def _ga_generations(world, params, rng, population, generations: int) -> list[np.ndarray]:
    """The populations of the first ``generations`` generations of a GA run."""
    run = ga.generations(ga.GAState(generation=0, population=population, rng=rng),
                         lambda population, _: world.evaluate(population), params)
    return [evaluated for _, evaluated, _ in itertools.islice(run, generations)]


def lane_keeping_bench(generations: int = 3) -> pd.DataFrame:
    """highway-env lane keeping: environment steps per second, in this process and over a
    process pool (one environment per worker), on the generations of a GA run."""
    world, params, rng, population = _workload("lane_keeping")
    populations = _ga_generations(world, params, rng, population, generations)
    rows = []
    for name, evaluator in (("one process", LocalEvaluator(world.scenario)),
                            ("process pool", ProcessEvaluator(world.scenario))):
        try:
            evaluator.evaluate(populations[0][:2])  # start the workers outside the timing
            steps, seconds = _timed_batches(evaluator, populations)
        finally:
            evaluator.close()
        workers = getattr(evaluator, "workers", 1)
        rows.append(("lane keeping: highway-env, P=40", name, workers, steps, steps, seconds))
    return _rate_table(rows)


def _generated(name: str, make: Callable[[Path], None]) -> Path:
    """The folder of a network the bench generates (netgenerate and randomTrips take seconds
    each): ``make(folder)`` writes it once into the cache folder
    (:func:`~enn_traffic.core.cache.cache_folder`), kept under ``name``, which holds every setting
    it is made with, and SUMO's version; later benches read it from there."""
    from importlib.metadata import version

    from enn_traffic.core.cache import cache_folder

    folder = cache_folder() / f"bench-nets-sumo{version('eclipse-sumo')}" / name
    if not folder.is_dir():
        folder.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=folder.parent, prefix=".partial-",
                                         ignore_cleanup_errors=True) as partial:
            make(Path(partial))
            try:
                Path(partial).rename(folder)
            except OSError:  # another bench made it meanwhile
                if not folder.is_dir():
                    raise
    return folder


def _random_roads(net: Path, iterations: int, *options: str) -> None:
    """SUMO's netgenerate (the eclipse-sumo wheel's) writes ``net``: a random road network of
    ``iterations`` growth steps, two lanes each way, roads of 80-200 m; ``options`` add to
    its command."""
    import sumo as sumo_wheel

    subprocess.run([f"{sumo_wheel.SUMO_HOME}/bin/netgenerate", "--rand",
                    "--rand.iterations", str(iterations), "--rand.max-distance", "200",
                    "--rand.min-distance", "80", "-L", "2", "--seed", "7", *options,
                    "-o", str(net)], check=True, capture_output=True)


def _random_city(iterations: int) -> Path:
    """:func:`_random_roads` of ``iterations`` growth steps (:func:`_generated`)."""
    return _generated(f"random{iterations}", lambda folder: _random_roads(
        folder / "random.net.xml", iterations)) / "random.net.xml"


def _city_with_lights(iterations: int, period_s: float) -> tuple[Path, Path]:
    """A random city (:func:`_random_roads`) whose junctions have actuated traffic lights
    where netgenerate guesses them, as OSM-built cities do, and random car trips departing
    every ``period_s`` seconds for an hour (SUMO's randomTrips; :func:`_generated`)."""
    import sumo as sumo_wheel

    def make(folder: Path) -> None:
        _random_roads(folder / "lights.net.xml", iterations, "--tls.guess",
                      "--tls.default-type", "actuated")
        subprocess.run([sys.executable, f"{sumo_wheel.SUMO_HOME}/tools/randomTrips.py", "-n",
                        "lights.net.xml", "-o", "lights.trips.xml", "--period",
                        f"{period_s:g}", "--end", "3600", "--seed", "7", "--fringe-factor",
                        "10", "--min-distance", "500"],
                       check=True, capture_output=True, cwd=folder)  # its routes.rou.xml too

    folder = _generated(f"lights{iterations}-period{period_s:g}", make)
    return folder / "lights.net.xml", folder / "lights.trips.xml"


def sumo_step_seconds(source: list[str], learners: int, steps: int, warmup_steps: int,
                      speed_factor: float | None = None) -> tuple[float, int, int]:
    """Seconds per SUMO step (moving the learners included) after ``warmup_steps`` steps of
    0.1 s, of SUMO started on ``source`` (``["-c", "city.sumocfg"]``, or a network and route
    files), with ``learners`` learners in SUMO as the closed loop puts them there
    (:func:`sumo.add_learner`, SSM devices, each moved along a lane of its own at 10 m/s by
    :func:`sumo.move_learner`); their vehicle type's speed factor ``speed_factor`` (default:
    :func:`sumo.add_learner`'s, :func:`sumo.learner_speed_factor`). Also the
    network's lanes (internal lanes excepted) and the vehicles on it when the timing
    starts."""
    import libsumo

    with tempfile.TemporaryDirectory(prefix="enn-bench-sumo-") as folder:
        libsumo.start(["sumo", *source, "--seed", "1", "--step-length", "0.1",
                       "--no-step-log", "true", "--no-warnings", "true", "--verbose", "false",
                       "--duration-log.statistics", "false", "--gui-settings-file", "",
                       "--collision.action", "none",
                       "--output-prefix", command.output_prefix(Path(folder)),
                       *ssm.ssm_options(tuple(learner_id(k) for k in range(learners)))])
        try:
            for _ in range(warmup_steps):
                libsumo.simulationStep()
            lanes = sorted(lane for lane in libsumo.lane.getIDList()
                           if not lane.startswith(":") and libsumo.lane.getLength(lane) > 60
                           and (not libsumo.lane.getAllowed(lane)  # every class
                                or "passenger" in libsumo.lane.getAllowed(lane)))
            paths = []
            for k in range(learners):
                lane = lanes[k * len(lanes) // max(learners, 1)]
                edge, index = lane.rsplit("_", 1)
                paths.append((edge, int(index), libsumo.lane.getLength(lane)))
                add_learner(4.3, 1.7, 10.0, learner_id(k))
            if learners and speed_factor is not None:
                libsumo.vehicletype.setSpeedFactor(command.LEARNER_TYPE, speed_factor)
            vehicles = libsumo.vehicle.getIDCount() - learners
            started = time.perf_counter()
            for t in range(steps):
                for k, (edge, index, length) in enumerate(paths):
                    along = 1.0 + t % (length - 2.0)  # back and forth along the lane
                    x, y = libsumo.simulation.convert2D(edge, along, index)
                    ahead = libsumo.simulation.convert2D(edge, along + 1.0, index)
                    move_learner(x, y, math.atan2(ahead[1] - y, ahead[0] - x),
                                      learner_id(k))
                libsumo.simulationStep()
            seconds = (time.perf_counter() - started) / steps
            lanes = sum(not lane.startswith(":") for lane in libsumo.lane.getIDList())
            return seconds, lanes, vehicles
        finally:
            libsumo.close()


def sumo_step_table(source: list[str], name: str, steps: int, warmup_steps: int,
                    repeats: int, before_steps: int = 0) -> pd.DataFrame:
    """:func:`sumo_step_seconds` without a learner, with one and with eight, one after another
    ``repeats`` times (the median kept, and the fastest and slowest run: machine drift hits
    every count alike, but a run's step time on a shared machine varies by a quarter and
    more), each start in
    a fresh process (libsumo keeps state between starts in one process); with
    ``before_steps``, also one learner at the speed factor of 100 used before issue 60."""
    from enn_traffic.sumo.fresh import fresh_calls

    counts = (0, 1, 8)
    calls = [(sumo_step_seconds, source, learners, steps, warmup_steps)
             for _ in range(repeats) for learners in counts]
    if before_steps:
        calls.append((sumo_step_seconds, source, 1, before_steps, warmup_steps, 100.0))
    measured = fresh_calls(calls)
    lanes, vehicles = measured[0][1:]
    runs = {learners: [m[0] for m, call in zip(measured, calls, strict=True)
                       if call[2] == learners and len(call) == 5] for learners in counts}
    rows = [(f"{learners} learner{'s' * (learners != 1)}", runs[learners], steps)
            for learners in counts]
    if before_steps:
        rows.append(("1 learner, speed factor 100 (before issue 60)", [measured[-1][0]],
                     before_steps))
    base = float(np.median(runs[0]))
    return pd.DataFrame([{
        "workload": f"SUMO step: {name}, {lanes:,} lanes, {vehicles:,} vehicles",
        "implementation": label, "threads": 1, "seconds": float(np.median(times)) * count,
        "steps": count, "runs": len(times), "ms_per_step": 1000 * float(np.median(times)),
        "ms_per_step_min": 1000 * min(times), "ms_per_step_max": 1000 * max(times),
        "slowdown_vs_no_learner": float(np.median(times)) / base}
        for label, times, count in rows])


def sumo_step_bench(quick: bool = False) -> pd.DataFrame:
    """SUMO's own step time on a city of thousands of lanes with actuated lights, without a
    learner, with one and with eight (issue 60: a learner once slowed SUMO 150-fold)."""
    net, trips = _city_with_lights(150 if quick else 1500, 0.5)
    return sumo_step_table(["-n", str(net), "-r", str(trips)],
                           "random city with actuated lights", 50 if quick else 300,
                           600 if quick else 3000, 1 if quick else 3, 0 if quick else 3)


def crowd_scale_seconds(net: Path, trips: Path, learners: int, steps: int) -> dict:
    """``learners`` learners in one SUMO of the city ``net`` (its ``trips``; closed loop, after
    300 s of warm-up), each driving a random network of its own for ``steps`` steps, SUMO's
    start and the learners' entry not timed: the seconds, those inside SUMO's own step, those
    inside the learners' two compiled calls (blame and sensing, :mod:`enn_traffic.sim.sumo.crowd`),
    and the process's peak resident memory (libsumo runs in it). Run in a fresh process."""
    import resource

    from enn_traffic.config import load_scenario
    from enn_traffic.sim.sumo import crowd as sumo_crowd

    inside = {"sumo": 0.0, "kernels": 0.0}

    def timed(call, part):
        def wrapped(*args):
            started = time.perf_counter()
            result = call(*args)
            inside[part] += time.perf_counter() - started
            return result
        return wrapped

    with tempfile.TemporaryDirectory(prefix="enn-bench-crowd-") as folder:
        path = Path(folder) / "city.toml"
        path.write_text(f'name = "city"\n[track]\nnet = "{net}"\nstart_lane = "auto"\n'
                        f'[traffic]\nstrategy = "sumo"\nroutes = ["{trips}"]\n'
                        f'mode = "closed-loop"\nwarmup_s = 300.0\nwarmup_states = 1\n'
                        f"learners = {learners}\n")
        scenario = load_scenario(path)
        world = make_world(scenario)
        genes = world.spec.in_source_layout(np.random.default_rng(learners).uniform(
            -1, 1, (learners, world.spec.chromosome_length)))
        with SumoCrowd(world, world.seeds(1)[0]) as crowd:
            crowd.run(scenario.vehicle.dt, genes)  # start SUMO, let the learners enter
            crowd.simulation.step = timed(crowd.simulation.step, "sumo")
            kernels = sumo_crowd.learner_events, sumo_crowd.drive
            sumo_crowd.learner_events = timed(kernels[0], "kernels")
            sumo_crowd.drive = timed(kernels[1], "kernels")
            vehicles = int((crowd.slots[0][crowd.now] >= 0).sum())  # SUMO's, when timed
            started = time.perf_counter()
            try:
                crowd.run(steps * scenario.vehicle.dt, genes)
            finally:
                sumo_crowd.learner_events, sumo_crowd.drive = kernels
            seconds = time.perf_counter() - started
    return {"seconds": seconds, "sumo_seconds": inside["sumo"],
            "kernel_seconds": inside["kernels"], "vehicles": vehicles,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def crowd_scale_bench(quick: bool = False) -> pd.DataFrame:
    """Learners in one city SUMO (issue 63): learner-steps per second, SUMO's own share of the
    time, the learners' compiled calls per learner-step and the peak memory as the learners
    grow, each count in a fresh process, on the random city with actuated lights of the SUMO
    step rows."""
    from enn_traffic.sumo.fresh import fresh_calls

    net, trips = _city_with_lights(150 if quick else 1500, 0.5)
    counts = (8, 32, 100) if quick else (8, 32, 100, 300, 1000)
    steps = 100 if quick else 600
    measured = fresh_calls([(crowd_scale_seconds, net, trips, k, steps) for k in counts])
    import sumolib

    lanes = sum(not lane.getID().startswith(":") for edge in sumolib.net.readNet(
        str(net)).getEdges() for lane in edge.getLanes())
    return pd.DataFrame([{
        "workload": f"learners in one city SUMO: random city with actuated lights, {lanes:,} "
                    f"lanes, {m['vehicles']:,} vehicles",
        "implementation": f"{k} learners", "threads": numba.get_num_threads(),
        "seconds": m["seconds"], "steps": steps, "learner_steps": k * steps,
        "learner_steps_per_s": k * steps / m["seconds"],
        "ms_per_step": 1000 * m["seconds"] / steps,
        "sumo_ms_per_step": 1000 * m["sumo_seconds"] / steps,
        "kernel_us_per_learner_step": 1e6 * m["kernel_seconds"] / (k * steps),
        "peak_memory_mb": m["peak_mb"]} for k, m in zip(counts, measured, strict=True)])


CROWD_TABLES = ("crowd_situations.csv", "table3.csv", "table4.csv", "table4_learners.csv",
                "table4_learning.csv")


def crowd_ray_bench(learners: int = 100, situations: int = 10) -> pd.DataFrame:
    """``enn-traffic crowd`` with ``learners`` learners in each of ``situations`` situations
    (one SUMO each, ``learners`` × ``situations`` in all) on the random city with actuated
    lights, once with ``--executor local`` (the situations one after another) and once with
    ``--executor ray`` (a local Ray, a worker per core), each a whole command into an empty
    folder, timed; ``identical``: every table the same."""
    net, trips = _city_with_lights(150, 0.5)
    with tempfile.TemporaryDirectory(prefix="enn-bench-crowd-ray-") as folder:
        scenario = Path(folder) / "city.toml"
        scenario.write_text(
            f'name = "random_city"\n[track]\nnet = "{net}"\nstart_lane = "auto"\n'
            "[ga]\npopulation_size = 10\ngenerations = 1\nelite_count = 2\n"
            "[episode]\nmax_steps = 600\n"
            f'[traffic]\nstrategy = "sumo"\nroutes = ["{trips}"]\nwarmup_s = 300.0\n'
            f"warmup_states = 2\nepisodes = 1\nlearners = {learners}\n"
            "[crowd]\nlearning_s = 20.0\nwindow_s = 10.0\npopulation_size = 10\n"
            f"elite_count = 2\nsituations = {situations}\nvalidation_situations = 0\n")
        seconds = {}
        for executor in ("local", "ray"):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "enn_traffic", "crowd", str(scenario),
                            "--out", str(Path(folder) / executor), "--executor", executor,
                            "--quiet"], check=True)
            seconds[executor] = time.perf_counter() - started
        identical = all(pd.read_csv(Path(folder) / "local" / name).equals(
            pd.read_csv(Path(folder) / "ray" / name)) for name in CROWD_TABLES)
    return pd.DataFrame([{
        "workload": f"crowd across SUMOs: random city with actuated lights, {learners} learners "
                    f"x {situations} situations ({learners * situations:,} learners)",
        "implementation": label, "threads": numba.get_num_threads(),
        "seconds": seconds[executor], "learners": learners * situations,
        "identical": identical}
        for executor, label in (("local", "--executor local (one after another)"),
                                ("ray", f"--executor ray ({os.cpu_count()} workers)"))])


def _folder_state(folder: Path) -> dict[str, tuple]:
    """Every file under ``folder``: its size, modification time and SHA-256."""
    from enn_traffic.core.cache import file_digest

    return {str(path.relative_to(folder)): (path.stat().st_size, path.stat().st_mtime_ns,
                                            file_digest(path))
            for path in sorted(folder.rglob("*")) if path.is_file()}


def published_check(scenario: Path, name: str, work: Path, generations: int = 2
                    ) -> pd.DataFrame:
    """A user's published scenario as the docs' template runs it: ``enn-traffic run`` for
    ``generations`` generations, then a closed-loop ``evaluate`` of its best controller,
    each timed as a command (wall seconds, caches as they are), and whether the scenario's
    own folder (its ``.sumocfg``'s) is byte-identical after (issue 60's check)."""
    from enn_traffic.config import load_scenario

    folder = load_scenario(scenario).traffic.sumocfg.parent
    before = _folder_state(folder)
    commands = {"run": ["run", str(scenario), "--generations", str(generations), "--out",
                        str(work / "run"), "--force", "--quiet"],
                "closed-loop evaluate": ["evaluate", str(work / "run" / "best.npz"),
                                         str(scenario), "--mode", "closed-loop", "--out",
                                         str(work / "closed.csv"), "--quiet"]}
    rows = []
    for label, arguments in commands.items():
        started = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "enn_traffic", *arguments],
                              capture_output=True, text=True, check=False)
        rows.append({"scenario": name, "command": label,
                     "seconds": time.perf_counter() - started, "exit_status": done.returncode})
    closed = pd.read_csv(work / "closed.csv")
    generations_csv = pd.read_csv(work / "run" / "generations.csv")
    for row in rows:
        row["folder_unchanged"] = _folder_state(folder) == before
    rows[0]["detail"] = (f"{len(generations_csv)} generations, best "
                         f"{int(generations_csv['best_fitness'].max())} steps")
    life = closed.iloc[0]
    rows[1]["detail"] = (f"{int(life['steps'])} steps, {life['outcome']}"
                         + (f" with {life['hit_vehicle']} ({life['hit_type']})"
                            if life["hit"] == "vehicle" else "")
                         + f" at ({life['end_x_m']:.1f}, {life['end_y_m']:.1f}) on edge "
                         f"{life['end_edge']}, SUMO time {life['end_sumo_time_s']:g} s"
                         + f"; SSM: lowest TTC {life['min_ttc_s']:g} s, "
                         f"{int(life['ttc_conflicts'])} TTC conflicts")
    return pd.DataFrame(rows)


def _measured(work, memory: bool = True) -> tuple[float, float, object]:
    """Seconds and peak memory (MB of Python and numpy allocations, by tracemalloc; NaN when
    not ``memory``: tracing doubles the time of many small allocations, and does not see
    GEOS's) of ``work()``, and its value."""
    if memory:
        tracemalloc.start()
    started = time.perf_counter()
    value = work()
    seconds = time.perf_counter() - started
    peak = tracemalloc.get_traced_memory()[1] / 2**20 if memory else np.nan
    if memory:
        tracemalloc.stop()
    return seconds, peak, value


def network_bench(quick: bool = False) -> pd.DataFrame:
    """Preparing a large network: its walls and the wall grid, built the first time and
    loaded from the cache after; the grid also as it was built until issue 39 (cells ×
    walls), in the same run, on a network where that takes seconds. ``quick``: a smaller
    network, without the grid as it was built before issue 39."""
    reach = 29.5  # the default sensor's: 25 m range, a 4.3 m body, 1 m spare
    rows = []

    def row(workload: str, implementation: str, seconds: float, memory: float,
            reference: float | None = None) -> None:
        rows.append({"workload": workload, "implementation": implementation, "threads": 1,
                     "seconds": seconds, "peak_memory_mb": memory,
                     "speedup_vs_reference": np.nan if reference is None
                     else reference / seconds})

    sizes = ((150, False),) if quick else ((100, True), (1500, False))
    nets = [_random_city(iterations) for iterations, _ in sizes]
    with tempfile.TemporaryDirectory(prefix="enn-bench-network-") as folder:
        environment = os.environ.get("ENN_TRAFFIC_CACHE")
        os.environ["ENN_TRAFFIC_CACHE"] = str(Path(folder) / "cache")  # cold, then warm
        try:
            for net, (_, with_reference) in zip(nets, sizes, strict=True):
                walls_s, _, track = _measured(lambda n=net: load_track(n, exits=True), False)
                grid_s, grid_mb, grid = _measured(lambda t=track: WallGrid.cached(t.walls,
                                                                                reach))
                workload = (f"network: random city, {len(track.walls):,} walls, "
                            f"{grid.cells_x * grid.cells_y:,} cells")
                reference = None
                if with_reference:
                    reference, memory, _ = _measured(
                        lambda t=track: reference_wall_grid(t.walls, reach))
                    row(workload, "grid: cells × walls (before issue 39)", reference, memory)
                row(workload, "grid: walls binned into cells", grid_s, grid_mb, reference)
                row(workload, "walls and grid, first time", walls_s + grid_s, np.nan)
                again, memory, _ = _measured(lambda n=net: WallGrid.cached(
                    load_track(n, exits=True).walls, reach))
                row(workload, "walls and grid, from the cache", again, memory)
        finally:
            if environment is None:
                del os.environ["ENN_TRAFFIC_CACHE"]
            else:
                os.environ["ENN_TRAFFIC_CACHE"] = environment
    return pd.DataFrame(rows)


def first_run_bench(runs: int = 2) -> pd.DataFrame:
    """The README's main command as a new user runs it (issue 62): ``enn-traffic run
    navigation_narrow`` with an empty cache folder (numba compiles the kernels), then
    ``runs - 1`` times more with the kernels it cached; each timed as a whole command."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="enn-bench-first-") as folder:
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache")}
        env.pop("NUMBA_CACHE_DIR", None)  # derived from the empty cache folder
        for run in range(runs):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-m", "enn_traffic", "run", "navigation_narrow",
                            "--out", str(Path(folder) / f"run{run}"), "--quiet"],
                           env=env, check=True, capture_output=True)
            rows.append({"workload": "first contact: enn-traffic run navigation_narrow "
                         "(P=200, 50 generations)",
                         "implementation": "empty cache: numba compiles" if run == 0
                         else "kernels from the cache", "threads": numba.get_num_threads(),
                         "seconds": time.perf_counter() - started})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table


# A new interpreter that runs one pickled call from its standard input: how every fresh
# process started before the zygote of :mod:`enn_traffic.sumo.fresh` (issue 62).
_NEW_INTERPRETER = ("import pickle, sys; function, args = pickle.loads(sys.stdin.buffer.read()); "
                    "function(*args)")


_ZYGOTE_START = """
import os, time
from enn_traffic.sumo import fresh
started = time.perf_counter()
fresh.fresh(os.getpid)
print(time.perf_counter() - started)
"""


def fresh_bench(calls: int = 4, before: bool = True) -> pd.DataFrame:
    """A fresh process (docs/sumo.md, "One SUMO start, one process") for one arm of a Table
    3–4 situation (SUMO strategy 1, its learners driving random controllers for 10 s): forked
    from the zygote against a new interpreter running the same call, ``calls`` times each in
    turn (without ``before``, the zygote alone); seconds per call, SUMO's start and the drive
    included. The zygote's own start (once per calling process) is timed apart."""
    from enn_traffic.experiments.crowds.sumo import _driving_arm
    from enn_traffic.sumo import fresh

    world = make_world(shipped_scenario("sumo_strategy1").with_overrides(
        traffic={"mode": "closed-loop"}))
    genes = world.spec.in_source_layout(np.random.default_rng(0).uniform(
        -1, 1, (world.scenario.traffic.learners, world.spec.chromosome_length)))
    call = (_driving_arm, world.scenario, world.seeds(1)[0], genes, 10.0, 1)
    # The zygote's start in a new calling process: in this one, a zygote that earlier
    # workloads started would serve at once.
    zygote_start = float(subprocess.run(
        [sys.executable, "-c", _ZYGOTE_START], check=True, capture_output=True,
        text=True).stdout)
    fresh.fresh(os.getpid)  # this process's zygote, started outside the timing
    env = fresh.child_environment()
    job = pickle.dumps((call[0], call[1:]))
    seconds: dict[str, list[float]] = {"forked from the zygote": []}
    if before:
        seconds["a new interpreter"] = []
    for _ in range(calls):
        started = time.perf_counter()
        fresh.fresh(*call)
        seconds["forked from the zygote"].append(time.perf_counter() - started)
        if not before:
            continue
        started = time.perf_counter()
        subprocess.run([sys.executable, "-c", _NEW_INTERPRETER], input=job, env=env,
                       check=True, capture_output=True)
        seconds["a new interpreter"].append(time.perf_counter() - started)
    workload = "fresh process: one Table 3-4 arm (sumo_strategy1, 8 learners, 10 s)"
    rows = [{"workload": workload, "implementation": name, "threads": numba.get_num_threads(),
             "calls": calls, "seconds": float(np.median(times)), "seconds_min": min(times),
             "seconds_max": max(times)} for name, times in seconds.items()]
    rows.append({"workload": "fresh process: the zygote's start, once per calling process",
                 "implementation": "started by a new calling process",
                 "threads": numba.get_num_threads(), "calls": 1, "seconds": zygote_start,
                 "seconds_min": zygote_start, "seconds_max": zygote_start})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    if before:
        table.loc[0, "speedup_vs_reference"] = table.loc[1, "seconds"] / table.loc[0, "seconds"]
    return table


def reproduce_quick_bench() -> pd.DataFrame:
    """``enn-traffic reproduce --quick`` into an empty folder with an empty cache folder (SUMO's
    warm-ups simulated again) and the kernels numba compiled before (once per install),
    timed as a whole command; and each experiment's wall time from its ``summary.json``."""
    with tempfile.TemporaryDirectory(prefix="enn-bench-reproduce-") as folder:
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache"),
               "NUMBA_CACHE_DIR": os.environ["NUMBA_CACHE_DIR"]}
        out = Path(folder) / "out"
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "enn_traffic", "reproduce", "--quick", "--out",
                        str(out)], env=env, check=True, capture_output=True)
        total = time.perf_counter() - started
        records = json.loads((out / "summary.json").read_text())
    rows = [{"workload": "reproduce --quick", "implementation": name,
             "threads": numba.get_num_threads(), "seconds": record["seconds"]}
            for name, record in records.items()]
    rows.append({"workload": "reproduce --quick", "implementation": "the whole command",
                 "threads": numba.get_num_threads(), "seconds": total})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table


def bench_quick_bench() -> pd.DataFrame:
    """``enn-traffic bench --quick`` timed as a whole command, as a user's second call meets
    it (issue 62): a first call, untimed, leaves the kernels compiled and the networks the
    bench generates in the cache folder. One row: the second call's seconds and how many rows
    its table has."""
    with tempfile.TemporaryDirectory(prefix="enn-bench-quick-") as folder:
        table = Path(folder) / "quick.csv"
        subprocess.run([sys.executable, "-m", "enn_traffic", "bench", "--quick", "--out",
                        str(table)], check=True, capture_output=True)  # networks, kernels
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "enn_traffic", "bench", "--quick", "--out",
                        str(table)], check=True, capture_output=True)
        total = time.perf_counter() - started
        rows = len(pd.read_csv(table))
    return pd.DataFrame([{"workload": "bench --quick", "implementation": "the whole command",
                          "threads": numba.get_num_threads(), "rows": rows, "seconds": total,
                          "speedup_vs_reference": np.nan}])


def test_suite_bench() -> pd.DataFrame:
    """The README's test command (``pytest``, its install not timed) in a fresh clone of the
    project's git checkout, as a contributor meets it (issue 62): first with empty caches
    (numba compiles every kernel, SUMO's warm-ups are simulated, pytest's cache is new), then
    again in the same clone (warm). The clone's package is the one imported, by the tests and
    by the commands they start. Needs the source checkout (an installed wheel has no tests)."""
    from enn_traffic.core.errors import InputError

    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists() or not (root / "tests").is_dir():
        raise InputError("times the README's test command in a clone of the project's git "
                         f"checkout; {root} is not one (an installed package has no tests)",
                         key="test_suite")
    rows = []
    with tempfile.TemporaryDirectory(prefix="enn-bench-tests-") as folder:
        clone = Path(folder) / "clone"
        subprocess.run(["git", "clone", "--quiet", str(root), str(clone)], check=True)
        env = {**os.environ, "ENN_TRAFFIC_CACHE": str(Path(folder) / "cache"),
               "PYTHONPATH": str(clone)}
        env.pop("NUMBA_CACHE_DIR", None)  # derived from the empty cache folder
        for cache in ("empty caches: numba compiles, SUMO warms up", "warm: the same clone again"):
            started = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "pytest", "-rf"], cwd=clone, env=env,
                                  capture_output=True, text=True)
            seconds = time.perf_counter() - started
            lines = done.stdout.strip().splitlines() or [""]
            last = lines[-1]
            if done.returncode != 0:
                failed = "\n".join(line for line in lines if line.startswith("FAILED"))
                raise RuntimeError(f"pytest failed in the clone ({last}):\n{failed}")
            passed = re.search(r"(\d+) passed", last)
            rows.append({"workload": "the README's test command: pytest (2 workers)",
                         "implementation": cache, "threads": numba.get_num_threads(),
                         "rows": int(passed.group(1)) if passed else np.nan,
                         "seconds": seconds})
    table = pd.DataFrame(rows)
    table["speedup_vs_reference"] = np.nan
    return table


def workloads(quick: bool = False) -> dict[str, Callable[[], pd.DataFrame]]:
    """Every workload by the name ``bench --only`` takes, in the order the table shows them."""
    return {
        "first_run": lambda: first_run_bench(),
        "contention": lambda: contention_bench(quick),
        "fresh": lambda: fresh_bench(calls=1 if quick else 4, before=not quick),
        "network": lambda: network_bench(quick),
        "sumo_step": lambda: sumo_step_bench(quick),
        "navigation": lambda: navigation_bench(generations=10 if quick else 30,
                                               reference_seconds=1.0 if quick else 10.0),
        "arena": lambda: arena_bench(generations=3 if quick else 10),
        "env": lambda: env_bench(steps=50 if quick else 200, sync_seconds=1.0 if quick else 5.0),
        "sb3": lambda: sb3_bench(learn_steps=8_192 if quick else 65_536,
                                 steps=100 if quick else 500),
        "sumo": lambda: sumo_bench(generations=1 if quick else 10,
                                   closed_loop_steps=1_000 if quick else 10_000),
        "recording": lambda: recording_bench(generations=1 if quick else 2,
                                             cap=1_500 if quick else None, before=not quick),
        "crowd_scale": lambda: crowd_scale_bench(quick),
        "city": lambda: city_bench(generations=1 if quick else 20,
                                   closed_loop_steps=300 if quick else 5_000,
                                   own_warmups=not quick),
        "lane_keeping": lambda: lane_keeping_bench(generations=2 if quick else 4),
        "crowd_ray": crowd_ray_bench,
        "reproduce_quick": reproduce_quick_bench,
        "bench_quick": bench_quick_bench,
        "test_suite": test_suite_bench,
    }


# Workloads that take minutes whatever the settings (a compile from an empty cache, a whole
# reproduction): ``bench --quick`` runs them only when ``--only`` names them.
LONG = ("first_run", "crowd_ray", "reproduce_quick", "bench_quick", "test_suite")
# Workloads that need the project's git checkout, not only the package: run only when named.
CHECKOUT = ("test_suite",)


def table_text(table: pd.DataFrame) -> str:
    """The bench table as ``enn-traffic bench`` prints it: one block per kind of workload (the
    name before its colon) with only the columns it fills, every number formatted."""
    shown = table.drop(columns=["learner_steps"], errors="ignore")
    shapes = {"vehicle_steps_per_s": "{:,.0f}", "learner_steps_per_s": "{:,.0f}",
              "speedup_vs_reference": "{:.2f}x", "vs_one_thread": "{:.2f}x",
              "steps_per_s_min": "{:,.0f}", "steps_per_s_max": "{:,.0f}", "runs": "{:.0f}",
              "seconds": "{:.2f}", "seconds_min": "{:.2f}", "seconds_max": "{:.2f}",
              "peak_memory_mb": "{:,.0f}", "vehicle_steps": "{:,.0f}", "steps": "{:,.0f}",
              "calls": "{:.0f}", "rows": "{:.0f}", "ms_per_step": "{:.2f}",
              "ms_per_step_min": "{:.2f}", "ms_per_step_max": "{:.2f}",
              "sumo_ms_per_step": "{:.2f}",
              "slowdown_vs_no_learner": "{:.2f}x", "warmup_share": "{:.1%}"}
    for column, shape in shapes.items():
        if column in shown:
            shown[column] = shown[column].map(
                lambda v, f=shape: "" if isinstance(v, float) and np.isnan(v) else f.format(v))
    # one block per kind of workload (the name before its colon), with its own columns only
    kinds = shown["workload"].str.split(":").str[0]
    blocks = []
    for _, rows in shown.groupby(kinds, sort=False):
        filled = [column for column in rows
                  if not (rows[column].isna() | (rows[column] == "")).all()]
        blocks.append(rows[filled].to_string(index=False))
    return "\n\n".join(blocks)


def chosen_workloads(quick: bool = False, only: list[str] | None = None) -> list[str]:
    """The workloads ``only`` names, or every one but the :data:`CHECKOUT` ones (with
    ``quick``, but the :data:`LONG` ones too), in the order the table shows them."""
    names = list(workloads(quick))
    if only:
        return [name for name in names if name in only]
    return [name for name in names
            if not (quick and name in LONG) and name not in CHECKOUT]


def run_bench(quick: bool = False, only: list[str] | None = None) -> pd.DataFrame:
    """The throughput tables of every workload, or of the workloads ``only`` names."""
    chosen = workloads(quick)
    return pd.concat([chosen[name]() for name in chosen_workloads(quick, only)],
                     ignore_index=True)
