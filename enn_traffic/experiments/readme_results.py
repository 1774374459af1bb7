"""The README's table of results, written from the committed tables in ``results/paper`` rather
than typed: each row's figures are read from its CSV, so the README says what was measured.

``python -m enn_traffic.experiments.readme_results`` rewrites the table between the README's
markers after a reproduction; a test checks that the committed README holds what the
committed tables give.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments.crowds.arena import (
    LEARNING,
    curve_ends,
    direction,
    mean_reduction,
    reduction_interval,
    trend,
)
from enn_traffic.experiments.families import ARENA
from enn_traffic.experiments.table1 import diagonal_pattern

BEGIN = "<!-- results table: written by python -m enn_traffic.experiments.readme_results -->"
END = "<!-- end of results table -->"


def _table2_threshold() -> int:
    """The arena's Table 2 acceptance threshold in steps (docs/results.md)."""
    return round(ARENA.threshold)


def _navigation_cap() -> int:
    """The step cap of a navigation track's life."""
    return shipped_scenario("navigation_wide").episode.max_steps


def _span(values) -> str:
    low, high = min(values), max(values)
    return f"{low:g}" if low == high else f"{low:g}–{high:g}"


def _percent(part: float) -> str:
    return f"{100 * part:.0f}%"


def fig7(paper: Path) -> str:
    table = pd.read_csv(paper / "fig7.csv")
    reached = table["reached_B_generation"].dropna()
    return (f"best vehicle reaches the far dead end B (≥ 1200 steps) in {len(reached)}/"
            f"{len(table)} seeds, at generations {_span(reached.astype(int))}, after passing "
            f"the first turns (A) at generations {_span(table['passed_A_generation'])}; best "
            f"lifetimes {_span(table['max_best_fitness'])} steps")


def fig8(paper: Path) -> str:
    table = pd.read_csv(paper / "fig8.csv")
    capped = table["capped_generation"].dropna().astype(int)
    at_once = int((table["reached_B_generation"] == 0).sum())
    return (f"30 m track: best vehicle drives the {_navigation_cap():,}-step cap in {len(capped)}/"
            f"{len(table)} seeds, at generations {', '.join(map(str, capped))}. There is "
            f"little to learn on this track: generation 0's untrained best already passes B "
            f"in {at_once} of {len(table)} seeds; learning shows on Fig. 7's narrow track")


def fig9(paper: Path) -> str:
    table = pd.read_csv(paper / "fig9.csv")

    def sensor(row) -> str:
        name = f"{row.beams} beam{'s' if row.beams > 1 else ''}"
        if row.span_deg != 180:
            name = f"the authors' {name} over {row.span_deg}°"
        median = ("" if pd.isna(row.median_generations_to_accepted)
                  else f" (median {row.median_generations_to_accepted:g} generations)")
        return f"{name}: {row.runs_accepted}/{row.runs}{median}"

    return "over 180°: " + "; ".join(sensor(row) for row in table.itertuples())


def generalization(paper: Path) -> str:
    table = pd.read_csv(paper / "generalization.csv")
    test = table[table["tracks"] == "test"]
    shares = test.groupby("trained_on")["capped"].mean()
    single = [shares[name] for name in ("navigation_narrow", "navigation_wide")]
    return (f"on {test['track'].nunique()} test tracks of 12–30 m, controllers trained on five "
            f"tracks at once from starts drawn anywhere on them (a departure from the paper's "
            f"one track) reach the {test['cap'].max():,}-step cap in "
            f"{_percent(shares['navigation_mixed'])} of (controller, track) pairs; trained on "
            f"one track, {100 * min(single):.0f}–{_percent(max(single))} "
            "([docs/results.md](docs/results.md#generalisation-across-tracks-51))")


