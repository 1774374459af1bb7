
import numpy as np
import pandas as pd
import pytest

from enn_traffic.config import load_scenario
from enn_traffic.core.errors import InputError
from enn_traffic.learning.ga import GAState
from enn_traffic.runs.run import RunOutputs, evolve


def test_target_fitness_stops_the_run_and_resume_keeps_it_stopped(small, tmp_path):
    scenario = small.with_overrides(ga={"target_fitness": 40.0})
    table = evolve(scenario, tmp_path, progress=False)
    assert table["best_fitness"].iloc[-1] >= 40 and (table["best_fitness"].iloc[:-1] < 40).all()
    assert len(table) < 40
    assert RunOutputs.load(tmp_path).stopped
    again = evolve(scenario, tmp_path, resume=True, progress=False)
    pd.testing.assert_frame_equal(table, again)
    unstopped = RunOutputs.load(tmp_path)
    RunOutputs(unstopped.champions, unstopped.population, unstopped.elite_count,
               stopped=False).save(tmp_path)  # as the code before this test wrote it
    evolve(scenario, tmp_path, resume=True, progress=False)
    assert RunOutputs.load(tmp_path).stopped


def test_initial_population_seeds_a_fresh_run(small, tmp_path):
    first = evolve(small.with_overrides(ga={"generations": 3}), tmp_path / "a", progress=False)
    population = GAState.load(tmp_path / "a" / "checkpoint.npz").population
    continued = evolve(small.with_overrides(ga={"generations": 1}), tmp_path / "b",
                       progress=False, initial_population=population)
    # its first generation is that population, evaluated as it stands
    from enn_traffic.sim.world import make_world

    fitness = make_world(small).evaluate(population, 0).fitness
    assert continued["mean_fitness"].iloc[0] == pytest.approx(fitness.mean(), abs=1e-3)
    assert continued["best_fitness"].iloc[0] == pytest.approx(fitness.max(), abs=1e-3)
    assert len(first) == 3
    with pytest.raises(ValueError, match="initial population has shape"):
        evolve(small, tmp_path / "d", progress=False, initial_population=np.zeros((3, 3)))


def test_stop_hook_sees_the_evaluated_population_and_champions_are_its_fittest(small, tmp_path):
    seen = []

    def stop(population, fitness):
        seen.append((population.copy(), fitness.copy()))
        return len(seen) == 3

    table = evolve(small, tmp_path, progress=False, stop=stop)
    assert len(table) == 3
    assert RunOutputs.load(tmp_path).stopped  # what Table 2 reads as "accepted"
    assert all(p.shape == (30, 68) and f.shape == (30,) for p, f in seen)
    assert [f.max() for _, f in seen] == table["best_fitness"].tolist()
    champions = GAState.load(tmp_path / "checkpoint.npz").champions
    assert champions.shape == (3, 68)
    for champion, (population, fitness) in zip(champions, seen, strict=True):
        np.testing.assert_array_equal(champion, population[np.argmax(fitness)])


def test_a_run_is_resumed_only_from_the_same_start_and_other_worlds(small, tmp_path, root):
    """Incremental evolution's runs depend on the population they start from and on the other
    worlds they are judged in: a resume with either changed is refused, not silently reused."""
    scenario = small.with_overrides(ga={"generations": 2})
    population = np.random.default_rng(1).uniform(-1, 1, (30, 68))
    wide = load_scenario(root / "scenarios" / "navigation_wide.toml")
    evolve(scenario, tmp_path, progress=False, initial_population=population, others=[wide])
    again = evolve(scenario, tmp_path, resume=True, progress=False,
                   initial_population=population, others=[wide])
    assert len(again) == 2
    # the other worlds' own number of generations plays no part in this run
    longer = wide.with_overrides(ga={"generations": wide.ga.generations + 50})
    again = evolve(scenario, tmp_path, resume=True, progress=False,
                   initial_population=population, others=[longer])
    pd.testing.assert_frame_equal(again, evolve(scenario, tmp_path, resume=True, progress=False,
                                                initial_population=population, others=[wide]))
    changes = [{"initial_population": population * 0.5, "others": [wide]},
               {"initial_population": population, "others": []},
               {"initial_population": population,
                "others": [wide.with_overrides(sensor={"range": 20.0})]}]
    for change in changes:
        with pytest.raises(InputError, match="different settings"):
            evolve(scenario, tmp_path, resume=True, progress=False, **change)


def test_a_run_made_by_other_rules_is_named_and_run_again(small, tmp_path):
    """issue 26: a run's fingerprint holds the rules that ran it; reproduce reruns a run that
    other rules made, and says so."""
    from enn_traffic.core.provenance import rules_version
    from enn_traffic.experiments.common import run_or_reuse

    scenario = small.with_overrides(ga={"generations": 2})
    first = evolve(scenario, tmp_path, progress=False)
    state = GAState.load(tmp_path / "checkpoint.npz")
    assert state.extra["rules"] == rules_version()
    # what a checkpoint written by other rules holds
    state.fingerprint, state.extra["rules"] = "0" * 16, "0123456789ab"
    state.generation = 1
    state.save(tmp_path / "checkpoint.npz")
    with pytest.raises(InputError, match=r"made by other rules \(0123456789ab; these are"):
        evolve(scenario, tmp_path, resume=True, progress=False)
    again = run_or_reuse(scenario, tmp_path, progress=False)
    assert GAState.load(tmp_path / "checkpoint.npz").extra["rules"] == rules_version()
    pd.testing.assert_frame_equal(again.drop(columns="elapsed_s"),
                                  first.drop(columns="elapsed_s"))


