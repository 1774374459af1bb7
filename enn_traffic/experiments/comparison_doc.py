"""docs/results.md's section on the GA against PPO and SAC
(:mod:`enn_traffic.experiments.gradient_rl.campaign`), written from a comparison folder's CSVs and
its ``protocol.json`` (the folder's protocol, not today's): the protocol, the search, the test
fitness, the differences from the GA with their family-corrected intervals, and how the gap changes
between the spin rules (issue 65)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from enn_traffic.config.shipped import shipped_scenario
from enn_traffic.experiments.gradient_rl import campaign, scoring, stats
from enn_traffic.experiments.gradient_rl import protocol as round_protocol

TRACKS = {"navigation_narrow": "narrow track", "navigation_narrow_spin40": "narrow track",
          "arena_strategy1": "arena, strategy 1"}


def _steps(budget: float) -> str:
    return f"{budget / 1e6:g} M"


def _name(scenario: str, spin_variance: float) -> str:
    """A scenario as the tables name it: its track, and its spin rule where it has two."""
    track = TRACKS.get(scenario, scenario)
    if not any(scenario in pair for pair in stats.RULE_PAIRS):
        return track
    paper = (" (the paper's)" if any(scenario == pair[0] for pair in stats.RULE_PAIRS)
             else "")
    return f"{track}, spin ≤ {spin_variance:g} m²{paper}"


def comparison(folder: Path) -> str:
    """The section, from ``folder``'s CSVs."""
    protocol = json.loads((folder / "protocol.json").read_text())
    runs = pd.read_csv(folder / "comparison.csv")
    tuning = pd.read_csv(folder / "tuning.csv")
    rules = dict(zip(runs["scenario"], runs["spin_variance"], strict=False))
    rules |= {name: shipped_scenario(name).episode.spin_variance  # searched, no run yet
              for name in set(tuning["scenario"]) - set(rules)}
    names = {name: _name(name, rule) for name, rule in rules.items()}
    lines = _protocol(protocol, folder, names)
    lines += _search(tuning, names)
    lines += _fitness(runs, folder, names)
    lines += _differences(pd.read_csv(folder / "comparison_differences.csv"), names, runs)
    lines += _rule_changes(pd.read_csv(folder / "comparison_rules.csv"), names)
    if (folder / "travel.csv").is_file():
        travel = pd.read_csv(folder / "travel.csv")
        lines += _travel(travel, names) + _ablations(travel, names)
    lines += _stopping(pd.read_csv(folder / "curves.csv").merge(
        runs[round_protocol.RUN_KEYS]), names,
        protocol["validation_situations"])
    lines += ["", f"![GA, PPO and SAC](../{folder.parent.name}/{folder.name}/comparison.png)",
              ""]
    lines += _training_lives(pd.read_csv(folder / "training_lives.csv"), names)
    return "\n".join(lines)


