"""Tables 3–4 among SUMO traffic (paper §5.5 on a SUMO family of strategies: ``sumo_strategy1..4``
or the city's; docs/sumo.md), by the arena's method (:mod:`enn_traffic.experiments.crowds.arena`).

``traffic.learners`` learners (8) drive at once in one live SUMO, among its own traffic
(:mod:`enn_traffic.sim.sumo.crowd`). For each strategy and each of ``SUMO_LEARNING``'s
situations, three arms drive from the same SUMO state, in windows of ``window_s``:

- initial drivers: every learner a random network (drawn per situation);
- Table 3 (§5.5.1): every learner drives the winning chromosome. The winner is the strategy's
  Table 1 controller, chosen among the controllers individual learning evolved on validation
  traffic: ranking every candidate by broadcasting it, as the arena does, would cost about
  10 min of SUMO time per strategy;
- Table 4 (§5.5.2): every learner starts from its own copy of the evolved population (the first
  ``population_size`` rows of the final population of the winner's run: its elites first) and
  all learn at once for ``seconds``, each its own GA a chromosome per life, breeding when it has
  tried its population, with the best chromosomes of all learners as elites (reference §7.4);
  a life that reaches ``life_cap_steps`` ends its chromosome's trial without a respawn. Then
  each drives the fittest chromosome of its last whole generation (the authors' rule, as the
  arena's) over the window after learning.

The initial drivers and the winner drive as long, so Table 3 compares the first window and
Table 4 the window after learning, every arm paired by situation, with bootstrap intervals of
the differences (:func:`~enn_traffic.experiments.crowds.stats.table4_comparisons`). A live SUMO
cannot be forked, so the arena's re-ranked alternative is not run here. The learning time, cap
and population were chosen on crowd validation situations (``table4_validation_learners.csv``)
so that every learner breeds 3 generations or more in SUMO time a 2-core machine affords
(docs/departures.md).

Rates are by the scenario's ``[crowd] counting`` (by default responsible collisions per
learner-second, :meth:`SumoCrowdRun.rate`) and SUMO's SSM conflicts, time-to-collision below
1.5 s, per learner-hour. The situations' SUMO
seeds come from the crowd test keys (:data:`enn_traffic.core.keys.CROWD_TEST`), which no choice
looked at in a SUMO world. Each situation is kept under ``<family folder>/crowds/`` as it ends,
so an interrupted family resumes where it stopped.

Written under ``<family folder>/``: ``crowd_situations.csv``, ``table3.csv``, ``table4.csv``,
``table4_learners.csv``, ``table4_learning.csv`` and ``.png``, ``table4_validation_learners.csv``;
under ``controllers/<family>/table4/``: each strategy's evolved population
(``strategyS_evolved.npz``) and each learner's controller after learning in the first situation
(``strategyS_learnerK.npz``); with the Table 1 controllers they drive that situation again.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.core import keys
from enn_traffic.core.io import write_csv, write_text
from enn_traffic.core.progress import slow_step, terminal
from enn_traffic.core.provenance import SAME_RULES, rules_version, sources_of
from enn_traffic.experiments.choosing import final_population, specialists
from enn_traffic.experiments.common import save_arrays, save_controller
from enn_traffic.experiments.crowds.cost import cost_table
from enn_traffic.experiments.crowds.settings import CrowdSettings
from enn_traffic.experiments.crowds.stats import (
    Measured,
    SituationResult,
    curve_facts,
    learning_curve,
    learning_ends,
    table4_comparisons,
    trend_facts,
)
from enn_traffic.experiments.families import CITY, SUMO, Family
from enn_traffic.experiments.study import Study
from enn_traffic.learning import ga
from enn_traffic.learning.online import OnlineLearning, VehicleGA
from enn_traffic.report.stats import bootstrap_interval
from enn_traffic.runs.controller import Controller
from enn_traffic.sim.sumo.crowd import SumoCrowd
from enn_traffic.sim.sumo.world import SumoWorld
from enn_traffic.sim.world import make_world
from enn_traffic.sumo.fresh import fresh, fresh_calls

# The situations whose rates are reported, and those that chose SUMO_LEARNING (the ledger,
# enn_traffic.core.keys)
SITUATION_KEY = keys.SUMO_CROWD_TEST.start
VALIDATION_KEY = keys.CROWD_CHOICE.start
# Table 4's paired differences among SUMO traffic (no re-ranked arm: a live SUMO has no fork)
CONTRASTS = [("population", "initial_after"), ("population", "winner_after")]
CONFLICTS = ["initial", "winner", "initial_after", "winner_after", "population"]


# The SUMO and city families' crowds: the [crowd] keys' defaults, chosen on the crowd
# validation situations (docs/results.md).
SUMO_LEARNING = CrowdSettings(quick={"learning_s": 20.0, "window_s": 10.0, "situations": 2,
                                     "validation_situations": 1})


def _learning(world: SumoWorld, evolved: np.ndarray, situation: int, learning: CrowdSettings
              ) -> OnlineLearning:
    """Every learner its own GA on a copy of ``evolved`` (N, G, source layout)."""
    scenario = world.scenario
    population = evolved[:learning.population_size]
    learners = [VehicleGA(population.copy(), np.random.default_rng([scenario.seed, situation, k]))
                for k in range(scenario.traffic.learners)]
    if learning.start_population == "random":  # the authors' start (reference §7.1)
        for learner in learners:
            learner.population = world.spec.in_source_layout(ga.initial_population(
                learner.rng, learning.population_size, world.spec.chromosome_length,
                scenario.ga.init_range))
            learner.fitness = np.zeros(len(learner.population))
    params = scenario.ga.model_copy(update={"elite_count": learning.elite_count})
    return OnlineLearning(learners, params, share_elites=True,
                          elite_count=learning.elite_count, life_cap=learning.life_cap_steps,
                          finish_steps=learning.finish_steps)


def learn_together(world: SumoWorld, winner: np.ndarray, evolved: np.ndarray, situation: int,
                   learning: CrowdSettings, key: int = SITUATION_KEY):
    """The learning arm of one situation: each window's run while the learners learn, the run
    of the window after it (each learner its evolved controller) and the learning.
    ``winner`` (G,) and ``evolved`` (N, G) in the source layout. SUMO runs in a fresh process
    (:mod:`enn_traffic.sumo.fresh`)."""
    learnt, after, online, _ = fresh(_learning_arm, world.scenario, winner, evolved, situation,
                                     learning, key)
    return learnt, after, online


def _learning_arm(scenario, winner, evolved, situation, learning, key):
    """:func:`learn_together` in the process it runs in."""
    world = make_world(scenario)
    count = scenario.traffic.learners
    online = _learning(world, evolved, situation, learning)
    with SumoCrowd(world, world.seeds(key + situation)[0]) as crowd:
        learnt = [crowd.run(learning.window_s, np.tile(winner, (count, 1)), online)
                  for _ in range(learning.windows)]
        after = crowd.run(learning.window_s, online.evolved_controllers())
    return learnt, after, online, crowd.cost


def _driving_arm(scenario, seed: int, genes: np.ndarray, window_s: float, windows: int):
    """An arm whose drivers keep their controllers: a run per window, SUMO in this process;
    and what it cost (:attr:`SumoCrowd.cost`)."""
    world = make_world(scenario)
    with SumoCrowd(world, seed) as crowd:
        return [crowd.run(window_s, genes) for _ in range(windows)], crowd.cost


def situation_result(world: SumoWorld, winner: np.ndarray, evolved: np.ndarray, situation: int,
                     learning: CrowdSettings, key: int = SITUATION_KEY) -> SituationResult:
    """One situation's every arm, from its SUMO seed alone, each arm's SUMO in a fresh process
    of its own (the three at once, on up to three cores). ``winner`` (G,) and ``evolved``
    (N, G) in the source layout; the controllers after learning in the source layout."""
    scenario = world.scenario
    count, windows = scenario.traffic.learners, learning.windows
    seed = world.seeds(key + situation)[0]
    rng = np.random.default_rng([scenario.traffic.seed, key, situation])
    drivers = world.spec.in_source_layout(
        rng.uniform(-1, 1, (count, world.spec.chromosome_length)))
    started = time.perf_counter()
    (initial, initial_cost), (winning, winner_cost), learning_arm = fresh_calls([
        (_driving_arm, scenario, seed, drivers, learning.window_s, windows + 1),
        (_driving_arm, scenario, seed, np.tile(winner, (count, 1)), learning.window_s,
         windows + 1),
        (_learning_arm, scenario, winner, evolved, situation, learning, key)],
        workers=min(3, os.cpu_count() or 1))
    arms = {"initial": initial, "winner": winning}
    learnt, after, online, learning_cost = learning_arm
    cost = {"situation_wall_s": time.perf_counter() - started,
            "arms": {"initial drivers": initial_cost, "the winner": winner_cost,
                     "learning together": learning_cost}}
    measured = {"initial": arms["initial"][0], "winner": arms["winner"][0],
                "initial_after": arms["initial"][-1], "winner_after": arms["winner"][-1],
                "population": after}
    counting = scenario.crowd.counting
    rates = {arm: run.rate(counting) for arm, run in measured.items()}
    rates["learning"] = float(np.mean([run.rate(counting) for run in learnt]))
    rates |= {f"{arm}_conflicts": measured[arm].conflict_rate for arm in CONFLICTS}
    rates |= {f"{arm}_conflicts_2d": measured[arm].conflict_rate_2d for arm in CONFLICTS}
    window_rows = [{"window_start_s": w * learning.window_s,
                    "learning": learnt[w].rate(counting),
                    "initial_drivers": arms["initial"][w].rate(counting),
                    "winner_driving_on": arms["winner"][w].rate(counting)}
                   for w in range(windows)]
    return SituationResult(rates, window_rows, online.learner_rows(),
                           online.evolved_controllers(), (), cost)


def crowd_world(family: Family, strategy: int) -> SumoWorld:
    """The strategy's test world with its SUMO in closed loop (the learners are in it), and the
    GA settings its populations evolved with."""
    return make_world(family.scenario(strategy).with_overrides(
        ga=dict(family.ga), traffic={"mode": "closed-loop"}))


def _kept(path: Path, settings: dict, earlier: list[dict] = ()) -> dict | None:
    """What :func:`_keep` kept at ``path`` with the same ``settings`` (or one of ``earlier``,
    the same settings as an earlier digest of these rules wrote them: :func:`_measured_as`), or
    None."""
    if path.is_file():
        kept = json.loads(path.read_text(encoding="utf-8"))
        if kept.get("settings") == settings or kept.get("settings") in earlier:
            return kept
    return None


def _measured_as(settings: dict, identity: Callable[[str | None], dict] | None
                 ) -> tuple[dict, list[dict]]:
    """``settings`` with ``identity(None)``, what else a kept situation is measured with
    (a user's scenario: its fingerprint), and the same as an earlier digest of these rules
    wrote them (:data:`~enn_traffic.core.provenance.SAME_RULES`, ``identity`` under it)."""
    def under(rules: str | None) -> dict:
        return settings | ({} if rules is None else {"rules": rules}) | (
            identity(rules) if identity else {})

    return under(None), [under(rules) for rules in SAME_RULES]


def _keep(path: Path, settings: dict, result: dict) -> dict:
    """``result`` (JSON-able) kept at ``path`` with ``settings`` so that an interrupted
    family resumes where it stopped."""
    kept = {"settings": settings, **result}
    write_text(path, json.dumps(kept))
    return kept


def _digest(winner: np.ndarray, evolved: np.ndarray) -> str:
    """Which winner and evolved population a kept situation was measured with."""
    return hashlib.sha256(np.concatenate([winner[None], evolved]).tobytes()).hexdigest()[:16]


def validation_learners(world: SumoWorld, winner: np.ndarray, evolved: np.ndarray,
                        learning: CrowdSettings) -> list[dict[str, int]]:
    """The learners' counts in a strategy's crowd validation situations: what chose
    ``learning`` (every learner breeds 3 generations or more)."""
    rows = []
    for situation in range(learning.validation_situations):
        *_, online = learn_together(world, winner, evolved, situation, learning, VALIDATION_KEY)
        rows += [{"situation": situation} | learner for learner in online.learner_rows()]
    return rows


def crowd_inputs(study: Study, family: Family
                 ) -> dict[int, tuple[SumoWorld, np.ndarray, np.ndarray]]:
    """Per strategy: its crowd world, the winner (the Table 1 controller) and the final
    population of the winner's run (source layout); the population saved under
    ``controllers/``."""
    controllers = specialists(study, family)
    inputs = {}
    for strategy in family.strategies:
        world = crowd_world(family, strategy)
        winner = controllers[strategy]
        evolved = final_population(study, family, strategy, winner)
        save_arrays(study.out, f"{family.folder}/table4/strategy{strategy}_evolved",
                    population=evolved)
        source = world.spec.in_source_layout(np.vstack([winner, evolved]))
        inputs[strategy] = world, source[0], source[1:]
    return inputs


def saved_crowd_inputs(out: Path, family: Family
                       ) -> dict[int, tuple[SumoWorld, np.ndarray, np.ndarray]]:
    """:func:`crowd_inputs` read back from what it and the Table 1 run saved under
    ``out/controllers/`` (the winners, the evolved populations): the crowds measured again
    without their GA runs."""
    folder = out / "controllers" / family.folder
    inputs = {}
    for strategy in family.strategies:
        world = crowd_world(family, strategy)
        winner = Controller.load(folder / "table1" / f"strategy{strategy}.npz").chromosome
        with np.load(folder / "table4" / f"strategy{strategy}_evolved.npz") as saved:
            evolved = saved["population"]
        source = world.spec.in_source_layout(np.vstack([winner, evolved]))
        inputs[strategy] = world, source[0], source[1:]
    return inputs


def _settings(learning: CrowdSettings) -> dict:
    """What a kept situation was measured with: ``learning``, the simulation's rules and the
    sources outside them that measure a situation."""
    settings = asdict(learning) | {"rules": rules_version(),
                                   "measured_by": sources_of(situation_result)}
    settings.pop("quick")
    return settings


def validation(folder: Path, inputs: dict[int, tuple[SumoWorld, np.ndarray, np.ndarray]],
               learning: CrowdSettings, identity: Callable[[str | None], dict] | None = None
               ) -> pd.DataFrame:
    """Every strategy's learners in its validation situations, written to
    ``table4_validation_learners.csv`` (kept under ``crowds/`` like the situations, with
    ``identity(None)`` among their settings)."""
    rows = []
    for strategy, (world, winner, evolved) in inputs.items():
        settings, earlier = _measured_as(_settings(learning) | {
            "strategy": strategy, "inputs": _digest(winner, evolved)}, identity)
        path = folder / "crowds" / f"validation_strategy{strategy}.json"
        kept = _kept(path, settings, earlier) or _keep(path, settings, {
            "learners": validation_learners(world, winner, evolved, learning)})
        rows += [{"strategy": strategy} | row for row in kept["learners"]]
    table = pd.DataFrame(rows)
    write_csv(folder / "table4_validation_learners.csv", table)
    return table


def measure(study: Study, family: Family, learning: CrowdSettings,
            inputs: dict[int, tuple[SumoWorld, np.ndarray, np.ndarray]] | None = None
            ) -> Measured:
    """Every strategy's situations, their learning windows and learners, written under the
    family's folder (the module's list); ``inputs`` (:func:`saved_crowd_inputs`) instead of
    the study's runs."""
    inputs = inputs or crowd_inputs(study, family)

    def save_learner(strategy: int, k: int, scenario, genes: np.ndarray) -> None:
        save_controller(study.out, f"{family.folder}/table4/strategy{strategy}_learner{k}",
                        scenario, genes, float("nan"))

    learners = family.scenario(family.strategies[0]).traffic.learners
    return measure_situations(
        study.out / family.folder, inputs, learning, study.progress,
        f"{len(inputs)} strategies of {family.folder}: {learners} learners among SUMO traffic",
        save_learner)


