"""Which SUMO traffic a situation meets: its SUMO seed and the shared warm-up it loads, from
the scenario and the traffic key alone (docs/sumo.md). No SUMO here: the generations table and
the reports read these without starting one."""

from __future__ import annotations

import numpy as np

from enn_traffic.config import Scenario
from enn_traffic.core import keys

WARMUP_STREAM = 7  # the key of the shared warm-ups' seeds (traffic.warmup_states)


def situation_seed(scenario: Scenario, key: int, index: int) -> int:
    """The SUMO seed of situation ``index`` of traffic key ``key`` (as the world draws it:
    after ``traffic.vary``)."""
    sequence = np.random.SeedSequence([scenario.traffic.seed, key, 0, index])
    return int(sequence.generate_state(1)[0] % 2**31)


def shared_warmup(scenario: Scenario, key: int, index: int) -> int | None:
    """Which of the ``traffic.warmup_states`` shared warm-ups situation ``index`` of traffic
    key ``key`` loads (None: none are shared). A training generation's situations take them in
    turn, (generation × episodes + index) mod N, so that consecutive generations meet every
    warm-up equally often; a held-out situation, one of a sample, draws one by its seed."""
    shared = scenario.traffic.warmup_states
    if not shared:
        return None
    if keys.is_training(key):
        return (key * scenario.traffic.episodes + index) % shared
    return situation_seed(scenario, key, index) % shared


def warmups_used(scenario: Scenario, key: int) -> str:
    """The shared warm-ups the situations of a training ``key`` load, in order (``"0 1"``), a
    track's after another's (``"0 1; 2 3"``); empty without shared warm-ups."""
    parts = ([scenario.on_track(i) for i in range(len(scenario.tracks))]
             if isinstance(scenario.track, list) else [scenario])
    used = []
    for part in parts:
        traffic_key = 0 if part.traffic.vary == "fixed" and keys.is_training(key) else key
        indices = [shared_warmup(part, traffic_key, e) for e in range(part.traffic.episodes)]
        if part.traffic.is_sumo and part.traffic.warmup_states:
            used.append(" ".join(str(i) for i in indices))
    return "; ".join(used)


def first_alike(starts: list[np.ndarray], warmups: list[int | None]) -> list[int]:
    """For each situation (its learner start and shared warm-up), the first one that starts
    from the same state: the same shared warm-up (loaded without SUMO's random generators, so
    only the randomness SUMO draws after it can tell them apart) and the same start; itself
    where it is the first, or starts from a warm-up of its own (None)."""
    first: dict[tuple, int] = {}
    return [index if warmup is None
            else first.setdefault((warmup, *np.round(start, 6).tolist()), index)
            for index, (start, warmup) in enumerate(zip(starts, warmups, strict=True))]