def _protocol(protocol: dict, folder: Path, names: dict[str, str]) -> list[str]:
    starts = _starts(protocol)
    scenarios = " ".join(json.loads((folder / "scenarios.json").read_text()))
    planned = ", ".join(f"{p.method} {_steps(p.budget_steps)} × {p.seeds} seeds"
                        for p in round_protocol.PLAN)
    return [
        f"`enn-traffic baseline {scenarios}` (PPO and SAC need the `[rl]` extra and a CPU "
        "torch: docs/envs.md). Every method learns on training keys: the GA meets a new key "
        "each generation, PPO and SAC draw each life from "
        f"{protocol['training_pool_keys']:,} training keys (on the narrow track, without "
        "traffic and from its one start, every key is the same situation). A run's "
        f"candidates are its controllers at every 1/{protocol['checkpoints']} of its budget "
        "and the last it learned (PPO's and SAC's policy acting on its mean; the GA's best "
        "of the generation that reached the checkpoint, one a generation at most). No method "
        "learns from steps past its budget: the GA's last generation and PPO's last rollout "
        "end within it. Candidates are scored on "
        f"{protocol['validation_situations']} validation situations (keys from "
        f"{protocol['validation_key']:,}); the best there is the run's controller (saved in "
        f"`controllers/`), scored once on {protocol['test_situations']} test situations (keys "
        f"from {protocol['test_key']:,}, read by this round alone). The narrow track trains "
        "from its one start (§5.1) and is scored from starts all along it (every 5 m, facing "
        f"either way): of its {protocol['test_situations']} test starts {starts['distinct']} "
        f"are distinct, and {starts['shared']} of them also start a validation situation. "
        f"Validation and test take {starts['used']} of the track's {starts['track']} starts, "
        "and the median test start has a validation start facing the same way "
        f"{starts['validation_nearest']:.0f} m from it; the training start "
        f"is {starts['training_nearest']:.1f} m from the nearest test start. "
        f"Planned per scenario: {planned}. A run's random stream comes from its seed and its "
        "budget, so a 5 M run is no continuation of a 1 M run; the two spin rules' "
        "scenarios share their seed, so a seed starts alike under both. Every method's "
        "setting is the best on validation of an equal search (below). Runs ran two at a "
        "time on the shared 2-core machine, one torch thread each; wall time is training "
        "alone.",
        ""]


def _starts(protocol: dict) -> dict:
    """The narrow track's starts under ``protocol``: which of its test starts are also
    validation starts, how many are distinct, how many starts the track has, and how far
    the training start is from the nearest test start."""
    import numpy as np

    from enn_traffic.envs.rangefinder import rangefinder_world

    narrow = shipped_scenario("navigation_narrow")
    training = scoring.start_of(rangefinder_world(narrow).situations(0)[0])
    scored = scoring.scoring_scenario(narrow)
    world = rangefinder_world(scored)

    def starts(chosen: list[int], count: int) -> list[tuple]:
        return [scoring.start_of(situation) for key in chosen
                for situation in world.situations(key)][:count]

    validation_keys, test_keys = scoring.held_out_keys(scored, protocol)
    validation = set(starts(validation_keys, protocol["validation_situations"]))
    test = starts(test_keys, protocol["test_situations"])
    def nearest(start: tuple, among: set) -> float:  # facing the same way
        return min((np.hypot(start[0] - x, start[1] - y) for x, y, heading in among
                    if abs(np.angle(np.exp(1j * (heading - start[2])))) < 0.1), default=np.inf)

    return {"shared": sum(start in validation for start in test), "distinct": len(set(test)),
            "test_shared": [start in validation for start in test],
            "validation_nearest": float(np.median([nearest(start, validation)
                                                   for start in test])),
            "track": len(world.starts), "used": len(validation | set(test)),
            "training_nearest": min(np.hypot(x - training[0], y - training[1])
                                    for x, y, _ in test)}


def _search(tuning: pd.DataFrame, names: dict[str, str]) -> list[str]:
    budget = tuning["budget_steps"].iloc[0]
    counts = tuning.groupby("method")["setting"].nunique()
    searched = (f"{counts.iloc[0]} settings of each method" if counts.nunique() == 1 else
                ", ".join(f"{count} settings of {method}" for method, count in counts.items()))
    lines = [
        "The search (`tuning.csv`, every setting in `enn_traffic/baseline.py`'s `SEARCH`): "
        f"{searched}, one run each per scenario (seed {round_protocol.TUNING_SEED}, "
        f"{_steps(budget)} learner-steps at most) scored on validation keys; the best is "
        "each method's setting in the comparison, a tie going to the setting listed first "
        "(PPO and SAC start at RL Zoo's BipedalWalker-v3 entries; the GA's other settings "
        "keep the scenario's share of elites). One seed a setting: the seeds' spread below "
        "is the measure of how much a search score can owe to its seed.",
        "",
        "| scenario | method | validation fitness: best (its setting) | median | worst |",
        "|---|---|---|---|---|"]
    for (name, method), rows in tuning.groupby(["scenario", "method"]):
        chosen = campaign.chosen_setting(tuning, name, method)
        best = rows.set_index("setting").loc[chosen, "validation_fitness"]
        fitness = rows["validation_fitness"]
        searching = ("" if len(rows) == len(round_protocol.SEARCH[method]) else
                     f", {len(rows)} of {len(round_protocol.SEARCH[method])} settings so far")
        lines.append(f"| {names.get(name, name)} | {method} | {best:,.0f} ({chosen}"
                     f"{searching}) | {fitness.median():,.0f} | {fitness.min():,.0f} |")
    return lines + [""]