def _situation_task(scenario, winner, evolved, situation, learning) -> SituationResult:
    """A Ray task: one situation's every arm (:func:`situation_result`), from its scenario."""
    return situation_result(make_world(scenario), winner, evolved, situation, learning)


def measure_situations(folder: Path, inputs: dict[int, tuple[SumoWorld, np.ndarray, np.ndarray]],
                       learning: CrowdSettings, progress: bool, title: str,
                       save_learner=None, ray=None,
                       identity: Callable[[str | None], dict] | None = None) -> Measured:
    """Each input's validation (:func:`validation`) and situations, their learning windows and
    learners, written into ``folder`` (the module's list): each situation kept under
    ``crowds/`` as it ends, so that an interrupted measurement resumes where it stopped.
    ``save_learner(strategy, k, scenario, genes)`` keeps each learner's controller after
    learning in the first situation. With ``ray`` (:func:`~enn_traffic.learning.evaluators.
    connect_ray`'s module) the situations run side by side as Ray tasks; a situation's result
    depends on its seed alone, so it is the same wherever it ran. ``identity(rules)``: what
    else a kept situation must have been measured with under ``rules`` (None: these; a user's
    scenario: its fingerprint)."""
    with slow_step(f"{folder.name}: the crowd's validation situations ({learning.learning_s:g} s "
                   "of SUMO time learning in each)"):
        validation(folder, inputs, learning, identity)
    settings = _settings(learning) | {"key": SITUATION_KEY}
    jobs, kept = {}, {}
    for strategy, (_, winner, evolved) in inputs.items():
        for situation in range(learning.situations):
            label = (strategy, situation)
            path = folder / "crowds" / f"strategy{strategy}_situation{situation}.json"
            measured_as, earlier = _measured_as(settings | {
                "strategy": strategy, "situation": situation,
                "inputs": _digest(winner, evolved)}, identity)
            kept[label] = _kept(path, measured_as, earlier)
            if kept[label] is None:
                jobs[label] = (path, measured_as)

    def keep(label, result: SituationResult) -> None:
        strategy, situation = label
        path, measured_as = jobs[label]
        kept[label] = _keep(path, measured_as, {"rates": result.rates,
                                                "windows": result.windows,
                                                "learners": result.learners,
                                                "cost": result.cost})
        world = inputs[strategy][0]
        if situation == 0 and save_learner is not None:  # committed with the tables
            for k, genes in enumerate(world.spec.from_source_layout(result.controllers)):
                save_learner(strategy, k, world.scenario, genes)

    with tqdm(file=terminal(), total=len(kept), initial=len(kept) - len(jobs), unit="situation",
              desc=f"{folder.name} crowds", disable=not progress, leave=False) as bar:
        if ray is None:
            for label in list(jobs):
                world, winner, evolved = inputs[label[0]]
                with slow_step(f"situation {label[1] + 1} of {learning.situations}: three "
                               f"arms of {learning.learning_s + learning.window_s:g} s of "
                               "SUMO time each, side by side"):
                    keep(label, situation_result(world, winner, evolved, label[1], learning))
                bar.update(1)
        else:
            task = ray.remote(num_cpus=1)(_situation_task)
            pending = {task.remote(inputs[strategy][0].scenario, *inputs[strategy][1:],
                                   situation, learning): (strategy, situation)
                       for strategy, situation in jobs}
            while pending:
                [done], _ = ray.wait(list(pending))
                keep(pending.pop(done), ray.get(done))
                bar.update(1)
    rows, windows, learners = [], [], []
    for (strategy, situation), result in kept.items():
        label = {"strategy": strategy, "situation": situation}
        rows.append(label | result["rates"])
        windows += [label | window for window in result["windows"]]
        learners += [label | learner for learner in result["learners"]]
    measured = Measured(pd.DataFrame(rows), pd.DataFrame(windows), pd.DataFrame(learners))
    write_csv(folder / "crowd_cost.csv", cost_table(kept))
    curve = learning_curve(measured.windows)
    write_csv(folder / "crowd_situations.csv", measured.situations)
    write_csv(folder / "table4_learners.csv", measured.learners)
    write_csv(folder / "table4_learning.csv", curve)
    write_csv(folder / "table4_learning_ends.csv", learning_ends(measured.windows))
    from enn_traffic.report.figures import crowd_learning_figure

    crowd_learning_figure(curve, measured.situations, folder / "table4_learning.png",
                          learning.learning_s,
                          f"{title}, mean of the situations in {learning.window_s:g} s windows",
                          "collisions per learner-second")
    return measured


