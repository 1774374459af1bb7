"""One evolutionary run: GA + evaluator + outputs, checkpointed after every generation.

Writes into the run folder: ``scenario.toml`` (resolved), ``generations.csv``, ``best.npz``,
``learning_curve.png``, ``outputs.npz`` (:class:`RunOutputs`: what others read of the run) and
``checkpoint.npz`` (the run's own, for resuming). ``resume=True`` continues from the checkpoint
to exactly the result of an uninterrupted run: the GA's generator state is checkpointed and
evaluation is deterministic.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.config import Scenario, read_files
from enn_traffic.core import interrupts as stopping
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_not_source, folder_lock, write_atomic, write_csv, write_text
from enn_traffic.core.neural import NetworkSpec
from enn_traffic.core.progress import slow_step, terminal
from enn_traffic.core.provenance import SAME_RULES, rules_version, sources_of
from enn_traffic.learning import ga
from enn_traffic.learning.evaluators import Evaluator, make_evaluator
from enn_traffic.runs import generations_csv as generations
from enn_traffic.runs.controller import Controller
from enn_traffic.sumo.command import RUN_LOG

# What a first generation may wait for when numba's cache folder has no kernels yet.
COMPILING = (" (numba compiles the kernels first, once per install, edit of the kernels or "
             "new cache folder; docs/bench.md, First contact)")


def _kernels_cached() -> bool:
    """Has this version of the kernels been compiled into numba's cache folder before?"""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    return folder is not None and any(Path(folder).rglob("*.nbi"))
CHECKPOINT = "checkpoint.npz"
OUTPUTS = "outputs.npz"  # what a run leaves for others to read: RunOutputs


@dataclass(frozen=True)
class RunOutputs:
    """What a run writes for others to read, besides ``best.npz`` and ``generations.csv``
    (its checkpoint is its own, for resuming): each generation's best chromosome, and the
    population it ends with, whose first ``elite_count`` rows are the last generation's
    elites (kept unchanged by the GA); ``stopped``: it ended early, by ``ga.target_fitness``
    or its ``stop`` rule."""

    champions: np.ndarray  # (generations, G)
    population: np.ndarray  # (P, G)
    elite_count: int
    stopped: bool = False

    @classmethod
    def of(cls, state: ga.GAState, scenario: Scenario) -> RunOutputs:
        champions = state.champions
        if champions is None:  # a run from before runs kept them
            champions = (state.population[:0] if state.best_chromosome is None
                         else state.best_chromosome[None, :])
        return cls(champions, state.population, scenario.ga.elite_count,
                   bool(state.extra.get("target_reached", False)))

    def save(self, run_dir: Path) -> None:
        def write(handle):
            np.savez(handle, champions=self.champions, population=self.population,
                     elite_count=self.elite_count, stopped=self.stopped)

        write_atomic(Path(run_dir) / OUTPUTS, write, binary=True)

    @classmethod
    def load(cls, run_dir: str | Path) -> RunOutputs:
        path = Path(run_dir) / OUTPUTS
        try:
            with np.load(path) as data:
                return cls(data["champions"], data["population"], int(data["elite_count"]),
                           bool(data["stopped"]))
        except (OSError, KeyError, ValueError) as exc:
            raise InputError(f"not a run's outputs ({exc})", path) from None


def fingerprint(scenario: Scenario, others: Sequence[Scenario] = (),
                population: np.ndarray | None = None, deciders: Sequence[object] = (),
                rules: str | None = None) -> str:
    """Identifies a run: its settings (everything but the number of generations) and the
    contents of the files they name, with the other scenarios its evaluator runs (their
    worlds: not their own number of generations), the population it started from, where there
    are such, and the code that decides its result: the rules
    (:func:`~enn_traffic.core.provenance.rules_version`) and the files of its ``deciders`` (an
    evaluator or stopping rule from elsewhere, :func:`~enn_traffic.core.provenance.sources_of`);
    ``rules``: another digest of the rules than this code's."""
    digest = hashlib.sha256((rules or rules_version()).encode())
    digest.update(sources_of(*deciders).encode())
    for one in (scenario, *others):
        digest.update(one.with_overrides(ga={"generations": 1}).to_toml().encode())
        for path in read_files(one):
            digest.update(path.read_bytes() if path.is_file() else b"missing")
    if population is not None:
        digest.update(np.ascontiguousarray(population, dtype=np.float64).tobytes())
    return digest.hexdigest()[:16]


def _fresh_state(scenario: Scenario, key: str, population: np.ndarray | None = None
                 ) -> ga.GAState:
    rng = np.random.default_rng(scenario.seed)
    length = NetworkSpec(scenario.layer_sizes, scenario.network.layout).chromosome_length
    if population is None:
        population = ga.initial_population(
            rng, scenario.ga.population_size, length, scenario.ga.init_range
        )
    elif population.shape != (scenario.ga.population_size, length):
        raise ValueError(f"initial population has shape {population.shape}, the scenario "
                         f"needs ({scenario.ga.population_size}, {length})")
    return ga.GAState(generation=0, population=population, rng=rng, fingerprint=key,
                      extra={"elapsed_s": 0.0, "rules": rules_version()})


