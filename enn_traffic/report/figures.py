"""The experiments' figures (paper Fig. 11, Fig. 12, Table 1 as paths; the GA against PPO and SAC):
drawing only; the experiments compute what is drawn."""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.report.plots import draw_paths, learning_curves, save_figure
from enn_traffic.report.stats import t_interval


def fig11_figure(panels: dict[int, dict[int, pd.DataFrame]],
                 held_out: dict[tuple[int, int], np.ndarray | None], titles: dict[int, str],
                 title: str, path: Path) -> None:
    """One panel per strategy: each run's (by seed) best training fitness per generation
    (solid) and the same chromosomes on test traffic (dashed, where known)."""
    figure, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for (strategy, runs), ax in zip(panels.items(), axes.ravel(), strict=True):
        learning_curves({f"seed {s}": t for s, t in runs.items()}, None, axes=ax,
                        title=titles[strategy])
        for index, (seed, table) in enumerate(runs.items()):
            scores = held_out[strategy, seed]
            if scores is not None:
                ax.plot(table["generation"], scores, color=f"C{index}", ls="--", lw=0.9)
    figure.suptitle(title)
    figure.tight_layout()
    save_figure(figure, path)


def fig12_figure(matrix: np.ndarray, strategies: list[int], path: Path) -> None:
    """Fig. 12: mean fitness of each training strategy's controller (rows) on each deployment
    strategy (columns), as a colour map."""
    size = len(strategies)
    figure, ax = plt.subplots(figsize=(5, 4.2))
    image = ax.imshow(matrix, cmap="viridis")
    ax.set_xticks(range(size), [str(s) for s in strategies])
    ax.set_yticks(range(size), [str(s) for s in strategies])
    ax.set_xlabel("deployment strategy")
    ax.set_ylabel("training strategy")
    for i in range(size):
        for j in range(size):
            ax.text(j, i, f"{matrix[i, j]:.0f}", ha="center", va="center", color="white")
    figure.colorbar(image, label="mean fitness [steps]")
    ax.set_title("Fig. 12: fitness on seen and unseen strategies")
    figure.tight_layout()
    save_figure(figure, path)


def specialist_paths(traces: dict[tuple[int, int], np.ndarray], walls: dict[int, np.ndarray],
                     strategies: list[int], steps: int, path: Path) -> None:
    """Table 1 as paths: ``traces[trained, deployed]`` (n, V, 3), the learner first, drawn in
    a grid of training strategies (rows) by deployment strategies (columns)."""
    size = len(strategies)
    figure, axes = plt.subplots(size, size, figsize=(2.6 * size, 2.75 * size))
    for column, deployed in enumerate(strategies):
        for row, trained in enumerate(strategies):
            ax = axes[row, column]
            poses = traces[trained, deployed]
            traffic = [poses[:, v] for v in range(1, poses.shape[1])]
            draw_paths(ax, walls[deployed], [*traffic, poses[:, 0]],
                       colors=["0.65"] * len(traffic) + ["C3"])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"trained {trained}, among {deployed}: {len(poses) - 1} steps",
                         fontsize=8)
    figure.suptitle(f"Table 1 as paths: each strategy's controller (red, by row) among each "
                    f"strategy's traffic (grey, by column),\nfirst {steps} steps of a test "
                    "episode (x: where a vehicle's path ends)")
    figure.tight_layout()
    save_figure(figure, path)


# The comparison's methods (enn_traffic.experiments.gradient_rl), one colour each.
METHOD_COLOURS = {"GA": "tab:blue", "PPO": "tab:orange", "SAC": "tab:green"}