def table(situations: pd.DataFrame, columns: list[str]) -> pd.DataFrame:
    """Per strategy: the mean of each span's collision and conflict rates (SSM's and the 2-D
    ones), with the 90% interval of the collision rate over the situations."""
    rng = np.random.default_rng(0)
    rows = []
    for strategy, group in situations.groupby("strategy"):
        row = {"strategy": strategy}
        for span in columns:
            low, high = bootstrap_interval(group[span].to_numpy(), rng)
            row |= {f"{span}_collisions_per_s": round(group[span].mean(), 4),
                    f"{span}_low": round(low, 4), f"{span}_high": round(high, 4),
                    f"{span}_conflicts_per_h": round(group[f"{span}_conflicts"].mean(), 1),
                    f"{span}_conflicts_2d_per_h": round(group[f"{span}_conflicts_2d"].mean(),
                                                        1)}
        rows.append(row)
    return pd.DataFrame(rows)


def table4(situations: pd.DataFrame) -> pd.DataFrame:
    """Table 4 among SUMO traffic: each arm over the window after learning, the paired
    differences (``CONTRASTS``) with their 90% intervals, and each arm's conflicts (SSM's and
    the 2-D ones) per learner-hour."""
    arms = ["initial_after", "population", "winner_after"]
    comparisons = table4_comparisons(situations, arms, CONTRASTS)
    columns = [f"{arm}_{measure}" for arm in arms for measure in ("conflicts", "conflicts_2d")]
    conflicts = situations.groupby("strategy", as_index=False)[columns].mean().round(1)
    return comparisons.merge(conflicts.rename(
        columns={column: f"{column}_per_h" for column in columns}), on="strategy")