def _fitness(runs: pd.DataFrame, folder: Path, names: dict[str, str]) -> list[str]:
    # from the runs' rows alone: a run's other rows are written before its comparison row,
    # so a run under way may have some (and comparison_summary.csv may be older)
    keys = round_protocol.RUN_KEYS
    summary = stats.summary(runs, pd.read_csv(folder / "curves.csv").merge(
        runs[keys], on=keys))
    situations = pd.read_csv(folder / "situations.csv").merge(runs[keys], on=keys)
    planned = {(p.method, p.budget_steps): p.seeds for p in round_protocol.PLAN}
    lines = [
        "Test fitness (steps lived, 0 for a spin) of each run's chosen controller: the mean "
        "over seeds with its 90% Student's t interval over seeds (cut to the fitness a run "
        "can have, 0 to the step cap); at the cap: the share of "
        "all its runs' test situations driven to the scenario's step cap. The learner-steps "
        "simulated are in brackets (short of the budget where the GA's last generation or "
        "PPO's last rollout would have ended past it); validation − test: the optimism of "
        "choosing the best of many candidates.",
        "",
        "| scenario | method | budget (simulated) | seeds | test fitness (90% interval over "
        "seeds) | runs, min–max | at the cap | candidates | chose its last | validation − "
        "test | wall time per run |",
        "|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in summary.itertuples():
        mine = runs[(runs["scenario"] == row.scenario) & (runs["method"] == row.method)
                    & (runs["budget_steps"] == row.budget_steps)]
        cap = shipped_scenario(row.scenario).episode.max_steps
        lived = situations[(situations["scenario"] == row.scenario)
                           & (situations["method"] == row.method)
                           & (situations["budget_steps"] == row.budget_steps)]["test_fitness"]
        seeds = planned.get((row.method, row.budget_steps))
        lines.append(
            f"| {names[row.scenario]} | {row.method} | {_steps(row.budget_steps)} "
            f"({row.learner_steps / 1e6:.2f} M) | {row.seeds}"
            f"{'' if seeds in (None, row.seeds) else f' of {seeds}'} | "
            f"{row.test_fitness:,.0f} ({max(row.seeds_low, 0):,.0f}–"
            f"{min(row.seeds_high, cap):,.0f}) | "
            f"{mine['test_fitness'].min():,.0f}–{mine['test_fitness'].max():,.0f} | "
            f"{(lived >= cap).mean():.0%} | {row.candidates:.0f} | "
            f"{row.last_chosen} of {row.seeds} | {row.validation_minus_test:,.0f} | "
            f"{row.wall_s:.0f} s |")
    return lines + [""]


def _cell(row) -> str:
    if pd.isna(row.p_value):
        return f"{row.minus_ga:+,.0f}"
    return (f"{row.minus_ga:+,.0f} ({row.minus_ga_low:+,.0f} to {row.minus_ga_high:+,.0f}; "
            f"together {row.minus_ga_low_simultaneous:+,.0f} to "
            f"{row.minus_ga_high_simultaneous:+,.0f}), p {row.p_value:.2g}, Holm "
            f"{row.p_holm:.2g}, above {row.above_ga:.0%}")


def _differences(differences: pd.DataFrame, names: dict[str, str], runs: pd.DataFrame
                 ) -> list[str]:
    if differences.empty:
        return []
    ga_budgets = sorted(differences["ga_budget_steps"].unique())
    lines = [
        "PPO and SAC minus the GA (`comparison_differences.csv`): the difference of the seeds' "
        "mean test fitness with its 90% Welch t interval; *together*: Bonferroni's "
        "simultaneous interval, all of a scenario's comparisons at once (90% together); p: "
        "the exact permutation test's (every split of the two groups' seeds), and Holm's "
        "adjustment of it for the same family; above: the share of (seed, GA seed) pairs "
        "in which the method's seed scores higher, ties counting half.",
        "",
        "| scenario | method, budget | " + " | ".join(
            f"minus the GA at {_steps(b)}" for b in ga_budgets) + " |",
        "|---|---|" + "---|" * len(ga_budgets)]
    for (name, method, budget), rows in differences.groupby(
            ["scenario", "method", "budget_steps"]):
        cells = {row.ga_budget_steps: _cell(row) for row in rows.itertuples()}
        lines.append(f"| {names.get(name, name)} | {method}, {_steps(budget)} | "
                     + " | ".join(cells.get(b, "") for b in ga_budgets) + " |")
    return lines + [""] + _verdicts(differences, names, runs)


def _verdicts(differences: pd.DataFrame, names: dict[str, str], runs: pd.DataFrame,
              alpha: float = 0.1) -> list[str]:
    """Each method against the GA at the same budget, read from the table above: ahead or
    behind where Holm's p is under ``alpha``, else not told apart; with the seeds' medians,
    which a few seeds at the step cap move less than the means."""
    median = runs.groupby(["scenario", "method", "budget_steps"])["test_fitness"].median()
    lines = [f"In short, each method against the GA at the same budget (Holm's p under "
             f"{alpha:g}, a scenario's comparisons at once; the seeds' median test fitness, "
             "the method's against the GA's):", ""]
    same = differences[differences["budget_steps"] == differences["ga_budget_steps"]]
    for name, rows in same.groupby("scenario", sort=False):
        parts = []
        for row in rows.itertuples():
            verdict = ("not told apart from the GA" if not row.p_holm < alpha else
                       "ahead of the GA" if row.minus_ga > 0 else "behind the GA")
            parts.append(
                f"{row.method} at {_steps(row.budget_steps)} {verdict} (Holm p "
                f"{row.p_holm:.2g}; above the GA in {row.above_ga:.0%} of seed pairs; "
                f"medians {median[name, row.method, row.budget_steps]:,.0f} against "
                f"{median[name, 'GA', row.ga_budget_steps]:,.0f})")
        lines.append(f"- {names.get(name, name)}: " + "; ".join(parts) + ".")
    return lines + [""]


def _rule_changes(changes: pd.DataFrame, names: dict[str, str]) -> list[str]:
    if changes.empty:
        return []
    paper_rule, second = (names.get(n, n) for n in changes.iloc[0][["paper_rule",
                                                                     "second_rule"]])
    lines = [
        "How the gap changes between the spin rules (`comparison_rules.csv`): each method's "
        "difference from the GA under each rule; how often a seed of the method scores above "
        "a seed of the GA (of every pair; a measure no rescaling of fitness changes, where "
        "the rules' fitness ranges differ); and the change of the difference (second rule "
        "minus the paper's) with its 90% Welch–Satterthwaite interval over the four groups "
        "of seeds and, *together*, Bonferroni's simultaneous one for the table. A seed "
        "starts alike under both rules (the scenarios share their seed); the intervals treat "
        "the groups as independent.",
        "",
        f"| method, budget | against the GA at | minus the GA, {paper_rule} | minus the GA, "
        f"{second} | above the GA, paper's → second | change (90% interval; together) |",
        "|---|---|---|---|---|---|"]
    for row in changes.itertuples():
        lines.append(f"| {row.method}, {_steps(row.budget_steps)} | "
                     f"{_steps(row.ga_budget_steps)} | {row.minus_ga_paper_rule:+,.0f} | "
                     f"{row.minus_ga_second_rule:+,.0f} | {row.above_ga_paper_rule:.0%} → "
                     f"{row.above_ga_second_rule:.0%} | {row.change:+,.0f} "
                     f"({row.change_low:+,.0f} to {row.change_high:+,.0f}; "
                     f"{row.change_low_simultaneous:+,.0f} to "
                     f"{row.change_high_simultaneous:+,.0f}) |")
    return lines + [""]


def _travel(travel: pd.DataFrame, names: dict[str, str]) -> list[str]:
    from enn_traffic.experiments.gradient_rl import spin_rule

    situations = travel["situations"].iloc[0]
    lines = [
        "Where the controllers drive (`travel.csv`, "
        "`python -m enn_traffic.experiments.gradient_rl.spin_rule travel`): "
        f"each run's controller on the first {situations} validation situations. Long lives "
        f"pass {spin_rule.LONG:,} steps; their extent is the larger of the x and y ranges "
        f"of a life's last {spin_rule.TAIL:,} positions (a vehicle circling where the "
        "looser rule lets it, a radius of 9–11.5 m, stays within 23 m; *circling*: long "
        f"lives within {spin_rule.CIRCLING:g} m); *turned*: long lives that reach a dead end "
        f"of the track (within {spin_rule.END_RADIUS:g} m of it) and then reach one again, "
        "so turned round at least once (the track is one corridor between two dead ends); "
        "and the same controllers scored under the other rule of the pair.",
        "",
        "| scenario | method, budget | runs | long lives (of all) | capped | circling | "
        "turned | dead ends met by a long life (median) | distance of a long life (median of "
        "the runs' medians) | least extent of a long life | fitness | under the other rule "
        "(spins) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (name, method, budget), rows in travel.groupby(["scenario", "method",
                                                        "budget_steps"]):
        long = rows["long_lives"].sum()
        lines.append(
            f"| {names.get(name, name)} | {method}, {_steps(budget)} | {len(rows)} | "
            f"{long} of {rows['situations'].sum()} | {rows['capped'].sum()} | "
            f"{rows['circling'].sum()} | {rows['turned'].sum()} | "
            + (f"{rows['median_end_visits'].median():g} | "
               f"{rows['median_distance'].median():,.0f} m | "
               f"{rows['least_tail_extent'].min():,.0f} m | " if long else "– | – | – | ")
            + f"{rows['fitness'].mean():,.0f} | {rows['other_rule_fitness'].mean():,.0f} "
            f"({rows['other_rule_spins'].sum()}) |")
    return lines + [""]


