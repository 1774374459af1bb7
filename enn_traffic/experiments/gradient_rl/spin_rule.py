"""The spin rule's second setting for the GA-against-RL comparison.

The authors' code rules a vehicle whose last ``spin_window`` positions vary by at most
``spin_variance`` m² on both axes to be spinning in place: fitness 0 (§5.3). On the narrow
track's double bend that also rules ordinary driving a spin. Controllers without learning
that keep to the middle of the road (:func:`centre_keeping`: steer towards the side whose
beams read farther) show where: each is driven on the comparison's validation situations
under every candidate ``spin_variance``, and the second rule is the largest candidate under
which none of their lives ends as a spin (:func:`chosen_variance`). Validation keys only:
the choice reads no test situation.

A looser rule also lets more through: :func:`travel` checks whether the comparison's long
lives under it drive the track, turn round at its dead ends (:func:`end_visits`) or circle
in place, and scores each controller under lower step caps (:func:`capped`) and from the
start it trained from: the ablations of docs/results.md.

``python -m enn_traffic.experiments.gradient_rl.spin_rule [OUT]`` writes ``OUT/spin_rule.csv``
(default :data:`FOLDER`, the comparison's);
``python -m enn_traffic.experiments.gradient_rl.spin_rule travel [OUT]`` writes
``OUT/travel.csv`` from the runs there.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config import Scenario
from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.core import progress
from enn_traffic.core.io import write_atomic
from enn_traffic.experiments.gradient_rl import campaign, policy, protocol, scoring, stats
from enn_traffic.roads.network import read_net

# Candidate ``spin_variance`` values (m²), the paper's first; gains of the centre-keeping
# controllers (steering, as a share of full lock, per unit of the normalised left-right
# difference of the beams).
CANDIDATES = (64.0, 56.0, 48.0, 40.0, 32.0, 24.0, 16.0)
GAINS = (0.5, 1.0, 2.0, 4.0)
FOLDER = "results/baseline"


def centre_keeping(gain: float, beam_range: float) -> Callable[[np.ndarray], np.ndarray]:
    """A controller that keeps to the middle of the road: ``u = gain · (mean of the left
    half's beams − mean of the right half's) / range``, clipped to [−1, 1], as the action
    (−u, u): steering = the vehicle's gain · u, towards the side with more room (beams are
    read right to left; docs/envs.md)."""

    def act(observation: np.ndarray) -> np.ndarray:
        half = observation.shape[1] // 2
        left = observation[:, -half:].mean(axis=1)
        right = observation[:, :half].mean(axis=1)
        u = np.clip(gain * (left - right) / beam_range, -1.0, 1.0)
        return np.column_stack([-u, u]).astype(np.float32)

    return act


def spin_table(scenario: Scenario, keys: list[int], candidates=CANDIDATES,
               gains=GAINS) -> pd.DataFrame:
    """Per candidate ``spin_variance`` and gain: how many of the situations of ``keys`` the
    centre-keeping controller's lives end as a spin, as a collision, at the cap, and their
    median length."""
    beam_range = scenario.sensor.range
    rows = []
    for variance in candidates:
        ruled = scenario.with_overrides(episode={"spin_variance": variance})
        for gain in gains:
            table = scoring.policy_lives(ruled, centre_keeping(gain, beam_range), keys)
            rows.append({"scenario": scenario.name, "spin_variance": variance, "gain": gain,
                         "situations": len(table),
                         "spins": int((table["outcome"] == "spin").sum()),
                         "collisions": int((table["outcome"] == "collision").sum()),
                         "capped": int((table["outcome"] == "capped").sum()),
                         "median_steps": float(table["steps"].median()),
                         "first_key": keys[0]})
    return pd.DataFrame(rows)


def chosen_variance(table: pd.DataFrame) -> float:
    """The largest candidate ``spin_variance`` under which no centre-keeping life ends as a
    spin."""
    spins = table.groupby("spin_variance")["spins"].sum()
    passed = spins[spins == 0]
    if passed.empty:
        raise ValueError("centre keeping spins under every candidate spin_variance")
    return float(passed.index.max())


def write(out: Path) -> pd.DataFrame:
    """``out/spin_rule.csv``: the narrow track's table on the comparison's validation
    situations."""
    narrow = shipped_scenario("navigation_narrow")
    validation, _ = scoring.held_out_keys(narrow)
    table = spin_table(scoring.scoring_scenario(narrow), validation)
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / "spin_rule.csv", lambda handle: table.to_csv(handle, index=False))
    return table


def controller_act(folder: Path, scenario: Scenario, method: str, budget: int,
                   seed: int) -> Callable[[np.ndarray], np.ndarray]:
    """A comparison run's saved controller as a policy for the vector environment (on the
    observations :func:`baseline.observation_dtype` names)."""
    from enn_traffic.envs.rangefinder import action_of, rangefinder_world
    from enn_traffic.runs.controller import Controller

    path = campaign.controller_path(folder, scenario.name, method, budget, seed)
    if method != "GA":
        return policy.NumpyPolicy.load(path)
    chromosome = Controller.load(path).chromosome[None]
    spec = rangefinder_world(scenario).spec
    return lambda observation: action_of(
        spec.forward(np.repeat(chromosome, len(observation), 0), observation))


LONG = 1000  # a life this long (steps) has left any bend behind
TAIL = 1000  # the last positions of a long life whose extent says whether it still travels
END_RADIUS = 20.0  # m: a life this close to a dead end of the track has reached it
CAPS = (1000, 5000)  # lower step caps, the scenario's as an ablation (:func:`capped`)
CIRCLING = 25.0  # m: a long life whose tail stays this close circles (a 11.5 m radius: 23 m)


def travel(folder: Path, situations: int = 32) -> pd.DataFrame:
    """Do long lives under the second rule drive the track, or circle in a space the rule
    lets through (a radius of 9–11.5 m, tests/experiments/test_spin_rule.py)? Every comparison
    run of the pair's scenarios in ``folder``, its controller driven on the first ``situations``
    validation situations: how many lives pass :data:`LONG` steps, their median distance,
    and the smallest extent of their last :data:`TAIL` positions (a circle of 11.5 m stays
    within 23 m). The same controller scored under the pair's other rule too: what a rule
    does to a controller trained under the other, and from the one start it trained from
    (the start state as an ablation: the situations start all along the track). Validation
    keys only, ``folder/travel.csv``, a row written as each run ends: a stopped travel goes
    on from the runs it has (:func:`_travelled`)."""
    runs = pd.read_csv(folder / "comparison.csv")
    partner = {name: other for pair in stats.RULE_PAIRS
               for name, other in (pair, pair[::-1])}
    trained = {name: shipped_scenario(name) for name in partner}
    scored = {name: scoring.scoring_scenario(scenario) for name, scenario in trained.items()}
    ends_of = {name: dead_ends(scenario) for name, scenario in trained.items()}
    validation_of = {name: scoring.held_out_keys(scenario)[0]  # once a scenario, not a run
                     for name, scenario in scored.items()}
    path = folder / "travel.csv"
    rows = _travelled(path, situations)
    done = {tuple(row[key] for key in protocol.RUN_KEYS) for row in rows}
    pair_runs = [run for run in runs[runs["scenario"].isin(partner)].itertuples()
                 if tuple(getattr(run, key) for key in protocol.RUN_KEYS) not in done]
    for run in progress.bar(len(pair_runs), "travel", "run", iterable=pair_runs):
        scenario, other = scored[run.scenario], scored[partner[run.scenario]]
        validation = validation_of[run.scenario]
        act = controller_act(folder, scenario, run.method, run.budget_steps, run.seed)
        dtype = scoring.observation_dtype(run.method)
        lives = scoring.policy_lives(scenario, act, validation, situations, tail=TAIL,
                                      observation_dtype=dtype)
        crossed = scoring.policy_lives(other, act, validation, situations,
                                        observation_dtype=dtype)
        own_start = scoring.policy_lives(trained[run.scenario], act, validation[:1], 1,
                                          observation_dtype=dtype)
        long = lives[lives["steps"] > LONG]
        visits = np.array([end_visits(lived, ends_of[run.scenario]) for lived in long["path"]])
        rows.append({"scenario": run.scenario, "method": run.method,
                     "budget_steps": run.budget_steps, "seed": run.seed,
                     "situations": situations, "long_lives": len(long),
                     "capped": int((lives["outcome"] == "capped").sum()),
                     "median_distance": long["distance"].median(),
                     "least_tail_extent": long["tail_extent"].min(),
                     "circling": int((long["tail_extent"] < CIRCLING).sum()),
                     "turned": int((visits >= 2).sum()),
                     "median_end_visits": float(np.median(visits)) if len(visits) else np.nan,
                     "fitness": lives["fitness"].mean(),
                     **{f"fitness_cap_{cap}": capped(lives, cap).mean() for cap in CAPS},
                     "training_start_fitness": own_start["fitness"].iloc[0],
                     "other_rule_fitness": crossed["fitness"].mean(),
                     "other_rule_spins": int((crossed["outcome"] == "spin").sum())})
        table = pd.DataFrame(rows, columns=TRAVEL_COLUMNS)
        write_atomic(path, partial(table.to_csv, index=False))  # kept as each run ends
    return pd.DataFrame(rows, columns=TRAVEL_COLUMNS)


TRAVEL_COLUMNS = (*protocol.RUN_KEYS, "situations", "long_lives", "capped", "median_distance",
                  "least_tail_extent", "circling", "turned", "median_end_visits", "fitness",
                  *(f"fitness_cap_{cap}" for cap in CAPS), "training_start_fitness",
                  "other_rule_fitness", "other_rule_spins")


def dead_ends(scenario: Scenario) -> np.ndarray:
    """(E, 2): where the scenario's track ends, its SUMO network's dead-end nodes (m)."""
    net = read_net(Path(scenario.track.net))
    return np.array([node.getCoord()[:2] for node in net.getNodes()
                     if node.getType() == "dead_end"], dtype=float).reshape(-1, 2)


def end_visits(path: np.ndarray, ends: np.ndarray, radius: float = END_RADIUS) -> int:
    """How many times a life's ``path`` (steps, 2) comes within ``radius`` of one of ``ends``
    (a start there not counted): a life that drives one way meets a dead end once at most,
    one that turns round at a dead end and drives on meets one again."""
    near = (np.linalg.norm(path[:, None, :] - ends[None], axis=2) < radius).any(axis=1)
    return int((np.diff(near.astype(np.int8)) == 1).sum())


def capped(lives: pd.DataFrame, cap: int) -> np.ndarray:
    """Each life's fitness had the scenario capped lives at ``cap`` steps: a life that went
    on past ``cap`` scores ``cap`` whatever ended it later (a spin ruled after ``cap`` too),
    one that ended sooner its own fitness. The cap as an ablation of the comparison: a
    method's lead owed to lives at the 20,000-step cap shows as a gap shrinking with it."""
    return np.where(lives["steps"] > cap, cap, lives["fitness"]).astype(float)


def _travelled(path: Path, situations: int) -> list[dict]:
    """The rows of an earlier ``travel.csv`` that this one keeps: all of them when it has
    this version's columns and was driven on as many situations, else none."""
    if not path.exists():
        return []
    table = pd.read_csv(path)
    if tuple(table.columns) != TRAVEL_COLUMNS or (table["situations"] != situations).any():
        return []
    return table.to_dict("records")


if __name__ == "__main__":
    arguments = sys.argv[1:]
    if arguments[:1] == ["travel"]:
        print(travel(Path(arguments[1] if len(arguments) > 1 else FOLDER)).to_string(
            index=False))
    else:
        table = write(Path(arguments[0] if arguments else FOLDER))
        print(table.to_string(index=False))
        print(f"chosen spin_variance: {chosen_variance(table):g} m²")