def write_tables(folder: Path, situations: pd.DataFrame, learners: pd.DataFrame) -> list[str]:
    """Table 3 (the winner broadcast against the initial drivers, the first window) and
    Table 4 (after learning together against both drivers driving on, the window after
    learning), each with paired intervals, into ``folder/table3.csv`` and ``table4.csv``; the
    summary's lines."""
    table3 = table(situations, ["initial", "winner"]).merge(
        table4_comparisons(situations, (), [("winner", "initial")]), on="strategy")
    write_csv(folder / "table3.csv", table3)
    write_csv(folder / "table4.csv", table4(situations))
    return crowd_lines(folder, learners)


def crowd_lines(folder: Path, learners: pd.DataFrame | None = None) -> list[str]:
    """The summary's Table 3 and Table 4 lines of a SUMO family, from the ``table3.csv``,
    ``table4.csv`` and ``table4_learners.csv`` in its ``folder``."""
    table3 = pd.read_csv(folder / "table3.csv")
    table4_rows = pd.read_csv(folder / "table4.csv")
    if learners is None:
        learners = pd.read_csv(folder / "table4_learners.csv")
    bred = learners.groupby("strategy")["generations_bred"].median()

    def entries(frame: pd.DataFrame, before: str, after: str) -> str:
        return ", ".join(
            f"strategy {int(r['strategy'])}: {r[f'{before}_collisions_per_s']:.3f} -> "
            f"{r[f'{after}_collisions_per_s']:.3f}" for _, r in frame.iterrows())

    def below(frame: pd.DataFrame, name: str) -> str:
        return (f"{int((frame[f'{name}_high'] < 0).sum())} of {len(frame)} strategies with the "
                f"paired interval below 0, {int((frame[f'{name}_low'] > 0).sum())} above")

    return [f"{folder.name}/table3: collisions per learner-second, initial drivers -> winner: "
            f"{entries(table3, 'initial', 'winner')} ({below(table3, 'winner_minus_initial')})",
            f"{folder.name}/table4: collisions per learner-second over the window after "
            f"learning, initial drivers -> after learning together: "
            f"{entries(table4_rows, 'initial_after', 'population')} (against the initial "
            f"drivers: {below(table4_rows, 'population_minus_initial_after')}; against the "
            f"winner driving on: {below(table4_rows, 'population_minus_winner_after')}); median "
            f"generations bred per learner {', '.join(f'{g:g}' for g in bred)}"]


