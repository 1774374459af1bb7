"""What a SUMO crowd cost (``crowd_cost.csv``): per situation and arm, the learner-steps it
drove and its wall and CPU time, in all and inside SUMO's step; and the summary's line of
it (:mod:`enn_traffic.experiments.crowds.sumo` writes the table, ``enn-traffic crowd`` the
line)."""

from __future__ import annotations

import pandas as pd

COST_COLUMNS = ["strategy", "situation", "arm", "situation_wall_s", "learner_steps", "wall_s",
                "sumo_s", "learner_steps_per_s", "sumo_share", "cpu_s", "sumo_cpu_s",
                "learner_steps_per_cpu_s", "sumo_cpu_share"]


def _cpu(spent: dict) -> dict:
    """An arm's CPU columns of ``crowd_cost.csv`` (NaN where it was measured without)."""
    if "cpu_s" not in spent:
        return dict.fromkeys(COST_COLUMNS[-4:], float("nan"))
    cpu = max(spent["cpu_s"], 1e-9)
    return {"cpu_s": round(spent["cpu_s"], 2), "sumo_cpu_s": round(spent["sumo_cpu_s"], 2),
            "learner_steps_per_cpu_s": round(spent["learner_steps"] / cpu, 1),
            "sumo_cpu_share": round(spent["sumo_cpu_s"] / cpu, 3)}


def cost_table(kept: dict) -> pd.DataFrame:
    """``crowd_cost.csv``: per situation and arm, the learner-steps it drove, its wall time and
    the share of it inside SUMO's step, the same in its process's CPU time (what the arm cost:
    the arms run side by side, and on fewer cores than arms a wall clock also counts the
    waits for one), and the situation's wall time. A situation kept from before costs were
    recorded has no rows; one kept from before CPU times were, no CPU figures."""
    rows = []
    for (strategy, situation), result in kept.items():
        cost = result.get("cost")
        for arm, spent in (cost or {}).get("arms", {}).items():
            wall = max(spent["wall_s"], 1e-9)
            rows.append({"strategy": strategy, "situation": situation, "arm": arm,
                         "situation_wall_s": round(cost["situation_wall_s"], 2),
                         "learner_steps": spent["learner_steps"],
                         "wall_s": round(spent["wall_s"], 2), "sumo_s": round(spent["sumo_s"], 2),
                         "learner_steps_per_s": round(spent["learner_steps"] / wall, 1),
                         "sumo_share": round(spent["sumo_s"] / wall, 3)} | _cpu(spent))
    return pd.DataFrame(rows, columns=COST_COLUMNS)


def cost_lines(cost) -> list[str]:
    """What the crowd cost (``crowd_cost.csv``): each arm's learner-steps per CPU-second and
    SUMO's share of that CPU time (its wall time where CPU times were not recorded), and the
    wall time per situation (its arms side by side)."""
    if cost.empty:
        return ["cost: not recorded (every situation was measured before costs were kept)"]
    cpu = cost["cpu_s"].notna().all() if "cpu_s" in cost else False
    spent, inside, unit = (("cpu_s", "sumo_cpu_s", "learner-steps per CPU-second") if cpu
                           else ("wall_s", "sumo_s", "learner-steps/s"))
    arms = cost.groupby("arm", sort=False)[["learner_steps", spent, inside]].sum()
    per_arm = "; ".join(f"{arm} {row.learner_steps / max(row[spent], 1e-9):,.0f} {unit}, "
                        f"SUMO {row[inside] / max(row[spent], 1e-9):.0%} of it"
                        for arm, row in arms.iterrows())
    situations = cost.drop_duplicates(["strategy", "situation"])["situation_wall_s"]
    return [f"cost (crowd_cost.csv): {per_arm}; {situations.mean():.1f} s per situation "
            f"({len(situations)} measured here)"]