def table1(paper: Path) -> str:
    table = pd.read_csv(paper / "table1.csv").set_index("training_strategy")
    own, rest, on_top = diagonal_pattern(table.to_numpy())
    unseen = pd.read_csv(paper / "table1_seed5000_matrix.csv", index_col=0)
    unseen_own, unseen_rest, unseen_top = diagonal_pattern(unseen.to_numpy())
    rows = len(table)
    generations = shipped_scenario(ARENA.name(1)).ga.generations
    return (f"{generations} generations, {ARENA.table_situations} test situations per entry: "
            f"diagonal {own:.0f} against "
            f"{rest:.0f} steps ({own / rest:.2f}×), on top in {on_top} of {rows} rows; the "
            f"same controllers on traffic seed 5000: {unseen_own:.0f} against {unseen_rest:.0f}"
            f", {unseen_top} of {rows}. Strategies 2–4 are invented here (the paper defines "
            "only the first) and were adjusted until this pattern appeared on since-retired "
            "test keys ([docs/departures.md](docs/departures.md)) "
            "([docs/results.md](docs/results.md#dynamic-vehicles-paper-5354))")


def table2(paper: Path) -> str:
    table = pd.read_csv(paper / "table2.csv")
    runs = pd.read_csv(paper / "table2_runs.csv")
    threshold = _table2_threshold()
    first, last = table["average"].iloc[0], table["average"].iloc[-1]
    strategies = [c for c in table.columns if c.startswith("strategy_")]
    kept = (table[strategies].iloc[-1] > threshold).all()
    final = runs[runs["iteration"] == runs["iteration"].max()]
    others = final[~(final[strategies].to_numpy() == table[strategies].iloc[-1].to_numpy())
                   .all(axis=1)]
    below = sorted(v for v in others[strategies].to_numpy().ravel() if v < threshold)
    below_seeds = int((others[strategies] < threshold).any(axis=1).sum())
    return (f"{ARENA.incremental_hidden[0]} hidden neurons, {runs['seed'].nunique()} seeds, "
            f"the evolution chosen on "
            f"validation traffic: average {first:.0f} → {last:.0f} steps "
            f"({_percent(last / first)}), "
            f"{'every strategy above' if kept else 'not every strategy above'} the "
            f"{threshold}-step threshold at the end; {below_seeds} of the other "
            f"{len(others)} seeds' last controllers end below it among wanderers "
            f"({', '.join(f'{v:.0f}' for v in below)})")


def tables34(paper: Path) -> str:
    table = pd.read_csv(paper / "simultaneous.csv")
    situations = pd.read_csv(paper / "simultaneous_situations.csv")
    table4 = pd.read_csv(paper / "table4.csv")
    learners = pd.read_csv(paper / "table4_learners.csv")
    regime = pd.read_csv(paper / "regime.csv")
    initial = regime[regime["configuration"] == "initial drivers"]["collisions_per_s"]
    low, high = reduction_interval(situations, "population", np.random.default_rng(0),
                                   "initial_after")
    above = int((table4["population_minus_winner_after_low"] > 0).sum())
    first, last = curve_ends(pd.read_csv(paper / "table4_learning.csv"),
                             "collisions_per_vehicle_s")
    _, rise_low, rise_high = trend(pd.read_csv(paper / "table4_learning_ends.csv"))
    verb = direction(rise_low, rise_high, neither="goes, its interval spanning no change,")
    return (f"per vehicle-second: {_percent(mean_reduction(table, 'winner'))} by the winner; "
            f"after learning together for {LEARNING.learning_s / 3600:.3g} h of simulated time "
            f"(median {learners['generations_bred'].median():g} generations bred per vehicle), "
            f"each vehicle its evolved controller: "
            f"{_percent(mean_reduction(table, 'population', 'initial_after'))} below the "
            f"initial drivers over the same span (90% interval {low:.0%} to {high:.0%}; "
            f"{_percent(mean_reduction(table, 'population', 'initial'))} against their first "
            f"span, the paper's baseline), while the winner simply driving on reaches "
            f"{mean_reduction(table, 'winner_after', 'initial_after'):.1%}: above it in "
            f"{above} of {len(table4)} strategies, paired intervals apart (paper: Table 4 below "
            f"Table 3 in 4 of 4). While they learn, their rate {verb} from {first:.3f} to "
            f"{last:.3f} (the first and last tenth of the learning). In the paper's unit (all 8 "
            f"vehicles) our initial drivers collide "
            f"{initial.min():.2f}–{initial.max():.2f} times per second, the paper's "
            f"{regime['paper_low'].iloc[0]:g}–{regime['paper_high'].iloc[0]:g} "
            "([docs/results.md](docs/results.md#all-vehicles-at-once-paper-55-tables-34))")