RUN_OWN = ("sumo",)  # what a run writes before its first checkpoint, besides scenario.toml
# What a start of the same run may have written beside its scenario.toml when it stopped
# before its first checkpoint was whole (a full disk): written over by the new start.
RUN_FILES = ("best.npz", "generations.csv", OUTPUTS, "learning_curve.png")


def _check_fresh_folder(scenario: Scenario, out: Path, force: bool) -> None:
    """A fresh run writes into a folder that is empty or holds only what this run would
    write before its first checkpoint (an interrupted start), or into any with ``--force``;
    never over the scenario file it reads (docs/design.md, "Reliability")."""
    own = out / "scenario.toml"
    check_not_source(own, scenario.source)
    if force or not out.is_dir():
        return
    same_run = own.is_file() and own.read_text(errors="replace") == scenario.to_toml()
    _refuse_others(out, lambda path: same_run and (path == own or path.name in RUN_FILES))


def _refuse_others(out: Path, own) -> None:
    """Refuse a folder holding a file that is neither :data:`RUN_OWN` nor ``own(path)``,
    naming every file but :data:`RUN_OWN`."""
    names = sorted(path.name for path in out.iterdir() if path.name not in RUN_OWN)
    if any(not own(out / name) for name in names):
        shown = ", ".join(names[:3]) + (" …" if len(names) > 3 else "")
        raise InputError(f"holds files but no run to resume ({shown}); give an empty folder "
                         "or --force to write over them", out, "--out")


def check_folder_unread(out: str | Path, source: Path, resume: bool = False,
                        force: bool = False) -> None:
    """What :func:`check_folder` can tell before the scenario file ``source`` is read (a
    city's network takes seconds): the scenario's own folder, a run without ``--resume``,
    the user's files (a ``scenario.toml`` alone is compared once the scenario is read)."""
    out = Path(out)
    check_not_source(out / "scenario.toml", source)
    if force or not out.is_dir():
        return
    if (out / CHECKPOINT).exists():
        if not resume:
            raise InputError(ALREADY_A_RUN, out)
        return
    started = (out / "scenario.toml").is_file()  # compared once the scenario is read
    _refuse_others(out, lambda path: started and (path.name == "scenario.toml"
                                                  or path.name in RUN_FILES))


ALREADY_A_RUN = ("the folder already holds a run; pass --resume to continue it or --force to "
                 "start over")


def earlier_keys(scenario: Scenario, others: Sequence[Scenario] = (),
                 population: np.ndarray | None = None, deciders: Sequence[object] = ()
                 ) -> frozenset[str]:
    """The fingerprints the same run had under the earlier digests of these same rules
    (:data:`~enn_traffic.core.provenance.SAME_RULES`): a run made under one resumes."""
    return frozenset(fingerprint(scenario, others, population, deciders, rules)
                     for rules in SAME_RULES)


def _open_state(scenario: Scenario, out: Path, resume: bool, force: bool,
                population: np.ndarray | None, key: str,
                earlier: frozenset[str] = frozenset()) -> ga.GAState:
    checkpoint = out / CHECKPOINT
    if not checkpoint.exists() or force:
        _check_fresh_folder(scenario, out, force)
        logs = scenario.sumo_folder
        if force and logs is not None and logs.resolve().parent == out.resolve():
            (logs / RUN_LOG).unlink(missing_ok=True)  # starting over: the old run's log too
        return _fresh_state(scenario, key, population)
    if not resume:
        raise InputError(ALREADY_A_RUN, out)
    state = ga.GAState.load(checkpoint)
    if state.fingerprint in earlier:  # these rules, digested the earlier way
        state = replace(state, fingerprint=key, extra={**state.extra, "rules": rules_version()})
    if state.fingerprint != key:
        made_by = state.extra.get("rules", "older")
        if made_by != rules_version():
            raise InputError(f"the folder holds a run made by other rules ({made_by}; these "
                             f"are {rules_version()}); use another --out or --force", out)
        raise InputError(f"the folder holds a run of different {_differences(scenario, out)}; "
                         "use another --out or --force", out)
    _check_checkpoint(state, scenario, checkpoint)
    return state


