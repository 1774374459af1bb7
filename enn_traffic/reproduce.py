"""``enn-traffic reproduce``: every experiment of the paper into one folder, with summary.md."""

from __future__ import annotations

import time
from pathlib import Path

from enn_traffic.errors import InputError
from enn_traffic.io import write_text


def reproduce(out: Path, quick: bool = False, only: list[str] | None = None,
              progress: bool = True) -> list[str]:
    from enn_traffic.experiments import EXPERIMENTS

    names = only or list(EXPERIMENTS)
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        raise InputError(f"unknown experiment(s) {', '.join(unknown)}; choose from "
                         f"{', '.join(EXPERIMENTS)}", key="--only")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    lines, timings = [], []
    for name in names:
        started = time.perf_counter()
        lines += EXPERIMENTS[name](out, quick=quick, progress=progress)
        timings.append((name, time.perf_counter() - started))
        print(lines[-1], flush=True)
    summary = ["# enn-traffic: reproduction of Eraqi et al. (2016)", "",
               f"Settings: {'--quick' if quick else 'full'}; experiments: {', '.join(names)}.", ""]
    summary += [f"- {line}" for line in lines]
    summary += ["", "| experiment | wall time [s] |", "|---|---|"]
    summary += [f"| {name} | {seconds:.1f} |" for name, seconds in timings]
    write_text(out / "summary.md", "\n".join(summary) + "\n")
    for name, seconds in timings:
        print(f"{name:>16}: {seconds:7.1f} s")
    return lines