def _minus(mine: pd.Series, ga: pd.Series) -> str:
    """A table cell: the difference of two groups' means with its 90% Welch t interval."""
    from enn_traffic.report.stats import welch_contrast

    estimate, low, high = welch_contrast([mine, ga], [1, -1])
    return f"{estimate:+,.0f}" + ("" if np.isnan(low) else f" ({low:+,.0f} to {high:+,.0f})")


def _ablations(travel: pd.DataFrame, names: dict[str, str]) -> list[str]:
    """The step cap and the start state as ablations: each group's validation fitness had lives been
    capped lower (:func:`~enn_traffic.experiments.gradient_rl.spin_rule.capped`) and its one life
    from the start it trained from, each with its difference from the GA at the same budget and a
    90% Welch t interval over seeds."""
    from enn_traffic.experiments.gradient_rl import spin_rule

    columns = [*(f"fitness_cap_{cap}" for cap in spin_rule.CAPS), "fitness",
               "training_start_fitness"]
    lines = [
        "The step cap and the start state as ablations (the same controllers and validation "
        "situations as above): each method's mean fitness had a life been capped at "
        + ", ".join(f"{cap:,}" for cap in spin_rule.CAPS) + " steps (a life past the cap "
        "scores the cap), at the scenario's own cap, and of one life from the start it "
        "trained from (the narrow track's one start, §5.1; one life a seed), each with its "
        "difference from the GA at the same budget and a 90% Welch t interval over seeds "
        "(uncorrected).",
        "",
        "| scenario | method, budget | " + "".join(
            f"cap {cap:,} | minus the GA | " for cap in spin_rule.CAPS)
        + "the scenario's cap | minus the GA | from the training start | minus the GA |",
        "|---|---|" + "---|---|" * len(columns)]
    for name, runs in travel.groupby("scenario"):
        ga = {budget: rows for budget, rows in runs[runs["method"] == "GA"].groupby(
            "budget_steps")}
        for (method, budget), rows in runs.groupby(["method", "budget_steps"]):
            theirs = ga.get(budget) if method != "GA" else None
            cells = []
            for column in columns:
                cells.append(f"{rows[column].mean():,.0f}")
                if theirs is None:
                    cells.append("–")
                    continue
                cells.append(_minus(rows[column], theirs[column]))
            lines.append(f"| {names.get(name, name)} | {method}, {_steps(budget)} | "
                         + " | ".join(cells) + " |")
    return lines + [""]