def ablation(paper: Path) -> str:
    from enn_traffic.experiments.ablation import carrier, idle_arms

    table = pd.read_csv(paper / "table4_ablation.csv")
    arms = table.groupby(["start_population", "stopping"], sort=False)[
        "reduction_vs_first_span"].mean()
    idle = idle_arms(table)
    listed = "; ".join(("the authors' set-up" if start == "authors" else f"{start}, {stop}")
                       + f" {reduction:.0%}"
                       + (" (no generation bred)" if (start, stop) in idle else "")
                       for (start, stop), reduction in arms.items())
    return (f"fewer collisions after learning than in the learning's own first span: {listed}. "
            f"{carrier(pd.read_csv(paper / 'table4_ablation_factors.csv'))} ([docs/results.md]"
            "(docs/results.md#table-4-as-an-ablation-which-choice-carries-the-pattern))")


def lane_keeping(paper: Path) -> str:
    table = pd.read_csv(paper / "lane_keeping.csv")
    roads = table["road"].nunique()
    kept = table.groupby(["trained_on", "noise_m", "seed"])["kept_whole_episode"].sum()
    drawn, one_road = kept["lane_keeping_mixed"], kept["lane_keeping"]
    seeds = drawn.index.get_level_values("seed").nunique()
    every = int((drawn.groupby("seed").min() == roads).sum())
    fresh = table[(table["trained_on"] == "lane_keeping_mixed") & table["fresh"]]
    fresh_roads = fresh["road"].nunique()
    fresh_kept = int(fresh.groupby("seed")["kept_whole_episode"].all().sum())
    return (f"highway-env, camera offsets of the lane markings 5–20 m ahead: trained on roads "
            f"drawn per situation, {every}/{seeds} seeds keep the lane for the capped 1000 "
            f"steps on all {roads} fixed roads, none trained on (sines whose sharpest bend has "
            f"a 17 m radius, circles down to 35 m, both ways), with 0.1 m of camera noise as "
            f"without; {roads - fresh_roads} of those roads were read by earlier designs, the "
            f"{fresh_roads} fresh ones too, {fresh_kept}/{seeds}; trained on the one "
            f"road, {_span(one_road)} of {roads} "
            "([docs/results.md](docs/results.md#lane-keeping-paper-56))")


ROWS = [
    ("Fig. 7, narrow 12 m track", "learnt in < 50 generations; stalls at the 180° turn (B)",
     fig7),
    ("Fig. 8, wide track", '"very high fitness", back and forth', fig8),
    ("Fig. 9, sensor resolution", "1 beam fails; ≥ 3 beams learn; 5 fastest", fig9),
    ("unseen tracks", '"navigates other tracks"', generalization),
    ("Table 1, arena (§5.4)", "trained on one traffic strategy, deployed on each: the "
     "diagonal ≈ 4.9× the rest and tops every row", table1),
    ("Table 2, arena (§5.4.1)", "one controller, strategies added one at a time: the average "
     "stays within 96%", table2),
    ("Tables 3–4, arena (§5.5)", "collisions cut 54% by the winner driving every vehicle, 89% "
     "by learning together", tables34),
    ("Table 4's ablation, arena", "89% fewer collisions after learning together; the "
     "authors' code: random start populations, no life cap, a car finishes once a chromosome "
     "lived 2000 steps", ablation),
    ("lane keeping (§5.6)", "CarMaker camera; keeps the lane for hours after ~10 h of "
     "learning", lane_keeping),
]


def results_table(paper: Path) -> str:
    """The README's results table, with the markers around it, from the tables in ``paper``."""
    lines = [BEGIN, "| | paper | here |", "|---|---|---|"]
    lines += [f"| {name} | {claim} | {here(paper)} |" for name, claim, here in ROWS]
    return "\n".join([*lines, END])


def rewrite(readme: Path, paper: Path) -> None:
    """Replace the results table between the markers of ``readme``."""
    text = readme.read_text()
    start, end = text.index(BEGIN), text.index(END) + len(END)
    readme.write_text(text[:start] + results_table(paper) + text[end:])


if __name__ == "__main__":
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(".")
    rewrite(root / "README.md", root / "results" / "paper")
