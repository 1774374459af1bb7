"""Every car learning in a user's own SUMO scenario: Tables 3–4 of the paper (§5.5) on any city
(``enn-traffic crowd``; docs/sumo.md, "Every car learning in your city").

The shipped SUMO families' procedure (:mod:`enn_traffic.experiments.crowds.sumo`), on one
scenario, in three steps that each resume after an interrupt:

1. **individual learning**: the scenario's GA, one learner among SUMO's traffic, into
   ``OUT/individual/`` as ``enn-traffic run`` writes a run. Its best controller is the
   *winner*; its last population (elites first) is what every vehicle starts learning from;
2. **the crowds**: ``traffic.learners`` learners in one SUMO, closed loop, in each of
   ``crowd.situations`` test situations (the crowd test keys), three arms from the same SUMO
   state: initial drivers (random networks), the winner for all (Table 3), every vehicle
   evolving on (Table 4). Each situation is kept under ``OUT/crowds/`` as it ends; with
   ``--executor ray`` the situations run side by side as Ray tasks, the same results;
3. **the tables**: ``table3.csv``, ``table4.csv`` (paired intervals), ``table4_learners.csv``,
   ``table4_learning.csv`` and ``.png``, ``table4_learning_ends.csv``, ``crowd_situations.csv``,
   ``table4_validation_learners.csv``, each learner's controller after learning in the first
   situation (``controllers/learnerK.npz``) and ``crowd.gif``: those controllers driving
   together.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.core.cache import key_of
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import check_not_source, folder_lock, write_text
from enn_traffic.core.progress import slow_step
from enn_traffic.experiments import facts
from enn_traffic.experiments.common import save_controller
from enn_traffic.experiments.crowds.cost import cost_lines
from enn_traffic.experiments.crowds.settings import CrowdSettings
from enn_traffic.experiments.crowds.sumo import (
    SITUATION_KEY,
    SUMO_LEARNING,
    measure_situations,
    write_tables,
)
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.world import make_world

MARKER = "crowd.toml"  # the scenario a folder's crowd run measures: written first
GIF_SECONDS = 30.0  # SUMO time the GIF shows
INDIVIDUAL = "individual"
# --quick: the shipped families' quick spans and situations
QUICK = dict(SUMO_LEARNING.quick)


def crowd_scenario(scenario: Scenario, learners: int | None = None, quick: bool = False
                   ) -> Scenario:
    """``scenario`` checked for a crowd (an InputError naming the key otherwise), with
    ``learners`` (default: ``traffic.learners``) and, ``quick``, two generations of GA and
    :data:`QUICK`'s crowd."""
    traffic = scenario.traffic
    if traffic is None or not traffic.is_sumo:
        raise InputError('a crowd drives among SUMO traffic: set traffic.strategy = "sumo"',
                         scenario.source, "traffic.strategy")
    if scenario.crowd.population_size > scenario.ga.population_size:
        raise InputError(f"each vehicle copies {scenario.crowd.population_size} rows of the "
                         f"individual run's population of {scenario.ga.population_size}; "
                         "lower crowd.population_size or raise ga.population_size",
                         scenario.source, "crowd.population_size")
    overrides = {"traffic": {"learners": learners or traffic.learners}}
    if quick:
        overrides["ga"] = {"generations": min(scenario.ga.generations, 2)}
        overrides["crowd"] = QUICK
    return scenario.with_overrides(**overrides)


def individual_scenario(scenario: Scenario) -> Scenario:
    """What the individual run learns on: ``scenario`` without its crowd's settings, so that
    a crowd measured again with other ``[crowd]`` keys or learners resumes the same run."""
    learners = type(scenario.traffic).model_fields["learners"].default
    return scenario.with_overrides(crowd=type(scenario.crowd)().model_dump(),
                                   traffic={"learners": learners})


def check_folder(out: Path, resume: bool, force: bool, source: Path | None = None) -> None:
    """A crowd writes into an empty folder, its own run's (``--resume``), or any with
    ``--force``; never over its scenario file ``source``."""
    check_not_source(out / MARKER, source)
    if not out.is_dir() or not any(out.iterdir()) or force:
        return
    if not (out / MARKER).is_file():
        raise InputError(f"holds files but no crowd run ({MARKER}); give an empty folder, "
                         "or --force to write over it", out, "--out")
    if not resume:
        raise InputError("holds a crowd run; --resume continues it, --force starts over", out,
                         "--out")


def run_crowd(scenario: Scenario, out: Path, executor: str = "local",
              address: str | None = None, resume: bool = False, force: bool = False,
              progress: bool = True) -> list[str]:
    """The three steps (the module's list) into ``out``; the tables' summary lines.
    ``scenario``: from :func:`crowd_scenario`."""
    from enn_traffic.learning.evaluators import connect_ray, make_evaluator
    from enn_traffic.runs.run import RunOutputs, evolve, fingerprint

    out = Path(out)
    settings = scenario.to_toml()  # one the folder cannot hold: refused before it is made
    with folder_lock(out):
        if force:
            shutil.rmtree(out / "crowds", ignore_errors=True)
        write_text(out / MARKER, settings)
        individual = out / INDIVIDUAL
        alone = individual_scenario(scenario)
        with slow_step(f"preparing the worlds of {scenario.name}"):
            evaluator = make_evaluator(alone, executor, address)
        try:
            evolve(alone, individual, evaluator, resume=resume or not force, force=force,
                   progress=progress)
        finally:
            evaluator.close()
        winner = Controller.load(individual / "best.npz").chromosome
        evolved = RunOutputs.load(individual).population
        world = make_world(scenario.with_overrides(traffic={"mode": "closed-loop"}))
        source = world.spec.in_source_layout(np.vstack([winner, evolved]))
        learning = CrowdSettings.of(scenario.crowd)

        def save_learner(strategy: int, k: int, crowd_scenario: Scenario, genes) -> None:
            save_controller(out, f"learner{k}", crowd_scenario, genes, float("nan"))

        measured = measure_situations(
            out, {1: (world, source[0], source[1:])}, learning, progress,
            f"{scenario.name}: {scenario.traffic.learners} learners among SUMO traffic",
            save_learner, connect_ray(address) if executor == "ray" else None,
            lambda rules: {"scenario": fingerprint(world.scenario, rules=rules)})  # its files too
        for kept in (out / "controllers").glob("learner*.npz"):  # of a run with more learners
            index = kept.stem.removeprefix("learner")
            if index.isdigit() and int(index) >= scenario.traffic.learners:
                kept.unlink()
        write_tables(out, measured.situations, measured.learners)
        facts.write_all(out, "crowd")
        draw_crowd(world, out, progress)
    return summary(out)