def _check_checkpoint(state: ga.GAState, scenario: Scenario, path: Path) -> None:
    """A checkpoint whose settings match may still have been edited or damaged: its arrays
    must be the scenario's (population rows, genes, one champion per finished generation),
    real and finite, before anything resumes from it or is restored from it."""
    genes = NetworkSpec(scenario.layer_sizes, scenario.network.layout).chromosome_length
    arrays = {"population": (state.population, (scenario.ga.population_size, genes)),
              "best_chromosome": (state.best_chromosome, (genes,)),
              "champions": (state.champions, (state.generation, genes))}
    if state.generation < 0:
        raise InputError(f"generation {state.generation} is negative", path, "generation")
    for name, (array, shape) in arrays.items():
        if array is None:
            continue
        if not np.issubdtype(array.dtype, np.floating):
            raise InputError(f"holds {array.dtype} numbers, not real ones", path, name)
        if array.shape != shape:
            raise InputError(f"has shape {array.shape}; the scenario's run needs {shape}",
                             path, name)
        if not np.all(np.isfinite(array)):
            raise InputError("holds NaN or inf", path, name)
    if state.best_chromosome is not None and not np.isfinite(state.best_fitness):
        raise InputError(f"best fitness {state.best_fitness} with a best chromosome", path,
                         "best_fitness")


def _differences(scenario: Scenario, out: Path) -> str:
    """What differs between ``scenario`` and the run in ``out``: the keys whose values differ
    from its ``scenario.toml`` (a few), else its input files or the code that decides it."""
    def flat(table: dict, prefix: str = "") -> dict:
        items = {}
        for key, value in table.items():
            if isinstance(value, dict):
                items.update(flat(value, f"{prefix}{key}."))
            else:
                items[f"{prefix}{key}"] = value
        return items

    try:
        kept = flat(tomllib.loads((out / "scenario.toml").read_text(encoding="utf-8")))
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return "settings"
    ours = flat(tomllib.loads(scenario.to_toml()))
    keys = sorted(k for k in kept.keys() | ours.keys()
                  if kept.get(k) != ours.get(k) and k != "ga.generations")
    if not keys:
        return ("settings (its scenario keys match: the input files, the starting population, "
                "the other worlds or the evaluator's code differ)")
    listed = ", ".join(keys[:5]) + (f" and {len(keys) - 5} more" if len(keys) > 5 else "")
    return f"settings ({listed})"


def check_folder(scenario: Scenario, out: str | Path, resume: bool = False,
                 force: bool = False) -> None:
    """Would :func:`evolve` accept the run folder ``out`` (a clear InputError if not)? Asked
    before any world is built, so that a folder holding another run is said at once."""
    out = Path(out)
    if (out / CHECKPOINT).exists() and not force:
        _open_state(scenario, out, resume, force, None, fingerprint(scenario),
                    earlier_keys(scenario))
    else:
        _check_fresh_folder(scenario, out, force)


def restore_outputs(scenario: Scenario, out: Path, state: ga.GAState,
                    done: pd.DataFrame) -> None:
    """Write again, from the checkpoint, each output of a continued run that is missing or
    differs from it: ``scenario.toml`` (with the generations the folder holds, when more than
    asked for), ``best.npz``, ``outputs.npz``, the learning curve (a crash between two
    writes, or a file deleted or edited since)."""
    generations = max(scenario.ga.generations, state.generation)  # as many as the folder holds
    settings = scenario.with_overrides(ga={"generations": generations}).to_toml()
    written = out / "scenario.toml"
    if not written.is_file() or written.read_text(errors="replace") != settings:
        write_text(written, settings)
    if state.best_chromosome is not None:
        try:
            best = Controller.load(out / "best.npz")
            same = np.array_equal(best.chromosome, state.best_chromosome)
        except InputError:
            same = False
        if not same:
            generation = int(done["generation"][done["best_fitness"].idxmax()])
            Controller.from_scenario(scenario, state.best_chromosome, state.best_fitness,
                                     generation).save(out / "best.npz")
    outputs = RunOutputs.of(state, scenario)
    try:
        saved = RunOutputs.load(out)
        same = (np.array_equal(saved.champions, outputs.champions)
                and np.array_equal(saved.population, outputs.population)
                and saved.stopped == outputs.stopped)
    except InputError:
        same = False
    if not same:
        outputs.save(out)
    if not (out / "learning_curve.png").is_file():
        _draw_learning_curve(done, out, scenario.name)


def _finished_rows(table_path: Path, generation: int) -> pd.DataFrame:
    """The rows of the generations a checkpoint says are done, as written; a damaged table is
    an error, never silently shortened."""
    if generation == 0:
        return pd.DataFrame(columns=list(generations.COLUMNS))
    try:
        done = pd.read_csv(table_path)
        rows = done[done["generation"] < generation]
        complete = list(rows["generation"]) == list(range(generation))
    except Exception as exc:  # missing, empty, unparsable, or without a generation column
        raise InputError(f"cannot continue: the generations table is unreadable "
                         f"({type(exc).__name__}: {exc}); --force starts over",
                         table_path) from None
    if not complete:
        raise InputError(f"cannot continue: the generations table lacks some of the "
                         f"{generation} generations the checkpoint has done; --force starts over",
                         table_path)
    return rows.reset_index(drop=True)