def sumo_tables(study: Study, family: Family = SUMO) -> list[str]:
    """A SUMO family's Tables 3–4 (:func:`write_tables`), measured into its folder."""
    family = study.settings(family)
    measured = measure(study, family, study.settings(SUMO_LEARNING))
    return write_tables(study.out / family.folder, measured.situations, measured.learners)


def lane_facts(family: Family) -> dict:
    """The lanes a passenger car may drive on in ``family``'s strategy 1's network: their
    mean width weighted by length, and what it leaves on each side of the scenario's car."""
    from enn_traffic.roads.network import read_net

    scenario = family.scenario(1)
    lanes = [(lane.getWidth(), lane.getLength()) for edge in read_net(scenario.track.net)
             .getEdges() if edge.getFunction() != "internal" for lane in edge.getLanes()
             if lane.allows("passenger")]
    width = float(np.average([w for w, _ in lanes], weights=[length for _, length in lanes]))
    return {"scenario": scenario.name, "width": width, "car_width": scenario.vehicle.width,
            "margin": (width - scenario.vehicle.width) / 2}


def family_facts(folder: Path, family: Family) -> dict:
    """Facts (docs/_generate/README.md) of a SUMO family's Tables 3–4, from its subfolder of
    a reproduce folder: the learning curve's ends
    (:func:`~enn_traffic.experiments.crowds.stats.curve_facts`, ``table4_learning.csv``), the
    learners' trend (:func:`~enn_traffic.experiments.crowds.stats.trend_facts`,
    ``table4_learning_ends.csv``) and the lanes of its network (:func:`lane_facts`)."""
    tables = folder / family.folder
    return {"curve": curve_facts(pd.read_csv(tables / "table4_learning.csv")),
            "trend": trend_facts(pd.read_csv(tables / "table4_learning_ends.csv")),
            "lanes": lane_facts(family)}


def sumo_facts(folder: Path) -> dict:
    """:func:`family_facts` of the SUMO family (``sumo/``)."""
    return family_facts(folder, SUMO)


def city_facts(folder: Path) -> dict:
    """:func:`family_facts` of the city (``city/``)."""
    return family_facts(folder, CITY)
