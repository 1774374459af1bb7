"""Table 4's ablation among SUMO traffic (docs/results.md, "Table 4 as an ablation", "Among
SUMO traffic"): the arena ablation's deciding choice, the start population, on one strategy of
the SUMO family, from the controllers its Tables 3–4 saved."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from enn_traffic.core import keys
from enn_traffic.core.errors import InputError
from enn_traffic.core.io import write_csv
from enn_traffic.core.progress import terminal
from enn_traffic.experiments.ablation import EARLY_SPANS, FINISH_STEPS, ablation_table
from enn_traffic.experiments.crowds.settings import CrowdSettings
from enn_traffic.experiments.crowds.sumo import (
    SUMO_LEARNING,
    saved_crowd_inputs,
    situation_result,
)
from enn_traffic.experiments.families import SUMO, Family
from enn_traffic.experiments.study import Study

# One SUMO strategy: ours against the arm whose choice carries the arena's pattern (the
# start population, table4_ablation_factors.csv), on keys of its own in the ablation range.
SUMO_STRATEGY = 1
SUMO_ARMS = (("evolved", "cap"), ("random", "cap"))
SUMO_KEY = keys.ABLATION_SUMO.start


def sumo_situations(out: Path, family: Family, learning: CrowdSettings,
                    strategy: int = SUMO_STRATEGY, progress: bool = False) -> pd.DataFrame:
    """``SUMO_ARMS`` among the SUMO traffic of ``family``'s ``strategy``, from the winner
    and evolved population saved under ``out/controllers``: a row per situation and arm, the
    columns of ``table4_ablation_situations.csv``."""
    world, winner, evolved = saved_crowd_inputs(out, family)[strategy]
    stopping = {"cap": {"life_cap_steps": learning.life_cap_steps, "finish_steps": 0},
                "finish": {"life_cap_steps": 0, "finish_steps": FINISH_STEPS}}
    rows = []
    for situation in tqdm(range(learning.situations), desc=f"{family.folder} ablation",
                          unit="situation", disable=not progress, file=terminal()):
        for start, stop in SUMO_ARMS:
            arm = replace(learning, start_population=start, **stopping[stop])
            result = situation_result(world, winner, evolved, situation, arm, SUMO_KEY)
            learners = pd.DataFrame(result.learners)
            rows.append({"strategy": strategy, "situation": situation,
                         "start_population": start, "stopping": stop,
                         "first_span": result.windows[0]["learning"],
                         "early_spans": float(np.mean([w["learning"] for w in
                                                       result.windows[EARLY_SPANS]])),
                         "after": result.rates["population"], "after_spins": float("nan"),
                         "learning_s": learning.learning_s,
                         "initial_first": result.rates["initial"],
                         "initial_after": result.rates["initial_after"],
                         "winner_first": result.rates["winner"],
                         "winner_after": result.rates["winner_after"],
                         "generations_bred": float(learners["generations_bred"].median()),
                         "finished_share": float(learners.get("finished",
                                                              pd.Series([0])).mean())})
    return pd.DataFrame(rows)


def table4_ablation_sumo(study: Study) -> list[str]:
    """The arena ablation's deciding choice on one strategy of the SUMO family, from the
    controllers its Tables 3–4 saved: ``sumo/table4_ablation.csv`` and its situations."""
    family = study.settings(SUMO)
    try:
        situations = sumo_situations(study.out, family, study.settings(SUMO_LEARNING),
                                     progress=study.progress)
    except FileNotFoundError as error:
        raise InputError(f"{error.filename} is missing: the SUMO ablation starts from the "
                         "controllers the SUMO family saved (run sumo first)",
                         key="--only") from error
    folder = study.out / family.folder
    write_csv(folder / "table4_ablation_situations.csv", situations.round(5))
    write_csv(folder / "table4_ablation.csv", ablation_table(situations))
    return table4_ablation_sumo_lines(study)


def table4_ablation_sumo_lines(study: Study) -> list[str]:
    """The SUMO ablation's summary line, from the table the study wrote."""
    table = pd.read_csv(study.out / study.settings(SUMO).folder / "table4_ablation.csv")
    words = []
    for row in table.to_dict("records"):
        words.append(f"start {row['start_population']}, {row['stopping']}: "
                     f"{row['first_span']:.3f} -> {row['after']:.3f}, against the winner "
                     f"{_interval_words(row, 'after_minus_winner_after')}")
    return [f"sumo/table4_ablation (strategy {SUMO_STRATEGY}, collisions per learner-second, "
            "first window -> window after learning): " + "; ".join(words)]


def _interval_words(row: dict, name: str) -> str:
    word = ("above" if row[f"{name}_low"] > 0 else "below" if row[f"{name}_high"] < 0
            else "not apart")
    return (f"{word} ({row[name]:+.4f}, {row[f'{name}_low']:+.4f} to "
            f"{row[f'{name}_high']:+.4f})")