def _draw_learning_curve(table: pd.DataFrame, out: Path, name: str) -> None:
    """``learning_curve.png``; matplotlib is imported here, not when a run starts (a bad
    scenario is refused in a fraction of a second)."""
    from enn_traffic.report.plots import learning_curve

    learning_curve(table, out / "learning_curve.png", title=name)


def evolve(
    scenario: Scenario,
    out: str | Path,
    evaluator: Evaluator | None = None,
    resume: bool = False,
    force: bool = False,
    progress: bool = True,
    initial_population: np.ndarray | None = None,
    stop: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    others: Sequence[Scenario] = (),
) -> pd.DataFrame:
    """Run the GA for ``scenario.ga.generations`` generations (or until a generation's best
    reaches ``ga.target_fitness``); return the generations table. ``initial_population``
    replaces the random first generation of a fresh run (incremental evolution, §5.4.1);
    ``stop(population, fitness)``, asked after every generation, ends the run when it says so;
    ``others``: the scenarios of the other worlds ``evaluator`` runs, which a resumed run must
    share as it shares ``scenario`` and the initial population.
    """
    out = Path(out)
    scenario.check_population_fits()  # refused before the folder is made, as is a scenario
    for one in (scenario, *others):  # its folder's scenario.toml cannot hold
        one.to_toml()
    with folder_lock(out):
        return _evolve(scenario, out, evaluator, resume, force, progress, initial_population,
                       stop, others)


def _evolve(scenario: Scenario, out: Path, evaluator: Evaluator | None, resume: bool,
            force: bool, progress: bool, initial_population: np.ndarray | None,
            stop: Callable[[np.ndarray, np.ndarray], bool] | None,
            others: Sequence[Scenario]) -> pd.DataFrame:
    """:func:`evolve`, its folder locked."""
    deciders = [d for d in (evaluator, stop) if d is not None]
    key = fingerprint(scenario, others, initial_population, deciders)
    state = _open_state(scenario, out, resume, force, initial_population, key,
                        earlier_keys(scenario, others, initial_population, deciders))
    table_path = out / "generations.csv"
    done = _finished_rows(table_path, state.generation)
    total = scenario.ga.generations
    if state.generation > 0:
        restore_outputs(scenario, out, state, done)
    if state.generation >= total or state.extra.get("target_reached", False):
        return done  # nothing to compute
    rows = done.to_dict("records")
    write_text(out / "scenario.toml", scenario.to_toml())
    params = scenario.ga
    own_evaluator = evaluator is None
    evaluator = evaluator or make_evaluator(scenario)
    # The bar opens after this process's first generation, which may compile the kernels:
    # counted in, its minutes would set the remaining time's estimate for the whole run.
    bar = tqdm(disable=True)
    try:
        run = ga.generations(state, evaluator.evaluate, params)
        while state.generation < total and not state.extra.get("target_reached", False):
            stopping.raise_if_requested()
            started = time.perf_counter()
            generation, best_before = state.generation, state.best_fitness
            first = len(rows) == len(done)  # this process's first: the kernels may compile
            with slow_step(f"generation {generation} of {scenario.name}"
                           f"{'' if _kernels_cached() else COMPILING}") \
                    if first else contextlib.nullcontext():
                state, evaluated, results = next(run)
            fitness = results.fitness
            if state.best_fitness > best_before:
                Controller.from_scenario(
                    scenario, state.best_chromosome, state.best_fitness, generation
                ).save(out / "best.npz")
            state.extra["elapsed_s"] += time.perf_counter() - started
            rows.append(generations.row(generations.Generation(
                scenario, generation, results, state.extra["elapsed_s"])))
            write_csv(table_path, pd.DataFrame(rows, columns=list(generations.COLUMNS)))
            state.save(out / CHECKPOINT)
            RunOutputs.of(state, scenario).save(out)
            if first:
                bar = tqdm(total=total, initial=min(state.generation, total), desc=scenario.name,
                           unit="gen", disable=not progress, leave=False, file=terminal())
            else:
                bar.update(1)
            bar.set_postfix(best=int(fitness.max()), mean=round(float(fitness.mean()), 1))
            target = scenario.ga.target_fitness
            if (target is not None and fitness.max() >= target) or (
                    stop is not None and stop(evaluated, fitness)):
                state.extra["target_reached"] = True
                state.save(out / CHECKPOINT)
                RunOutputs.of(state, scenario).save(out)  # now stopped
    finally:
        bar.close()
        if own_evaluator:
            evaluator.close()
    table = pd.read_csv(table_path)  # the same types whether the run was resumed or not
    _draw_learning_curve(table, out, scenario.name)
    return table
