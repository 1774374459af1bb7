"""How the bench times, and what it runs on: a shipped scenario's compiled world and the
generations of a GA run on it, rate tables, and the large road networks it generates once
into the cache folder."""

from __future__ import annotations

import contextlib
import itertools
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.learning import ga
from enn_traffic.learning.evaluators import Evaluator
from enn_traffic.sim.world import World, make_world


def timed_batches(world: World | Evaluator, populations: list[np.ndarray]) -> tuple[int, float]:
    steps, seconds = 0, 0.0
    for population in populations:
        started = time.perf_counter()
        results = world.evaluate(population)
        seconds += time.perf_counter() - started
        steps += results.vehicle_steps
    return steps, seconds


def compiled_workload(name: str):
    """A shipped scenario's world, GA settings, generator and first population, compiled."""
    scenario = shipped_scenario(name)
    world = make_world(scenario)
    rng = np.random.default_rng(scenario.seed)
    params = scenario.ga
    population = ga.initial_population(
        rng, params.population_size, world.spec.chromosome_length, params.init_range
    )
    world.evaluate(population[:2])  # compile outside the timing
    return world, params, rng, population


def timed_generations(world, params, rng, population, generations: range) -> tuple:
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


def rate_table(rows: list[tuple]) -> pd.DataFrame:
    """Rows (workload, implementation, threads, vehicle steps, learner steps, seconds), with
    steps per second."""
    table = pd.DataFrame(rows, columns=["workload", "implementation", "threads",
                                        "vehicle_steps", "learner_steps", "seconds"])
    table["vehicle_steps_per_s"] = table["vehicle_steps"] / table["seconds"]
    table["learner_steps_per_s"] = table["learner_steps"] / table["seconds"]
    table["speedup_vs_reference"] = np.nan
    return table


def ga_generations(world, params, rng, population, generations: int) -> list[np.ndarray]:
    """The populations of the first ``generations`` generations of a GA run."""
    run = ga.generations(ga.GAState(generation=0, population=population, rng=rng),
                         lambda population, _: world.evaluate(population), params)
    return [evaluated for _, evaluated, _ in itertools.islice(run, generations)]


def generated(name: str, make: Callable[[Path], None]) -> Path:
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


def random_roads(net: Path, iterations: int, *options: str) -> None:
    """SUMO's netgenerate (the eclipse-sumo wheel's) writes ``net``: a random road network of
    ``iterations`` growth steps, two lanes each way, roads of 80-200 m; ``options`` add to
    its command."""
    import sumo as sumo_wheel

    subprocess.run([f"{sumo_wheel.SUMO_HOME}/bin/netgenerate", "--rand",
                    "--rand.iterations", str(iterations), "--rand.max-distance", "200",
                    "--rand.min-distance", "80", "-L", "2", "--seed", "7", *options,
                    "-o", str(net)], check=True, capture_output=True)


def random_city(iterations: int) -> Path:
    """:func:`random_roads` of ``iterations`` growth steps (:func:`generated`)."""
    return generated(f"random{iterations}", lambda folder: random_roads(
        folder / "random.net.xml", iterations)) / "random.net.xml"


def city_with_lights(iterations: int, period_s: float) -> tuple[Path, Path]:
    """A random city (:func:`random_roads`) whose junctions have actuated traffic lights
    where netgenerate guesses them, as OSM-built cities do, and random car trips departing
    every ``period_s`` seconds for an hour (SUMO's randomTrips; :func:`generated`)."""
    import sumo as sumo_wheel

    def make(folder: Path) -> None:
        random_roads(folder / "lights.net.xml", iterations, "--tls.guess",
                      "--tls.default-type", "actuated")
        subprocess.run([sys.executable, f"{sumo_wheel.SUMO_HOME}/tools/randomTrips.py", "-n",
                        "lights.net.xml", "-o", "lights.trips.xml", "--period",
                        f"{period_s:g}", "--end", "3600", "--seed", "7", "--fringe-factor",
                        "10", "--min-distance", "500"],
                       check=True, capture_output=True, cwd=folder)  # its routes.rou.xml too

    folder = generated(f"lights{iterations}-period{period_s:g}", make)
    return folder / "lights.net.xml", folder / "lights.trips.xml"


def city_crowd(folder: Path, net: Path, trips: Path, learners: int):
    """The scenario of ``learners`` learners in one SUMO of the city ``net`` and its
    ``trips`` (closed loop, after one shared 300 s warm-up), written into ``folder``, and its
    world."""
    from enn_traffic.config import load_scenario

    path = folder / "city.toml"
    path.write_text(f'name = "city"\n[track]\nnet = "{net}"\nstart_lane = "auto"\n'
                    f'[traffic]\nstrategy = "sumo"\nroutes = ["{trips}"]\n'
                    f'mode = "closed-loop"\nwarmup_s = 300.0\nwarmup_states = 1\n'
                    f"learners = {learners}\n")
    scenario = load_scenario(path)
    return scenario, make_world(scenario)


def timing_into(spent: dict[str, float]) -> Callable:
    """``timed(call, part)``: ``call``, its seconds added to ``spent[part]`` at every call."""
    def timed(call, part):
        def wrapped(*args):
            started = time.perf_counter()
            result = call(*args)
            spent[part] += time.perf_counter() - started
            return result
        return wrapped
    return timed


@contextlib.contextmanager
def environment(**values: str | None) -> Iterator[None]:
    """Environment variables set (None: unset) while inside, then as they were."""
    saved = {name: os.environ.get(name) for name in values}
    try:
        for name, value in values.items():
            os.environ.pop(name, None)
            if value is not None:
                os.environ[name] = value
        yield
    finally:
        for name, value in saved.items():
            os.environ.pop(name, None)
            if value is not None:
                os.environ[name] = value


def measured(work, memory: bool = True) -> tuple[float, float, object]:
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
