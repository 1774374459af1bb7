"""Every traffic key a use reads is in the ledger (docs/design.md, "Traffic keys"): the ranges
and each use's allocation in them, none sharing a key with another."""

import ast
from itertools import combinations

from test_imports import PACKAGE

from enn_traffic.config import GAConfig
from enn_traffic.core import keys


def test_key_ranges_are_disjoint():
    for (a, first), (b, second) in combinations(keys.RANGES.items(), 2):
        overlap = range(max(first.keys.start, second.keys.start),
                        min(first.keys.stop, second.keys.stop))
        assert len(overlap) == 0, f"{a} and {b} share keys"


def test_every_allocation_lies_in_one_range_and_shares_no_key():
    assert len(keys.ALLOCATIONS) >= 10
    for name, allocation in keys.ALLOCATIONS.items():
        holders = [r for r, block in keys.RANGES.items()
                   if allocation.keys.start in block.keys and allocation.keys[-1] in block.keys]
        assert len(holders) == 1, name
        assert holders[0] not in ("training", "retired test", "retired crowd test",
                                  "spent crowd test", "design trials"), name
    for (a, first), (b, second) in combinations(keys.ALLOCATIONS.items(), 2):
        overlap = range(max(first.keys.start, second.keys.start),
                        min(first.keys.stop, second.keys.stop))
        assert len(overlap) == 0, f"{a} and {b} share keys"


def test_no_module_writes_a_key_of_its_own():
    """A key is an allocation of the ledger, never ``keys.RANGE.start + offset`` written
    elsewhere (a use the ledger would not know)."""
    written = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "keys.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add)
                    and isinstance(node.left, ast.Attribute) and node.left.attr == "start"
                    and isinstance(node.left.value, ast.Attribute)
                    and node.left.value.attr in {name.upper().replace(" ", "_")
                                                 for name in keys.RANGES}):
                written.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert not written, written


def test_no_training_run_reaches_a_held_out_key():
    most = GAConfig.model_fields["generations"].metadata
    limit = next(m.le for m in most if hasattr(m, "le"))
    assert limit < keys.TRAINING.stop
    assert not keys.is_training(keys.TEST.start) and keys.is_training(limit)


def test_the_experiments_read_the_ledgers_keys():
    """The experiments' keys are the ledger's allocations (a sample of the uses)."""
    from enn_traffic.experiments import ablation, ablation_sumo, choosing, departures, lanekeeping
    from enn_traffic.experiments.crowds import arena, sumo
    from enn_traffic.experiments.gradient_rl import protocol
    from enn_traffic.runs import evaluate

    starts = {allocation.start for allocation in keys.ALLOCATIONS.values()}
    used = [evaluate.EVALUATION_KEY, lanekeeping.TEST_KEY, choosing.VALIDATION_KEY,
            choosing.ACCEPTANCE_KEY, arena.VALIDATION_KEY, arena.SITUATION_KEY,
            sumo.SITUATION_KEY, sumo.VALIDATION_KEY, ablation.ABLATION_KEY, ablation_sumo.SUMO_KEY,
            departures.DEPARTURE_KEY, protocol.TEST_KEY, protocol.VALIDATION_KEY]
    assert set(used) <= starts
    assert max(ablation.ABLATION.situations, departures.DEPARTURES.situations) <= len(
        keys.ABLATION_ARENA.keys)