def summary(out: Path) -> list[str]:
    """What the command prints: each table's rates and paired difference, and whether the
    learners bred (a learning span too short for their populations leaves Table 4's
    "after learning" the copied start population)."""
    import pandas as pd

    table3 = pd.read_csv(out / "table3.csv").iloc[0]
    table4 = pd.read_csv(out / "table4.csv").iloc[0]
    bred = pd.read_csv(out / "table4_learners.csv")["generations_bred"]

    def difference(row, name: str) -> str:
        return (f"{row[name]:+.4f}, 90% interval {row[name + '_low']:+.4f} to "
                f"{row[name + '_high']:+.4f}")

    lines = [f"Table 3, collisions per learner-second over the first window: initial drivers "
             f"{table3.initial_collisions_per_s:.4f}, the winner for all "
             f"{table3.winner_collisions_per_s:.4f} "
             f"({difference(table3, 'winner_minus_initial')})",
             f"Table 4, over the window after learning: initial drivers "
             f"{table4.initial_after_collisions_per_s:.4f}, after learning together "
             f"{table4.population_collisions_per_s:.4f} "
             f"({difference(table4, 'population_minus_initial_after')}), the winner driving "
             f"on {table4.winner_after_collisions_per_s:.4f} "
             f"({difference(table4, 'population_minus_winner_after')}); generations bred per "
             f"learner: median {bred.median():g}, {bred.min()}-{bred.max()}"]
    if bred.max() == 0:
        lines.append("note: no learner bred a generation, so 'after learning together' is the "
                     "copied start population; give crowd.learning_s more time than "
                     "crowd.population_size lives of crowd.life_cap_steps steps")
    return lines + cost_lines(pd.read_csv(out / "crowd_cost.csv"))


def record_crowd(scenario: Scenario, genes: np.ndarray, seed: int, seconds: float
                 ) -> tuple[np.ndarray, list[np.ndarray]]:
    """The learners' centres (n, K, 2; NaN off the network) and SUMO's vehicles' centres at
    each step of ``seconds`` of the learners driving ``genes`` (K, G, source layout) in the
    situation ``seed``; SUMO in this process."""
    from enn_traffic.sim.sumo.crowd import SumoCrowd
    from enn_traffic.sumo.simulation import FAR

    world = make_world(scenario)
    dt = scenario.vehicle.dt
    learners, traffic = [], []
    with SumoCrowd(world, seed) as crowd:
        for _ in range(round(seconds / dt)):
            crowd.run(dt, genes)
            centres = crowd.lives.pose[:, :2].copy()
            centres[np.abs(centres).max(axis=1) >= FAR / 2] = np.nan
            learners.append(centres)
            ids, _, vehicles = crowd.slots
            traffic.append(vehicles[crowd.now][ids[crowd.now] >= 0].copy())
    return np.array(learners), traffic


def draw_crowd(world, out: Path, progress: bool) -> Path:
    """``crowd.gif``: the learners' controllers after learning in the first situation driving
    together for :data:`GIF_SECONDS` in that situation's SUMO (a fresh process); ``world``:
    the crowd's closed-loop SUMO world."""
    from enn_traffic.report.animate import animate_crowd
    from enn_traffic.sumo.fresh import fresh

    scenario = world.scenario
    path, stamp = out / "crowd.gif", out / "crowds" / "gif.json"
    files = [out / "controllers" / f"learner{k}.npz" for k in range(scenario.traffic.learners)]
    drawn_from = key_of(scenario.to_toml(), GIF_SECONDS, *(file.read_bytes() for file in files))
    if (path.is_file() and stamp.is_file()
            and json.loads(stamp.read_text(encoding="utf-8")) == drawn_from):
        return path  # a resumed run: drawn from these controllers already
    genes = np.array([Controller.load(file).chromosome for file in files])
    seed = world.seeds(SITUATION_KEY)[0]
    with slow_step(f"driving the learners for the GIF ({GIF_SECONDS:g} s of SUMO time)"):
        learners, traffic = fresh(record_crowd, scenario, world.spec.in_source_layout(genes),
                                  seed, GIF_SECONDS)
    animate_crowd(world.track.walls, learners, traffic, path,
                  f"{scenario.name}: {scenario.traffic.learners} learners (red) after learning "
                  "together, among SUMO's vehicles (grey)", scenario.vehicle.dt,
                  progress=progress)
    write_text(stamp, json.dumps(drawn_from))
    return path
