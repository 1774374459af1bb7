"""``enn-traffic bench``: throughput and timing of the workloads, each measured A/B in one run
(absolute times on a shared machine drift; docs/bench.md).

A workload is a function ``(quick) -> DataFrame`` in the module of its area —
:mod:`~enn_traffic.bench.kernels` (the compiled step, the environments),
:mod:`~enn_traffic.bench.sumo` (SUMO), :mod:`~enn_traffic.bench.roads` (networks) and
:mod:`~enn_traffic.bench.commands` (whole commands) — named in :data:`WORKLOADS`, whose names
``bench --only`` takes and ``--help`` lists without importing the workloads.
"""

from __future__ import annotations

from enn_traffic.core.registry import Registry

# Every workload by the name ``bench --only`` takes, in the order the table shows them.
WORKLOADS = Registry("workload", {
    "first_run": "enn_traffic.bench.commands:first_run",
    "contention": "enn_traffic.bench.kernels:contention",
    "fresh": "enn_traffic.bench.sumo:fresh_process",
    "network": "enn_traffic.bench.roads:network",
    "sumo_step": "enn_traffic.bench.sumo:sumo_step",
    "navigation": "enn_traffic.bench.kernels:navigation",
    "arena": "enn_traffic.bench.kernels:arena",
    "env": "enn_traffic.bench.kernels:env",
    "sb3": "enn_traffic.bench.kernels:sb3",
    "sumo": "enn_traffic.bench.sumo:sumo",
    "recording": "enn_traffic.bench.sumo:recording",
    "crowd_scale": "enn_traffic.bench.sumo:crowd_scale",
    "crowd_marginal": "enn_traffic.bench.marginal:crowd_marginal",
    "city": "enn_traffic.bench.sumo:city",
    "lane_keeping": "enn_traffic.bench.kernels:lane_keeping",
    "crowd_ray": "enn_traffic.bench.sumo:crowd_ray",
    "reproduce_quick": "enn_traffic.bench.commands:reproduce_quick",
    "bench_quick": "enn_traffic.bench.commands:bench_quick",
    "test_suite": "enn_traffic.bench.commands:test_suite",
})
# Workloads that take minutes whatever the settings (a compile from an empty cache, a whole
# reproduction): ``bench --quick`` runs them only when ``--only`` names them.
LONG = ("first_run", "crowd_marginal", "crowd_ray", "reproduce_quick", "bench_quick", "test_suite")
# Workloads that need the project's git checkout, not only the package: run only when named.
CHECKOUT = {"test_suite": "the README's pytest in a clone of the git checkout, cold and warm"}


def workloads() -> list[str]:
    """The workloads' names, in the order the table shows them."""
    return list(WORKLOADS)


def chosen_workloads(quick: bool = False, only: list[str] | None = None) -> list[str]:
    """The workloads ``only`` names, or every one but the :data:`CHECKOUT` ones (with
    ``quick``, but the :data:`LONG` ones too), in the order the table shows them."""
    if only:
        return [name for name in WORKLOADS if name in only]
    return [name for name in WORKLOADS
            if not (quick and name in LONG) and name not in CHECKOUT]


def table_text(table) -> str:
    """The bench table as ``enn-traffic bench`` prints it: one block per kind of workload (the
    name before its colon) with only the columns it fills, every number formatted."""
    import numpy as np

    shown = table.drop(columns=["learner_steps"], errors="ignore")
    shapes = {"vehicle_steps_per_s": "{:,.0f}", "learner_steps_per_s": "{:,.0f}",
              "speedup_vs_reference": "{:.2f}x", "vs_one_thread": "{:.2f}x",
              "steps_per_s_min": "{:,.0f}", "steps_per_s_max": "{:,.0f}", "runs": "{:.0f}",
              "seconds": "{:.2f}", "seconds_min": "{:.2f}", "seconds_max": "{:.2f}",
              "peak_memory_mb": "{:,.0f}", "vehicle_steps": "{:,.0f}", "steps": "{:,.0f}",
              "calls": "{:.0f}", "rows": "{:.0f}", "ms_per_step": "{:.2f}",
              "ms_per_step_min": "{:.2f}", "ms_per_step_max": "{:.2f}",
              "sumo_ms_per_step": "{:.2f}",
              "slowdown_vs_no_learner": "{:.2f}x", "warmup_share": "{:.1%}"}
    for column, shape in shapes.items():
        if column in shown:
            shown[column] = shown[column].map(
                lambda v, f=shape: "" if isinstance(v, float) and np.isnan(v) else f.format(v))
    # one block per kind of workload (the name before its colon), with its own columns only
    kinds = shown["workload"].str.split(":").str[0]
    blocks = []
    for _, rows in shown.groupby(kinds, sort=False):
        filled = [column for column in rows
                  if not (rows[column].isna() | (rows[column] == "")).all()]
        blocks.append(rows[filled].to_string(index=False))
    return "\n\n".join(blocks)


def run_bench(quick: bool = False, only: list[str] | None = None):
    """The tables of every workload, or of the workloads ``only`` names, one after another."""
    import pandas as pd

    return pd.concat([WORKLOADS[name](quick) for name in chosen_workloads(quick, only)],
                     ignore_index=True)