def test_a_run_made_under_an_earlier_digest_of_the_same_rules_resumes(small, tmp_path):
    """A checkpoint whose fingerprint holds an earlier digest of these same rules
    (provenance.SAME_RULES: the last version digested files, not code) continues, and
    takes today's digest; its generations are those of an uninterrupted run."""
    from enn_traffic.core.provenance import SAME_RULES, rules_version
    from enn_traffic.runs.run import fingerprint

    scenario = small.with_overrides(ga={"generations": 3})
    whole = evolve(scenario, tmp_path / "whole", progress=False)
    evolve(scenario.with_overrides(ga={"generations": 1}), tmp_path / "old", progress=False)
    state = GAState.load(tmp_path / "old" / "checkpoint.npz")
    state.fingerprint = fingerprint(scenario, rules=SAME_RULES[0])
    state.extra["rules"] = SAME_RULES[0]
    state.save(tmp_path / "old" / "checkpoint.npz")
    resumed = evolve(scenario, tmp_path / "old", resume=True, progress=False)
    assert GAState.load(tmp_path / "old" / "checkpoint.npz").extra["rules"] == rules_version()
    pd.testing.assert_frame_equal(resumed.drop(columns="elapsed_s"),
                                  whole.drop(columns="elapsed_s"))


def test_only_the_deciding_code_moves_a_runs_fingerprint(tmp_path):
    """On a copy of the package, code added to report/ or the command line leaves the rules' digest
    as it was (a finished run is reused); code added to sim/rules.py or the GA moves it (the run is
    made again). Every source's digest, the record of what wrote an output, moves with any of them;
    a comment moves neither."""
    import shutil

    from enn_traffic.core.provenance import PACKAGE, code_version, rules_version

    copy = tmp_path / "enn_traffic"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    rules, code = rules_version(copy), code_version(copy)
    assert (rules, code) == (rules_version(), code_version())
    steps = [("report/plots.py", "AN_EDIT = 1", False), ("cli/run.py", "AN_EDIT = 1", False),
             ("sim/rules.py", "# a comment", False), ("sim/rules.py", "AN_EDIT = 1", True),
             ("learning/ga.py", "AN_EDIT = 1", True)]
    for name, text, decides in steps:
        with open(copy / name, "a") as source:
            source.write(f"\n{text}\n")
        rules_version.cache_clear()
        code_version.cache_clear()
        assert (rules_version(copy) != rules) == decides, name
        assert (code_version(copy) != code) == (text != "# a comment"), name
        rules, code = rules_version(copy), code_version(copy)
    rules_version.cache_clear()
    code_version.cache_clear()


def test_a_stopping_rule_from_an_experiment_is_part_of_the_fingerprint(small):
    """A run's deciders from outside the rules (an experiment's evaluator or stopping rule)
    move its fingerprint; those within the rules, or none, leave it as it was."""
    from enn_traffic.experiments.incremental import incremental_evolution
    from enn_traffic.learning.evaluators import LocalEvaluator
    from enn_traffic.runs.run import fingerprint

    plain = fingerprint(small)
    assert fingerprint(small, deciders=[LocalEvaluator]) == plain
    assert fingerprint(small, deciders=[incremental_evolution]) != plain


def test_a_changed_network_file_changes_the_fingerprint(small, tmp_path, root):
    from enn_traffic.runs.run import fingerprint

    net = tmp_path / "track.net.xml"
    net.write_bytes((root / "sumo_nets" / "track_narrow.net.xml").read_bytes())
    scenario = small.with_overrides(track={"net": str(net)})
    before = fingerprint(scenario)
    assert fingerprint(scenario) == before
    net.write_bytes(net.read_bytes() + b"<!-- edited -->\n")
    assert fingerprint(scenario) != before


def test_a_registered_column_is_written_to_generations_csv(small, tmp_path):
    """A new column of generations.csv is one registered function (issue 41)."""
    from enn_traffic.runs import generations_csv as generations

    @generations.column
    def lives(evaluated):
        return int(evaluated.results.steps.size)

    try:
        table = evolve(small.with_overrides(ga={"generations": 2}), tmp_path, progress=False)
    finally:
        del generations.COLUMNS["lives"]
    assert list(table.columns)[-1] == "lives"
    assert (table["lives"] == small.ga.population_size * small.traffic.episodes).all()


def test_a_slow_step_speaks_on_stderr_where_no_logging_is_configured():
    """A script or notebook that configured no logging (the environments' users) still hears
    of a long wait, such as the first compile of an environment's kernels."""
    import subprocess
    import sys

    code = ("import time\nfrom enn_traffic.core.progress import slow_step\n"
            "with slow_step('compiling something', after_s=0.05):\n    time.sleep(0.3)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert "enn-traffic: compiling something ..." in done.stderr
    assert "compiling something: done in" in done.stderr


def test_design_md_lists_every_generations_column_as_its_function_says(root):
    """docs/design.md's table of generations.csv is rendered from the column functions'
    docstrings (tests/docs/test_render.py keeps the file rendered): every column has one and is
    in the table."""
    from enn_traffic.runs.generations_csv import COLUMNS

    doc = (root / "docs" / "design.md").read_text()
    assert all(function.__doc__ and f"| `{name}` |" in doc for name, function in COLUMNS.items())