def comparison_figure(curves: pd.DataFrame, comparison: pd.DataFrame, path: Path) -> None:
    """Per scenario: the validation fitness of each run's controllers against learner-steps
    (a line per run, the longest budgets), and each method's test fitness per run."""
    import matplotlib.pyplot as plt

    scenarios = sorted(comparison["scenario"].unique())
    figure, axes = plt.subplots(len(scenarios), 2, figsize=(12, 4.4 * len(scenarios)),
                                squeeze=False, gridspec_kw={"wspace": 0.35, "hspace": 0.35})
    for row, name in zip(axes, scenarios, strict=True):
        mine = curves[curves["scenario"] == name]
        for (method, budget, _), run in mine.groupby(["method", "budget_steps", "seed"]):
            row[0].plot(run["learner_steps"], run["validation_fitness"],
                        color=METHOD_COLOURS.get(method, "gray"), alpha=0.5,
                        linestyle="-" if budget > 1_000_000 else ":",
                        label=f"{method}, {budget / 1e6:g} M")
        row[0].set_xscale("log")
        row[0].set_xlabel("learner-steps simulated")
        row[0].set_ylabel(f"{name}\nvalidation fitness (steps lived)")
        handles, labels = row[0].get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        row[0].legend(unique.values(), unique.keys(), fontsize=7)
        runs = comparison[comparison["scenario"] == name].sort_values(
            ["method", "budget_steps"])
        groups = list(runs.groupby(["method", "budget_steps"], sort=False))
        for x, ((method, _), group) in enumerate(groups):
            row[1].errorbar(np.full(len(group), x) + np.linspace(-0.2, 0.2, len(group)),
                            group["test_fitness"],
                            yerr=[group["test_fitness"] - group["test_fitness_low"],
                                  group["test_fitness_high"] - group["test_fitness"]],
                            fmt="o", color=METHOD_COLOURS.get(method, "gray"), capsize=2,
                            alpha=0.6)
            mean = group["test_fitness"].mean()
            low, high = t_interval(group["test_fitness"].to_numpy())
            low = max(low, 0.0)  # no fitness is below 0 (the tables cut alike)
            row[1].errorbar([x + 0.3], [mean], yerr=[[mean - low], [high - mean]], fmt="D",
                            color="black", capsize=3)
        row[1].set_xticks(range(len(groups)),
                          [f"{m}\n{b / 1e6:g} M" for (m, b), _ in groups])
        row[1].set_ylim(bottom=0)
        row[1].set_ylabel("test fitness (steps lived)")
        row[1].set_title("each run: 90% interval over its test situations; black: the "
                         "seeds' mean, 90% t interval", fontsize=8)
    save_figure(figure, path)


def crowd_paths_figure(paths: dict, path: Path, seconds: float) -> None:
    """Each strategy of the arena's crowds: the first ``seconds`` of its initial drivers, the
    broadcast winner and the vehicles after simultaneous learning."""
    figure, axes = plt.subplots(3, 4, figsize=(16, 12))
    steps = round(seconds * 10)
    titles = ["initial drivers", "winning chromosome (Table 3)", "after learning (Table 4)"]
    for column, (strategy, traces) in enumerate(sorted(paths.items())):
        walls = traces[-1]
        for row, trace in enumerate(traces[:3]):
            ax = axes[row, column]
            draw_paths(ax, walls, [trace[:steps, v] for v in range(trace.shape[1])],
                       colors=[f"C{v}" for v in range(trace.shape[1])])
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"strategy {strategy}: {titles[row]}", fontsize=9)
    figure.suptitle(f"All 8 vehicles, first {seconds:g} s of simulated time "
                    "(after learning: the first seconds after it)")
    figure.tight_layout()
    save_figure(figure, path)


def crowd_learning_figure(curve: pd.DataFrame, situations: pd.DataFrame, path: Path,
                          seconds: float, title: str,
                          unit: str = "collisions per vehicle-second") -> None:
    """Per strategy: collisions per vehicle-second in each span while the vehicles learn,
    beside the initial drivers and the winner over the same spans, and each arm over the
    span after learning (the markers at its end: Table 4)."""
    strategies = sorted(curve["strategy"].unique())
    width = max(6, 4 * len(strategies))  # one panel (a user's crowd) holds its labels
    figure, axes = plt.subplots(1, len(strategies), figsize=(width, 3.8), sharey=True,
                                squeeze=False)
    arms = [("collisions_per_vehicle_s", "learning together", "C3", "population"),
            ("initial_drivers", "initial drivers", "C0", "initial_after"),
            ("winner_driving_on", "winner driving on", "C2", "winner_after")]
    for ax, strategy in zip(axes[0], strategies, strict=True):
        rows = curve[curve["strategy"] == strategy]
        after = situations[situations["strategy"] == strategy]
        for column, label, color, arm in arms:
            ax.plot(rows["window_start_s"] / 60, rows[column], color=color, label=label,
                    linewidth=1)
            ax.plot([seconds / 60], [after[arm].mean()], "o", color=color)
        if len(strategies) > 1:
            ax.set_title(f"strategy {strategy}", fontsize=10)
        ax.set_xlabel("simulated minutes (dots: the span after learning)")
    axes[0, 0].set_ylabel(unit)
    axes[0, 0].legend(fontsize=8)
    figure.suptitle("\n".join(textwrap.wrap(f"Learning while driving (paper §5.5.2): {title}",
                                           round(width * 11))), fontsize=10)
    figure.tight_layout()
    save_figure(figure, path)
