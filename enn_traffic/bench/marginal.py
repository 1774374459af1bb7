"""What a learner costs beside what a SUMO-driven vehicle costs, in one warmed-up city SUMO: the
crowd's step (SUMO's step, placing the learners, reading SUMO's vehicles, blame and sensing,
re-entries) with one learner, then with N SUMO-driven vehicles added, then with N learners
added; each arm in a fresh process, the marginal cost of an added vehicle per step inside
SUMO's step and outside it."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd

from enn_traffic.bench.measure import city_with_lights
from enn_traffic.sumo.timing import AddedTraffic, trip_ends

SETTLE_STEPS = 100  # steps between adding vehicles and timing (the added ones depart)
# Where a step's time outside SUMO's step goes: placing the learners in SUMO (one moveToXY
# each), reading SUMO's vehicles, the two compiled calls (blame; sensing and driving), and the
# re-entries of the learners whose lives ended.
PARTS = ("move", "read", "kernels", "reenter")


def marginal_seconds(net: Path, trips: Path, added_vehicles: int, learners: int,
                     steps: int, ssm: bool = True) -> dict:
    """``learners`` learners in one SUMO of the city ``net`` (its ``trips``; closed loop,
    after 300 s of warm-up), with ``added_vehicles`` SUMO-driven vehicles added on trips of
    its own demand; ``steps`` steps timed after :data:`SETTLE_STEPS`, each learner driving a
    random network of its own, with an SSM device unless not ``ssm``. The seconds, those
    inside SUMO's step, the vehicles SUMO drove (its own and the added), the added ones
    driving, the learners' re-entries, the seconds of each of :data:`PARTS`, and the peak
    resident memory. Run in a fresh process."""
    import resource

    from enn_traffic.config import load_scenario
    from enn_traffic.sim.sumo import crowd as sumo_crowd
    from enn_traffic.sim.world import make_world

    spent = dict.fromkeys(PARTS, 0.0)
    if not ssm:
        sumo_crowd.ssm.ssm_options = lambda learners=(): ()

    def timed(call, part):
        def wrapped(*args):
            started = time.perf_counter()
            result = call(*args)
            spent[part] += time.perf_counter() - started
            return result
        return wrapped

    with tempfile.TemporaryDirectory(prefix="enn-bench-marginal-") as folder:
        path = Path(folder) / "city.toml"
        path.write_text(f'name = "city"\n[track]\nnet = "{net}"\nstart_lane = "auto"\n'
                        f'[traffic]\nstrategy = "sumo"\nroutes = ["{trips}"]\n'
                        f'mode = "closed-loop"\nwarmup_s = 300.0\nwarmup_states = 1\n'
                        f"learners = {learners}\n")
        scenario = load_scenario(path)
        world = make_world(scenario)
        dt = scenario.vehicle.dt
        genes = world.spec.in_source_layout(np.random.default_rng(learners).uniform(
            -1, 1, (learners, world.spec.chromosome_length)))
        added = AddedTraffic(trip_ends(trips, scenario.traffic.warmup_s, 4 * added_vehicles + 1))
        with sumo_crowd.SumoCrowd(world, world.seeds(1)[0]) as crowd:
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
    added vehicle and step, inside SUMO's step and outside it; N = 300 and 3,000 (30 and 300
    with ``quick``)."""
    from enn_traffic.sumo.fresh import fresh_calls

    net, trips = city_with_lights(150 if quick else 1500, 0.5)
    counts = (30, 300) if quick else (300, 3000)
    steps = 50 if quick else 300
    # the last arm: the most learners without their SSM devices (what the devices cost)
    arms = ([(0, 1, True)] + [(n, 1, True) for n in counts] + [(0, n, True) for n in counts]
            + [(0, counts[-1], False)])
    measured = fresh_calls([(marginal_seconds, net, trips, v, k, steps, ssm)
                            for v, k, ssm in arms])
    base = measured[0]
    rows = []
    for (vehicles, learners, ssm), m in zip(arms, measured, strict=True):
        added = m["added_driving"] if vehicles else learners - 1
        outside, base_outside = (m["seconds"] - m["sumo_seconds"],
                                 base["seconds"] - base["sumo_seconds"])
        per = 1e6 / (added * steps) if added else np.nan
        rows.append({
            "workload": f"marginal cost: random city with actuated lights, "
                        f"{base['vehicles']:,} SUMO vehicles",
            "implementation": (f"1 learner, +{vehicles:,} SUMO-driven vehicles" if vehicles
                               else f"{learners:,} learner{'s' * (learners > 1)}"
                               + ("" if ssm else ", no SSM devices")),
            "threads": numba.get_num_threads(), "steps": steps, "seconds": m["seconds"],
            "added_driving": added, "ms_per_step": 1000 * m["seconds"] / steps,
            "sumo_ms_per_step": 1000 * m["sumo_seconds"] / steps,
            "us_per_added_step": (m["seconds"] - base["seconds"]) * per,
            "sumo_us_per_added_step": (m["sumo_seconds"] - base["sumo_seconds"]) * per,
            "outside_us_per_added_step": (outside - base_outside) * per,
            **{f"{part}_us_per_added_step": (m[f"{part}_seconds"] - base[f"{part}_seconds"])
               * per for part in PARTS},
            "entries_per_learner_step": m["entries"] / (learners * steps),
            "peak_memory_mb": m["peak_mb"]})
    return pd.DataFrame(rows)
