"""Every traffic key a use reads, named in one place: the ledger (docs/design.md, "Traffic
keys").

A world draws its traffic situations from (traffic seed, key, ...) alone, so a set of keys is a
set of situations. Training generations use their own numbers; every other use reads keys of a
range of its own (:data:`RANGES`), far past any training run, so that no choice is ever made
on the traffic that measures the result (the held-out discipline). Within a range, each use
reads an allocation of its own (:data:`ALLOCATIONS`): ``start``, ``start + 1``, ... A test
checks that every allocation lies in its range, that no two share a key, and that no module
writes a key as an offset of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

SPAN = 1_000_000_000

TRAINING = range(0, SPAN)  # generation g of a training run draws key g
VALIDATION = range(2 * SPAN, 3 * SPAN)  # choosing a controller among a run's candidates
ACCEPTANCE = range(3 * SPAN, 4 * SPAN)  # Table 2: a candidate's acceptance by its lower bound
CROWD_VALIDATION = range(4 * SPAN, 5 * SPAN)  # Tables 3–4: choosing the winning chromosome
# What is reported, sealed: read once, by the final configuration (docs/design.md, "Traffic
# keys").
TEST = range(6 * SPAN, 7 * SPAN)
# Tables 3–4's rates and regime.csv: fresh for learning while driving, as the range before it
# had been read twice by earlier designs of Table 4.
CROWD_TEST = range(9 * SPAN, 10 * SPAN)
ABLATION_CROWD_TEST = range(10 * SPAN, 11 * SPAN)  # Table 4's ablation and the departures
SPENT_CROWD_TEST = range(7 * SPAN, 8 * SPAN)  # read twice by earlier designs of Table 4
# Test ranges read while the design was still being chosen: never used again, for anything.
RETIRED_TEST = range(SPAN, 2 * SPAN)
RETIRED_CROWD_TEST = range(5 * SPAN, 6 * SPAN)
# Situations design trials were scored on (docs/history.md, "Dynamic vehicles"): no result is
# reported on them and no experiment reads them; tests draw here.
DESIGN_TRIALS = range(8 * SPAN, 9 * SPAN)

@dataclass(frozen=True)
class Allocation:
    """The keys one use reads (at most), in one of :data:`RANGES`, and who reads them."""

    keys: range
    read_by: str

    @property
    def start(self) -> int:
        return self.keys.start


# Every range, with who reads it.
RANGES = {
    "training": Allocation(TRAINING, "generation g draws key g"),
    "validation": Allocation(VALIDATION, "choosing a controller among a run's candidates"),
    "acceptance": Allocation(ACCEPTANCE, "Table 2: a candidate's acceptance by its lower "
                             "bound"),
    "crowd validation": Allocation(CROWD_VALIDATION, "Tables 3–4: choosing the winning "
                                   "chromosome, the learning time and life cap"),
    "test": Allocation(TEST, "what is reported: `evaluate`, Tables 1–2, the figures"),
    "crowd test": Allocation(CROWD_TEST, "Tables 3–4 and `regime.csv`: the situations whose "
                             "rates are reported"),
    "ablation crowd test": Allocation(ABLATION_CROWD_TEST, "Table 4's ablation and the "
                                      "departures from the authors' rules"),
    "spent crowd test": Allocation(SPENT_CROWD_TEST, "read twice by earlier designs of Table "
                                   "4; nothing reads it any more"),
    "retired test": Allocation(RETIRED_TEST, "read while the design was still being chosen; "
                               "never used again"),
    "retired crowd test": Allocation(RETIRED_CROWD_TEST, "read while the design was still "
                                     "being chosen; never used again"),
    "design trials": Allocation(DESIGN_TRIALS, "situations design trials were scored on; "
                                "nothing reported, no experiment reads them (tests draw here)"),
}


def _within(block: range, offset: int, count: int) -> range:
    return range(block.start + offset, block.start + offset + count)


# Each use's keys. A crowd reads its first key + situation; the GA-against-RL comparison walks
# keys from its first until its situations' starts are all new (779 keys on the narrow track).
EVALUATION = Allocation(_within(TEST, 0, 1), "enn-traffic evaluate, Tables 1–2, Fig. 11's "
                        "test curves, the SUMO families' closed loop")
LANE_KEEPING_TEST = Allocation(_within(TEST, 2, 1), "lane keeping's test roads")
COMPARISON_FIRST_ROUND_TEST = Allocation(_within(TEST, 520_000, 10_000),
                                         "the GA against RL, first round")
COMPARISON_SECOND_ROUND_TEST = Allocation(_within(TEST, 530_000, 10_000),
                                          "the GA against RL, second round")
COMPARISON_TEST = Allocation(_within(TEST, 540_000, 10_000), "the GA against RL, third round")
CHOOSING = Allocation(_within(VALIDATION, 0, 1), "choosing a run's controller (Table 1), "
                      "lane keeping's candidates")
COMPARISON_SECOND_ROUND_VALIDATION = Allocation(_within(VALIDATION, 530_000, 10_000),
                                                "the GA against RL, second round")
COMPARISON_VALIDATION = Allocation(_within(VALIDATION, 540_000, 10_000),
                                   "the GA against RL, third round")
TABLE2_ACCEPTANCE = Allocation(_within(ACCEPTANCE, 0, 1), "Table 2's acceptance")
CROWD_CHOICE = Allocation(_within(CROWD_VALIDATION, 0, 10_000), "Tables 3–4: the arena's "
                          "winner, the learning time and cap; the SUMO crowds' validation")
ARENA_CROWD_TEST = Allocation(_within(CROWD_TEST, 0, 1_000_000),
                              "the arena's Tables 3–4 and regime.csv")
# The SUMO crowds' situations before + 2·10⁶ were measured by two designs found wrong before
# any value was read (docs/departures.md): they are not read again.
SUMO_CROWD_TEST = Allocation(_within(CROWD_TEST, 2_000_000, 10_000),
                             "the SUMO and city families' Tables 3–4, enn-traffic crowd")
ABLATION_FIRST_READING = Allocation(_within(ABLATION_CROWD_TEST, 0, 20),
                                    "Table 4's ablation, its first design (read once)")
ABLATION_SUMO = Allocation(_within(ABLATION_CROWD_TEST, 1_000_000, 1_000_000),
                           "Table 4's ablation, the SUMO strategy")
ABLATION_ARENA = Allocation(_within(ABLATION_CROWD_TEST, 2_000_000, 1_000_000),
                            "Table 4's ablation, the arena")
DEPARTURES = Allocation(_within(ABLATION_CROWD_TEST, 3_000_000, 1_000_000),
                        "the departures from the authors' rules")
AUTHORS_RULES = Allocation(_within(ABLATION_CROWD_TEST, 4_000_000, 1_000_000),
                           "the authors' set-up's three rules, one at a time")

ALLOCATIONS = {name: value for name, value in globals().items()
               if isinstance(value, Allocation) and name.isupper()}


def is_training(key: int) -> bool:
    """Is ``key`` a training generation's (not a held-out key)?"""
    return key in TRAINING
