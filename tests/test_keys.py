"""Every traffic-key range is named once and no two overlap (docs/design.md, "Traffic keys")."""

from itertools import combinations

from enn_traffic.config import GAConfig
from enn_traffic.core import keys


def test_key_ranges_are_disjoint():
    for (a, first), (b, second) in combinations(keys.RANGES.items(), 2):
        overlap = range(max(first.start, second.start), min(first.stop, second.stop))
        assert len(overlap) == 0, f"{a} and {b} share keys"


def test_no_training_run_reaches_a_held_out_key():
    most = GAConfig.model_fields["generations"].metadata
    limit = next(m.le for m in most if hasattr(m, "le"))
    assert limit < keys.TRAINING.stop
    assert not keys.is_training(keys.TEST.start) and keys.is_training(limit)


def test_experiments_draw_from_their_named_ranges():
    from enn_traffic.experiments import choosing
    from enn_traffic.experiments.crowds import arena as simultaneous
    from enn_traffic.runs import evaluate as deploy

    assert deploy.EVALUATION_KEY in keys.TEST
    assert choosing.VALIDATION_KEY in keys.VALIDATION
    assert choosing.ACCEPTANCE_KEY in keys.ACCEPTANCE
    assert simultaneous.VALIDATION_KEY in keys.CROWD_VALIDATION
    assert simultaneous.SITUATION_KEY in keys.CROWD_TEST


def test_the_sumo_crowds_read_the_fresh_crowd_ranges():
    from enn_traffic.experiments.crowds import sumo as sumo_crowds

    assert sumo_crowds.SITUATION_KEY in keys.CROWD_TEST
    assert sumo_crowds.VALIDATION_KEY in keys.CROWD_VALIDATION


def test_no_experiment_reads_a_retired_test_range():
    from enn_traffic.experiments import choosing, lanekeeping
    from enn_traffic.experiments.crowds import arena as simultaneous
    from enn_traffic.experiments.crowds import sumo as sumo_crowds
    from enn_traffic.runs import evaluate as deploy

    used = [deploy.EVALUATION_KEY, lanekeeping.TEST_KEY, choosing.VALIDATION_KEY,
            choosing.ACCEPTANCE_KEY, simultaneous.VALIDATION_KEY, simultaneous.SITUATION_KEY,
            sumo_crowds.SITUATION_KEY, sumo_crowds.VALIDATION_KEY]
    for retired in (keys.RETIRED_TEST, keys.RETIRED_CROWD_TEST, keys.DESIGN_TRIALS,
                    keys.SPENT_CROWD_TEST):
        assert not any(key in retired for key in used)
    assert lanekeeping.TEST_KEY in keys.TEST


def test_the_ablation_reads_its_own_sealed_range():
    """Past the keys its first design read (10·10⁹ + 0…19), apart from the SUMO strategy's."""
    from enn_traffic.experiments import ablation

    first_reading = range(keys.ABLATION_CROWD_TEST.start, keys.ABLATION_CROWD_TEST.start + 20)
    for key in (ablation.ABLATION_KEY, ablation.SUMO_KEY):
        assert key in keys.ABLATION_CROWD_TEST and key not in first_reading
    assert abs(ablation.SUMO_KEY - ablation.ABLATION_KEY) >= ablation.ABLATION.situations


def test_the_departures_read_keys_no_other_measurement_read():
    from enn_traffic.experiments import ablation, departures

    key = departures.DEPARTURE_KEY
    assert key in keys.ABLATION_CROWD_TEST
    for other in (keys.ABLATION_CROWD_TEST.start, ablation.ABLATION_KEY, ablation.SUMO_KEY):
        assert abs(key - other) >= max(departures.DEPARTURES.situations,
                                       ablation.ABLATION.situations)