def _stopping(curves: pd.DataFrame, names: dict[str, str], situations: int) -> list[str]:
    """The stopping rule as an ablation: each run's last candidate (the controller its
    training ended with) against its chosen one (the best on validation), both on the
    validation situations; the last one's difference from the GA's last at the same budget,
    with a 90% Welch t interval over seeds."""
    runs = curves.sort_values("learner_steps").groupby(round_protocol.RUN_KEYS).agg(
        chosen=("validation_fitness", "max"),
        last=("validation_fitness", "last")).reset_index()
    lines = [
        f"The stopping rule as an ablation (`curves.csv`, all {situations} validation "
        "situations): "
        "each run's chosen controller (the best of its candidates on validation, as above) "
        "and its last (the one its training ended with, chosen by nothing), the mean over "
        "seeds, and the last ones' difference from the GA's last at the same budget with a "
        "90% Welch t interval over seeds (uncorrected).",
        "",
        "| scenario | method, budget | chosen | last | last, minus the GA's last |",
        "|---|---|---|---|---|"]
    for name, scenario_runs in runs.groupby("scenario"):
        ga = {budget: rows["last"] for budget, rows in
              scenario_runs[scenario_runs["method"] == "GA"].groupby("budget_steps")}
        for (method, budget), rows in scenario_runs.groupby(["method", "budget_steps"]):
            cell = _minus(rows["last"], ga[budget]) if method != "GA" and budget in ga else "–"
            lines.append(f"| {names.get(name, name)} | {method}, {_steps(budget)} | "
                         f"{rows['chosen'].mean():,.0f} | {rows['last'].mean():,.0f} | "
                         f"{cell} |")
    return lines + [""]


def _training_lives(lives: pd.DataFrame, names: dict[str, str]) -> list[str]:
    lines = [
        "How long the lives lived while learning were (`training_lives.csv`: one run per "
        "method, seed 1, its first budget; the GA's every individual in every situation, "
        "PPO's and SAC's exploring policy):",
        "",
        "| scenario | method | learner-steps | lives | median | longest | over 100 steps | "
        "over 1,000 steps |",
        "|---|---|---|---|---|---|---|---|"]
    for row in lives.sort_values(["scenario", "method"]).itertuples():
        lines.append(f"| {names.get(row.scenario, row.scenario)} | {row.method} | "
                     f"{_steps(row.budget_steps)} | {row.lives:,} | {row.median_life:.0f} | "
                     f"{row.longest_life:,} | {row.lives_over_100:,} | "
                     f"{row.lives_over_1000:,} |")
    return lines
