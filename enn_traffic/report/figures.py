"""The dynamic-traffic experiments' figures (paper Fig. 11, Fig. 12, Table 1 as paths): drawing
only; the experiments compute what is drawn."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from enn_traffic.report.plots import draw_paths, learning_curves, save_figure


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
