"""Every range of traffic keys, named in one place (docs/design.md, "Traffic keys").

A world draws its traffic situations from (traffic seed, key, ...) alone, so a key range is a
set of situations. Training generations use their own numbers; every other use has a range of
its own, far past any training run, so that no choice is ever made on the traffic that measures
the result (the held-out discipline). A use takes the keys ``start``, ``start + 1``, ... of
its range.
"""

from __future__ import annotations

SPAN = 1_000_000_000

TRAINING = range(0, SPAN)  # generation g of a training run draws key g
VALIDATION = range(2 * SPAN, 3 * SPAN)  # choosing a controller among a run's candidates
ACCEPTANCE = range(3 * SPAN, 4 * SPAN)  # Table 2: a candidate's acceptance by its lower bound
CROWD_VALIDATION = range(4 * SPAN, 5 * SPAN)  # Tables 3–4: choosing the winning chromosome
# What is reported, sealed: read once, by the final configuration (docs/design.md, "Traffic
# keys"). `evaluate`, Tables 1–2, the figures; Tables 3–4's rates.
TEST = range(6 * SPAN, 7 * SPAN)
# Tables 3–4 and regime.csv, the arena's and the SUMO and city families': fresh for learning
# while driving (issue 48), as the range before it had been read twice by earlier designs of
# Table 4. A SUMO world's situations on it were never read before the SUMO crowds were
# measured by today's method.
CROWD_TEST = range(9 * SPAN, 10 * SPAN)
# Table 4's ablation (issue 61; enn_traffic.experiments.ablation): fresh and sealed. Its first
# design read + 0…19 once; a review of that reading changed the design, which reads the arena's
# situations from + 2·10⁶ (once); the SUMO strategy's from + 10⁶. The crowds' last departures
# from the authors' rules (enn_traffic.experiments.departures) read + 3·10⁶ … (once).
ABLATION_CROWD_TEST = range(10 * SPAN, 11 * SPAN)
# Read twice by Tables 3–4 (the arena's, then the SUMO and city families' pooled and per-learner
# Table 4): nothing reads it any more.
SPENT_CROWD_TEST = range(7 * SPAN, 8 * SPAN)
# Test ranges read while the design was still being chosen: never used again, for anything.
RETIRED_TEST = range(SPAN, 2 * SPAN)
RETIRED_CROWD_TEST = range(5 * SPAN, 6 * SPAN)
# Situations design trials were scored on (docs/results.md, "Why Table 2 evolves a wider
# network": key 8e9): no result is reported on them and no experiment reads them.
DESIGN_TRIALS = range(8 * SPAN, 9 * SPAN)

RANGES = {"training": TRAINING, "test": TEST, "validation": VALIDATION,
          "acceptance": ACCEPTANCE, "crowd validation": CROWD_VALIDATION,
          "crowd test": CROWD_TEST, "ablation crowd test": ABLATION_CROWD_TEST,
          "spent crowd test": SPENT_CROWD_TEST,
          "retired test": RETIRED_TEST,
          "retired crowd test": RETIRED_CROWD_TEST, "design trials": DESIGN_TRIALS}


def is_training(key: int) -> bool:
    """Is ``key`` a training generation's (not a held-out key)?"""
    return key in TRAINING
