"""What a learner costs beside what a SUMO-driven vehicle costs, in one warmed-up city SUMO: the
crowd's step (SUMO's step, placing the learners, reading SUMO's vehicles, blame and sensing,
re-entries) with one learner, then with N SUMO-driven vehicles added, then with N learners
added; each arm in a fresh process, the arms interleaved over rounds; the marginal cost of an
added vehicle per step in SUMO's ``simulationStep`` call and outside it, as medians over the
rounds with their range."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd

from enn_traffic.bench.measure import city_crowd, city_with_lights, timing_into
from enn_traffic.core.provenance import PACKAGE
from enn_traffic.sumo.timing import AddedTraffic, trip_ends

SETTLE_STEPS = 100  # steps between adding vehicles and timing (the added ones depart)
# Where a step's time outside SUMO's step goes: placing the learners in SUMO (one moveToXY
# each), reading SUMO's vehicles, the two compiled calls (blame; sensing and driving), and the
# re-entries of the learners whose lives ended.
PARTS = ("move", "read", "kernels", "reenter")
# A trained controller for the learners of an arm (random networks end a life every few
# steps; a trained one drives on): the city's Table 1 winner of strategy 1.
# (The checkout's committed results, as bench test_suite reads the checkout.)
TRAINED = PACKAGE.parent / "results" / "paper" / "controllers" / "city" / "table1" / "strategy1.npz"


def marginal_seconds(net: Path, trips: Path, added_vehicles: int, learners: int,
                     steps: int, ssm: bool = True, controller: Path | None = None) -> dict:
    """``learners`` learners in one SUMO of the city ``net`` (its ``trips``; closed loop,
    after 300 s of warm-up), with ``added_vehicles`` SUMO-driven vehicles added on trips of
    its own demand; ``steps`` steps timed after :data:`SETTLE_STEPS`, each learner driving a
    random network of its own (or every one the saved ``controller``), with an SSM device
    unless not ``ssm``. The seconds, those
    inside SUMO's step, the vehicles SUMO drove (its own and the added), the added ones
    driving, the learners' re-entries, the seconds of each of :data:`PARTS`, and the peak
    resident memory. Run in a fresh process."""
    import resource

    from enn_traffic.sim.sumo import crowd as sumo_crowd

    spent = dict.fromkeys(PARTS, 0.0)
    timed = timing_into(spent)
    with tempfile.TemporaryDirectory(prefix="enn-bench-marginal-") as folder:
        scenario, world = city_crowd(Path(folder), net, trips, learners)
        dt = scenario.vehicle.dt
        if controller is None:
            genes = world.spec.in_source_layout(np.random.default_rng(learners).uniform(
                -1, 1, (learners, world.spec.chromosome_length)))
        else:
            from enn_traffic.runs.controller import Controller

            chromosome = Controller.load(controller).chromosome
            genes = np.tile(world.spec.in_source_layout(chromosome)[0], (learners, 1))
        added = AddedTraffic(trip_ends(trips, scenario.traffic.warmup_s, 4 * added_vehicles + 1))
        with sumo_crowd.SumoCrowd(world, world.seeds(1)[0], ssm_devices=ssm) as crowd:
            crowd.run(dt, genes)  # start SUMO, let the learners enter
            added.add(added_vehicles)
            read, present = timed(crowd._read, "read"), []

            def read_after_step():  # the crowd reads SUMO's vehicles after each step
                added.after_step()
                present.append(len(added.driving))
                read()

            crowd._read = read_after_step
            crowd._move_learners = timed(crowd._move_learners, "move")
            crowd.reenter = timed(crowd.reenter, "reenter")
            kernels = sumo_crowd.learner_events, sumo_crowd.drive
            sumo_crowd.learner_events = timed(kernels[0], "kernels")
            sumo_crowd.drive = timed(kernels[1], "kernels")
            crowd.run(SETTLE_STEPS * dt, genes)
            present.clear()
            spent.update(dict.fromkeys(PARTS, 0.0))
            added.spent, sumo_before, started = 0.0, crowd.cost["sumo_s"], time.perf_counter()
            try:
                run = crowd.run(steps * dt, genes)
            finally:
                sumo_crowd.learner_events, sumo_crowd.drive = kernels
            seconds = time.perf_counter() - started - added.spent
            sumo_seconds = crowd.cost["sumo_s"] - sumo_before
            entries = int(run.collisions.sum() + run.spins.sum() + run.exits.sum())
            vehicles = crowd.simulation.vehicle_count() - learners
    return {"seconds": seconds, "sumo_seconds": sumo_seconds, "vehicles": vehicles,
            "added_driving": float(np.mean(present)), "entries": entries,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            **{f"{part}_seconds": spent[part] for part in PARTS}}


def crowd_marginal(quick: bool = False) -> pd.DataFrame:
    """The marginal cost of a SUMO-driven vehicle and of a learner, N of each added to the
    same warmed-up city (the random city with actuated lights of the SUMO step rows), per
    added vehicle and step, in SUMO's ``simulationStep`` call and outside it; N = 300 and
    3,000 (30 and 300 with ``quick``), the learners driving random networks, and at the
    larger N without their SSM devices and driving a trained controller. Each arm in a fresh
    process, the arms interleaved over 3 rounds (1 with ``quick``); per arm the median of each
    figure, with the range of the marginal cost."""
    from enn_traffic.sumo.fresh import fresh_calls

    net, trips = city_with_lights(150 if quick else 1500, 0.5)
    counts = (30, 300) if quick else (300, 3000)
    steps, rounds = (50, 1) if quick else (300, 3)
    arms = ([(0, 1, True, None)] + [(n, 1, True, None) for n in counts]
            + [(0, n, True, None) for n in counts] + [(0, counts[-1], False, None),
                                                    (0, counts[-1], True, TRAINED)])
    calls = [(marginal_seconds, net, trips, v, k, steps, ssm, controller)
             for _ in range(rounds) for v, k, ssm, controller in arms]
    measured = fresh_calls(calls)
    runs = [measured[a::len(arms)] for a in range(len(arms))]  # per arm, its rounds

    def marginal(m: dict, base: dict, vehicles: int, learners: int) -> dict:
        added = m["added_driving"] if vehicles else learners - 1
        per = 1e6 / (added * steps) if added else np.nan
        figures = {"added_driving": added,
                   "us_per_added_step": (m["seconds"] - base["seconds"]) * per,
                   "sumo_us_per_added_step": (m["sumo_seconds"] - base["sumo_seconds"]) * per}
        figures["outside_us_per_added_step"] = (figures["us_per_added_step"]
                                                - figures["sumo_us_per_added_step"])
        figures.update({f"{part}_us_per_added_step": (m[f"{part}_seconds"]
                                                      - base[f"{part}_seconds"]) * per
                        for part in PARTS})
        return figures

    rows = []
    for (vehicles, learners, ssm, controller), arm in zip(arms, runs, strict=True):
        each = [marginal(m, base, vehicles, learners) for m, base in zip(arm, runs[0],
                                                                        strict=True)]
        totals = [e["us_per_added_step"] for e in each]
        name = (f"1 learner, +{vehicles:,} SUMO-driven vehicles" if vehicles
                else f"{learners:,} learner{'s' * (learners > 1)}")
        name += ("" if ssm else ", no SSM devices") + (", a trained controller" if controller
                                                       else "")
        median = {key: float(np.median([m[key] for m in arm])) for key in arm[0]}
        rows.append({
            "workload": f"marginal cost: random city with actuated lights, "
                        f"{int(median['vehicles']):,} SUMO vehicles at the end",
            "implementation": name, "threads": numba.get_num_threads(), "steps": steps,
            "runs": rounds, "seconds": median["seconds"],
            "ms_per_step": 1000 * median["seconds"] / steps,
            "sumo_ms_per_step": 1000 * median["sumo_seconds"] / steps,
            **{key: float(np.median([e[key] for e in each])) for key in each[0]},
            "us_per_added_step_min": float(np.min(totals)),
            "us_per_added_step_max": float(np.max(totals)),
            "entries_per_learner_step": (median["entries"] / (learners * steps) if not vehicles
                                         else np.nan),
            "peak_memory_mb": median["peak_mb"]})
    return pd.DataFrame(rows)
