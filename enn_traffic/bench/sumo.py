"""SUMO's workloads: replay and closed loop on the shipped scenarios and the city, SUMO's own
step with learners in it, many learners in one city SUMO and across SUMOs on Ray, and a
SUMO start in a fresh process."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd

from enn_traffic.bench.measure import (
    city_crowd,
    city_with_lights,
    compiled_workload,
    environment,
    rate_table,
    timed_generations,
    timing_into,
)
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.learning import ga
from enn_traffic.sim.sumo.crowd import SumoCrowd
from enn_traffic.sim.world import make_world
from enn_traffic.sumo import states
from enn_traffic.sumo.simulation import Simulation


def sumo(quick: bool = False) -> pd.DataFrame:
    """SUMO strategy 1 (steady ring traffic): replay mode over the generations of a GA run,
    recording included; then the run's best controller in closed loop, one process, over
    episodes of new traffic until as many learner steps (SUMO's start and warm-up of each
    situation, timed apart, not counted), and driving every learner of a SUMO crowd."""
    generations, closed_loop_steps = (1, 1_000) if quick else (10, 10_000)
    world, params, rng, population = compiled_workload("sumo_strategy1")
    threads = numba.get_num_threads()
    # generation 0's traffic was recorded above
    steps, learner_steps, seconds, best = timed_generations(world, params, rng, population,
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
    return rate_table(rows)


def recording(quick: bool = False) -> pd.DataFrame:
    """A SUMO scenario as docs/sumo.md's template writes it, the step cap left at its default
    (20,000 steps: 33 min of SUMO time; 1,500 with ``quick``) while lives last seconds:
    Cologne, P = 20, the generations of a GA run, and a gymnasium environment's reset and
    random-policy life, SUMO recorded only as far as the lives reach, from no kept recording.
    The shared warm-ups are simulated before the timing."""
    from enn_traffic.config import EpisodeConfig
    from enn_traffic.envs.sumo import SumoEnv
    from enn_traffic.sim.sumo.world import forget_recordings

    generations = 1 if quick else 2
    default = EpisodeConfig().max_steps
    cap = 1_500 if quick else default
    what = "default cap" if cap == default else f"cap of {cap:,} steps"
    label = "recorded as far as the lives reach"
    scenario = shipped_scenario("city_cologne3").with_overrides(
        episode={"max_steps": cap}, ga={"population_size": 20})
    forget_recordings()  # an earlier workload's would serve this one
    world = make_world(scenario)
    rng = np.random.default_rng(scenario.seed)
    params = scenario.ga
    population = ga.initial_population(rng, params.population_size,
                                       world.spec.chromosome_length, params.init_range)
    world.evaluate(population[:2], 0)  # compile and warm up outside the timing
    steps, learner_steps, seconds, _ = timed_generations(
        world, params, rng, population, range(1, generations + 1))
    rows = [(f"sumo {what}: Cologne, P=20, {generations} generation"
             f"{'s' if generations > 1 else ''}", label, numba.get_num_threads(), steps,
             learner_steps, seconds)]
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
    rows.append((f"sumo env: a reset and a random-policy life, Cologne, {what}", label, 1,
                 lived, lived, time.perf_counter() - started))
    env.close()
    forget_recordings()
    return rate_table(rows)


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


def city(quick: bool = False) -> pd.DataFrame:
    """The shipped city scenario (Cologne, its .sumocfg as published, P = 100): replay over the
    generations of a GA run, warm-ups and recordings included, once with the scenario's shared
    warm-ups (simulated in the timing, into an empty state folder) and (not with ``quick``)
    once with each traffic situation warming up itself; then the run's best controller in
    closed loop, SUMO's start included. ``warmup_share``: the part of the wall time spent
    simulating warm-ups."""
    generations, closed_loop_steps = (1, 300) if quick else (20, 5_000)
    own_warmups = not quick
    scenario = shipped_scenario("city_cologne3")
    rows = []
    with tempfile.TemporaryDirectory(prefix="enn-bench-states-") as folder, \
            environment(**{states.STATE_FOLDER_VARIABLE: folder}):
        arms = [("shared warm-ups", {}),
                ("each situation its own warm-up", {"warmup_states": 0})]
        for label, settings in arms if own_warmups else arms[:1]:
            world = make_world(scenario.with_overrides(traffic=settings))
            rows.append(_city_replay(world, label, generations))
        best = rows[0][-1]
        # closed loop: its situations' warm-ups are simulated before the timing
        steps, seconds = _closed_loop(scenario, best, generations, closed_loop_steps,
                                      count_start=True)
    table = rate_table([row[:-2] for row in rows] + [
        ("city closed loop: the best controller", "libsumo step by step, 1 process, SUMO "
         "start included", 1, steps, steps, seconds)])
    table["warmup_share"] = [row[-2] for row in rows] + [np.nan]
    return table


def _city_replay(world, label: str, generations: int) -> tuple:
    """Replay generations of a GA run on the city: the rate row, the warm-up share and the
    best chromosome."""
    scenario = world.scenario
    rng = np.random.default_rng(scenario.seed)
    params = scenario.ga
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
    steps, learner_steps, seconds, best = timed_generations(world, params, rng, population,
                                                             range(generations))
    total = seconds + (warmup if scenario.traffic.warmup_states else 0.0)
    return (f"city replay: Cologne, P={params.population_size}", label, numba.get_num_threads(),
            steps, learner_steps, total, warmup / total, best)


def sumo_step_table(source: list[str], name: str, steps: int, warmup_steps: int,
                    repeats: int) -> pd.DataFrame:
    """:func:`~enn_traffic.sumo.timing.step_seconds` without a learner, with one and with eight, one
    after another ``repeats`` times (the median kept, and the fastest and slowest run: machine drift
    hits every count alike, but a run's step time on a shared machine varies by a quarter and more),
    each start in a fresh process (libsumo keeps state between starts in one process)."""
    from enn_traffic.sumo.fresh import fresh_calls
    from enn_traffic.sumo.timing import step_seconds

    counts = (0, 1, 8)
    calls = [(step_seconds, source, learners, steps, warmup_steps)
             for _ in range(repeats) for learners in counts]
    measured = fresh_calls(calls)
    lanes, vehicles = measured[0][1:]
    runs = {learners: [m[0] for m, call in zip(measured, calls, strict=True)
                       if call[2] == learners] for learners in counts}
    base = float(np.median(runs[0]))
    return pd.DataFrame([{
        "workload": f"SUMO step: {name}, {lanes:,} lanes, {vehicles:,} vehicles",
        "implementation": f"{learners} learner{'s' * (learners != 1)}", "threads": 1,
        "seconds": float(np.median(times)) * steps, "steps": steps, "runs": len(times),
        "ms_per_step": 1000 * float(np.median(times)), "ms_per_step_min": 1000 * min(times),
        "ms_per_step_max": 1000 * max(times),
        "slowdown_vs_no_learner": float(np.median(times)) / base}
        for learners, times in runs.items()])


def sumo_step(quick: bool = False) -> pd.DataFrame:
    """SUMO's own step time on a city of thousands of lanes with actuated lights, without a
    learner, with one and with eight."""
    net, trips = city_with_lights(150 if quick else 1500, 0.5)
    return sumo_step_table(["-n", str(net), "-r", str(trips)],
                           "random city with actuated lights", 50 if quick else 300,
                           600 if quick else 3000, 1 if quick else 3)


def crowd_scale_seconds(net: Path, trips: Path, learners: int, steps: int) -> dict:
    """``learners`` learners in one SUMO of the city ``net`` (its ``trips``; closed loop, after
    300 s of warm-up), each driving a random network of its own for ``steps`` steps, SUMO's
    start and the learners' entry not timed: the seconds, those inside SUMO's own step, those
    inside the learners' two compiled calls (blame and sensing, :mod:`enn_traffic.sim.sumo.crowd`),
    and the process's peak resident memory (libsumo runs in it). Run in a fresh process."""
    import resource

    from enn_traffic.sim.sumo import crowd as sumo_crowd

    inside = {"sumo": 0.0, "kernels": 0.0}
    timed = timing_into(inside)
    with tempfile.TemporaryDirectory(prefix="enn-bench-crowd-") as folder:
        scenario, world = city_crowd(Path(folder), net, trips, learners)
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


def crowd_scale(quick: bool = False) -> pd.DataFrame:
    """Learners in one city SUMO: learner-steps per second, SUMO's own share of the
    time, the learners' compiled calls per learner-step and the peak memory as the learners
    grow, each count in a fresh process, on the random city with actuated lights of the SUMO
    step rows."""
    from enn_traffic.sumo.fresh import fresh_calls

    net, trips = city_with_lights(150 if quick else 1500, 0.5)
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


def crowd_ray(quick: bool = False) -> pd.DataFrame:
    """``enn-traffic crowd`` with 100 learners in each of 10 situations (one SUMO each, 1,000
    in all; the same with ``quick``) on the random city with actuated
    lights, once with ``--executor local`` (the situations one after another) and once with
    ``--executor ray`` (a local Ray, a worker per core), each a whole command into an empty
    folder, timed; ``identical``: every table the same."""
    learners, situations = 100, 10
    net, trips = city_with_lights(150, 0.5)
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


_ZYGOTE_START = """
import os, time
from enn_traffic.sumo import fresh
started = time.perf_counter()
fresh.fresh(os.getpid)
print(time.perf_counter() - started)
"""


def fresh_process(quick: bool = False) -> pd.DataFrame:
    """A fresh process (docs/sumo.md, "One SUMO start, one process") for one arm of a Table
    3–4 situation (SUMO strategy 1, its learners driving random controllers for 10 s), forked
    from the zygote, 4 times (once with ``quick``); seconds per call, SUMO's start and the
    drive included. The zygote's own start (once per calling process) is timed apart."""
    from enn_traffic.experiments.crowds.sumo import _driving_arm
    from enn_traffic.sumo import fresh

    calls = 1 if quick else 4
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
    times = []
    for _ in range(calls):
        started = time.perf_counter()
        fresh.fresh(*call)
        times.append(time.perf_counter() - started)
    workload = "fresh process: one Table 3-4 arm (sumo_strategy1, 8 learners, 10 s)"
    table = pd.DataFrame([
        {"workload": workload, "implementation": "forked from the zygote",
         "threads": numba.get_num_threads(), "calls": calls, "seconds": float(np.median(times)),
         "seconds_min": min(times), "seconds_max": max(times)},
        {"workload": "fresh process: the zygote's start, once per calling process",
         "implementation": "started by a new calling process",
         "threads": numba.get_num_threads(), "calls": 1, "seconds": zygote_start,
         "seconds_min": zygote_start, "seconds_max": zygote_start}])
    table["speedup_vs_reference"] = np.nan
    return table
