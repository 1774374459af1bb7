"""The compiled kernels' throughput: the navigation batch against the plain-Python oracle,
the arena, the gymnasium and Stable-Baselines3 environments, the kernels beside busy
processes, and highway-env lane keeping."""

from __future__ import annotations

import subprocess
import sys
import time

import numba
import numpy as np
import pandas as pd

from enn_traffic.bench.measure import (
    compiled_workload,
    environment,
    ga_generations,
    rate_table,
    timed_batches,
    timed_generations,
)
from enn_traffic.envs import env_id
from enn_traffic.learning.evaluators import LocalEvaluator, ProcessEvaluator
from enn_traffic.sim.reference import reference_life


def navigation(quick: bool = False) -> pd.DataFrame:
    """The navigation batch (the narrow track, 19 beams, P = 200, the generations of a GA run)
    on all cores and on one, against the plain per-vehicle Python loop of
    :mod:`enn_traffic.sim.reference` on chromosomes of the same generations, in the same
    process, so that machine drift cancels out of the ratio; the two must agree life for
    life."""
    generations, reference_seconds = (10, 1.0) if quick else (30, 10.0)
    world, params, rng, population = compiled_workload("navigation_narrow")
    populations = ga_generations(world, params, rng, population, generations)
    threads = numba.get_num_threads()
    rows = []
    steps, seconds = timed_batches(world, populations)
    rows.append(("compiled batch", threads, steps, seconds))
    numba.set_num_threads(1)
    try:
        steps, seconds = timed_batches(world, populations)
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


def arena(quick: bool = False) -> pd.DataFrame:
    """The arena workload: P = 200 worlds × 8 vehicles (strategy 1, random-network traffic),
    over the generations of a real GA run; every vehicle's steps count."""
    generations = 3 if quick else 10
    world, params, rng, population = compiled_workload("arena_strategy1")
    threads = numba.get_num_threads()
    steps, _, seconds, _ = timed_generations(world, params, rng, population,
                                              range(generations))
    table = pd.DataFrame([("compiled batch", threads, steps, seconds)],
                         columns=["implementation", "threads", "vehicle_steps", "seconds"])
    table.insert(0, "workload", f"arena: P=200 worlds x {world.vehicles} vehicles, strategy 1")
    table["vehicle_steps_per_s"] = table["vehicle_steps"] / table["seconds"]
    table["speedup_vs_reference"] = np.nan
    return table


def env(quick: bool = False) -> pd.DataFrame:
    """Gymnasium environments on the narrow track with random actions: the compiled vector
    environment of 256 and 4,096 worlds against gymnasium's ``SyncVectorEnv`` of the single
    environment (256 of them), in the same run; a step of N worlds counts N env-steps (one vehicle
    each)."""
    steps, sync_seconds = (50, 1.0) if quick else (200, 5.0)
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
    table = rate_table(rows)
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
    world, params, rng, population = compiled_workload("navigation_narrow")
    populations = ga_generations(world, params, rng, population, 3)
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
                                     *timed_batches(world, populations)))
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


BUSY = 2  # busy processes beside the kernels: a 2-core machine's other jobs


def contention(quick: bool = False) -> pd.DataFrame:
    """The compiled kernels on a quiet machine and beside :data:`BUSY` busy processes (as under
    ``pytest -n 2``, a process pool, or a second user): :func:`contention_rates` in a fresh
    process for each OpenMP wait policy of :data:`CONTENTION_POLICIES`, the default threads
    against one thread in the same process, alternating; the median of the rounds, with the
    slowest and fastest. ``quick``: enn-traffic's policy beside the busy processes only, fewer
    and shorter rounds."""
    from enn_traffic.sumo.fresh import fresh_calls

    seconds, rounds = (0.5, 2) if quick else (2.0, 5)
    loads = (BUSY,) if quick else (0, BUSY)
    policies = list(CONTENTION_POLICIES.items())
    measured = []
    for policy, settings in policies[-1:] if quick else policies:
        with environment(**{"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": None, **settings}):
            measured += [(load, policy, *row) for load, *row in
                         fresh_calls([(contention_rates, seconds, rounds, loads)])[0]]
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


def sb3(quick: bool = False) -> pd.DataFrame:
    """Stable-Baselines3 through :func:`~enn_traffic.envs.sb3.sb3_vec_env`: the
    docs/envs.md example's PPO learning on 32 arena worlds, one torch thread, and the adapter
    stepped with random actions, against the compiled vector environment of the same 32
    worlds stepped alone, in the same run. Empty without the ``rl`` extra."""
    learn_steps, steps = (8_192, 100) if quick else (65_536, 500)
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.vec_env import VecNormalize

        from enn_traffic.envs import make_vector_env
        from enn_traffic.envs.sb3 import sb3_vec_env
    except ImportError:
        return rate_table([])
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
    table = rate_table(rows)
    table["speedup_vs_reference"] = (table["vehicle_steps_per_s"]
                                     / table["vehicle_steps_per_s"].iloc[0])
    return table


def lane_keeping(quick: bool = False) -> pd.DataFrame:
    """highway-env lane keeping: environment steps per second, in this process and over a
    process pool (one environment per worker), on the generations of a GA run."""
    generations = 2 if quick else 4
    world, params, rng, population = compiled_workload("lane_keeping")
    populations = ga_generations(world, params, rng, population, generations)
    rows = []
    for name, evaluator in (("one process", LocalEvaluator(world.scenario)),
                            ("process pool", ProcessEvaluator(world.scenario))):
        try:
            evaluator.evaluate(populations[0][:2])  # start the workers outside the timing
            steps, seconds = timed_batches(evaluator, populations)
        finally:
            evaluator.close()
        workers = getattr(evaluator, "workers", 1)
        rows.append(("lane keeping: highway-env, P=40", name, workers, steps, steps, seconds))
    return rate_table(rows)
