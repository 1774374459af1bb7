"""Sections of docs/bench.md written from the committed bench tables in ``results/bench``
rather than typed (:mod:`enn_traffic.report.generated`), as docs/results.md's are.

``python -m enn_traffic.report.bench_doc`` rewrites each section between its markers
(``<!-- generated: NAME -->`` … ``<!-- end generated: NAME -->``); a test checks that the
committed docs/bench.md holds what the committed tables give.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from enn_traffic.report import generated


def sumo_step(folder: Path) -> str:
    """SUMO's step time with and without learners (issue 60), from ``sumo_step_issue60.csv``
    (:func:`enn_traffic.bench.sumo_step_table`)."""
    table = pd.read_csv(folder / "sumo_step_issue60.csv")
    lines = ["| network | learners in SUMO | runs × steps timed | ms per SUMO step, median "
             "(fastest–slowest run) | × without a learner (medians) |",
             "|---|---|---:|---:|---:|"]
    for row in table.itertuples():
        lines.append(f"| {row.workload.removeprefix('SUMO step: ')} | {row.implementation} | "
                     f"{row.runs} × {row.steps:,} | {row.ms_per_step:.2f} "
                     f"({row.ms_per_step_min:.2f}–{row.ms_per_step_max:.2f}) | "
                     f"{row.slowdown_vs_no_learner:.2f} |")
    return "\n".join(lines)


def published(folder: Path) -> str:
    """A published city through the docs' template, from ``published_issue60.csv``
    (:func:`enn_traffic.bench.published_check`)."""
    table = pd.read_csv(folder / "published_issue60.csv")
    lines = ["| scenario | command | wall time | exit status | what it gave | its folder |",
             "|---|---|---:|---:|---|---|"]
    for row in table.itertuples():
        lines.append(f"| {row.scenario} | {row.command} | {row.seconds:.1f} s | "
                     f"{row.exit_status} | {row.detail} | "
                     f"{'unchanged' if row.folder_unchanged else 'CHANGED'} |")
    return "\n".join(lines)


def contention(folder: Path) -> str:
    """The compiled kernels beside busy processes under each OpenMP wait policy (issue 62),
    from ``contention_issue62.csv`` (:func:`enn_traffic.bench.contention_bench`)."""
    table = pd.read_csv(folder / "contention_issue62.csv")
    lines = ["| workload | OpenMP wait policy | threads | steps/s, median (slowest–fastest "
             "round) | × one thread |", "|---|---|---:|---:|---:|"]
    for row in table.itertuples():
        lines.append(f"| {row.workload.removeprefix('contention: ')} | {row.implementation} | "
                     f"{row.threads} | {row.vehicle_steps_per_s:,.0f} "
                     f"({row.steps_per_s_min:,.0f}–{row.steps_per_s_max:,.0f}) | "
                     f"{row.vs_one_thread:.2f} |")
    policies = list(dict.fromkeys(table["implementation"]))
    several = table[table["threads"] > 1].set_index(["workload", "implementation"])

    def rate(workload: str, policy: str) -> float:
        return several.loc[(workload, policy), "vehicle_steps_per_s"]

    ratios = [f"{workload.removeprefix('contention: ')}: "
              f"{rate(workload, policies[1]) / rate(workload, policies[0]):.2f}"
              for workload in dict.fromkeys(several.index.get_level_values(0))]
    lines += ["", f"Sleeping idle threads against spinning ones, the default threads' medians "
              f"({several['threads'].iloc[0]}): " + "; ".join(ratios) + "."]
    return "\n".join(lines)


def first_run(folder: Path) -> str:
    """The README's main command timed as a whole, from an empty cache and again, from
    ``first_run_issue62.csv`` (:func:`enn_traffic.bench.first_run_bench`)."""
    table = pd.read_csv(folder / "first_run_issue62.csv")
    lines = ["| command | cache | wall time |", "|---|---|---:|"]
    for row in table.itertuples():
        lines.append(f"| {row.workload.removeprefix('first contact: ')} | "
                     f"{row.implementation} | {row.seconds:.1f} s |")
    return "\n".join(lines)


def fresh(folder: Path) -> str:
    """A fresh process forked from the zygote against a new interpreter (issue 62), from
    ``fresh_issue62.csv`` (:func:`enn_traffic.bench.fresh_bench`)."""
    table = pd.read_csv(folder / "fresh_issue62.csv")
    lines = ["| what | how the process starts | calls | seconds per call, median "
             "(fastest–slowest) |", "|---|---|---:|---:|"]
    for row in table.itertuples():
        lines.append(f"| {row.workload.removeprefix('fresh process: ')} | {row.implementation} "
                     f"| {row.calls} | {row.seconds:.2f} ({row.seconds_min:.2f}–"
                     f"{row.seconds_max:.2f}) |")
    arm = table.iloc[0]
    lines += ["", f"An arm in a forked process takes {1 / arm.speedup_vs_reference:.2f} of the "
              f"time it took in a new interpreter ({arm.speedup_vs_reference:.1f}× faster)."]
    return "\n".join(lines)


def reproduce_quick(folder: Path) -> str:
    """``reproduce --quick`` timed as a whole and by experiment (issue 62), from
    ``reproduce_quick_issue62.csv`` (:func:`enn_traffic.bench.reproduce_quick_bench`)."""
    table = pd.read_csv(folder / "reproduce_quick_issue62.csv")
    parts = table[table["implementation"] != "the whole command"]
    whole = table[table["implementation"] == "the whole command"]["seconds"].iloc[0]
    lines = ["| experiment | wall time |", "|---|---:|"]
    lines += [f"| {row.implementation} | {row.seconds:.1f} s |" for row in parts.itertuples()]
    lines += [f"| **the whole command** (imports and summary included) | **{whole:.0f} s** |"]
    return "\n".join(lines)


def bench_quick(folder: Path) -> str:
    """``bench --quick`` timed as a whole command (issue 62), from ``bench_quick_issue62.csv``
    (:func:`enn_traffic.bench.bench_quick_bench`)."""
    row = pd.read_csv(folder / "bench_quick_issue62.csv").iloc[0]
    return "\n".join(["| command | rows | wall time |", "|---|---:|---:|",
                      f"| enn-traffic bench --quick | {row.rows} | {row.seconds:.0f} s |"])


def test_suite(folder: Path) -> str:
    """The README's ``pytest`` in a fresh clone, cold and warm (issue 62), from
    ``test_suite_issue62.csv`` (:func:`enn_traffic.bench.test_suite_bench`)."""
    table = pd.read_csv(folder / "test_suite_issue62.csv")
    lines = ["| command | caches | tests passed | wall time |", "|---|---|---:|---:|"]
    lines += [f"| pytest | {row.implementation} | {row.rows:,.0f} | {row.seconds:.0f} s "
              f"({row.seconds / 60:.1f} min) |" for row in table.itertuples()]
    return "\n".join(lines)


def crowd_scale(folder: Path) -> str:
    """Learners in one city SUMO (issue 63), from ``crowd_scale_issue63.csv``
    (:func:`enn_traffic.bench.crowd_scale_bench`)."""
    table = pd.read_csv(folder / "crowd_scale_issue63.csv")
    lines = [f"{table['workload'].iloc[0].split(': ', 1)[1]}, {table['steps'].iloc[0]} steps "
             "each:", "",
             "| learners | learner-steps/s | ms per step | of which SUMO's own step | "
             "the rest per learner | of which blame and sensing | peak memory |",
             "|---:|---:|---:|---:|---:|---:|---:|"]
    for row in table.itertuples():
        learners = int(row.learner_steps / row.steps)
        rest = (row.ms_per_step - row.sumo_ms_per_step) / learners
        lines.append(f"| {learners} | {row.learner_steps_per_s:,.0f} | {row.ms_per_step:.1f} | "
                     f"{row.sumo_ms_per_step:.1f} | {1000 * rest:.0f} µs | "
                     f"{row.kernel_us_per_learner_step:.1f} µs | {row.peak_memory_mb:,.0f} MB |")
    return "\n".join(lines)


def crowd_ray(folder: Path) -> str:
    """``crowd`` across SUMOs, one after another and on Ray (issue 63), from
    ``crowd_ray_issue63.csv`` (:func:`enn_traffic.bench.crowd_ray_bench`)."""
    table = pd.read_csv(folder / "crowd_ray_issue63.csv")
    lines = ["| workload | executor | wall time | tables |", "|---|---|---:|---|"]
    for row in table.itertuples():
        lines.append(f"| {row.workload.split(': ', 1)[1]} | {row.implementation} | "
                     f"{row.seconds:.0f} s | {'identical' if row.identical else 'DIFFER'} |")
    return "\n".join(lines)


SECTIONS: generated.Sections = {"sumo_step": sumo_step, "published": published,
                                "contention": contention, "first_run": first_run,
                                "fresh": fresh, "reproduce_quick": reproduce_quick,
                                "bench_quick": bench_quick, "test_suite": test_suite,
                                "crowd_scale": crowd_scale,
                                "crowd_ray": crowd_ray}


def section(name: str, folder: Path) -> str:
    """Section ``name`` with its markers, from the tables in ``folder``."""
    return generated.section(name, folder, SECTIONS)


def rewrite(doc: Path, folder: Path) -> None:
    """Replace every generated section of ``doc``."""
    generated.rewrite(doc, folder, SECTIONS)


if __name__ == "__main__":
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(".")
    rewrite(root / "docs" / "bench.md", root / "results" / "bench")
