"""A corpus of bad input, generated from the schema and the command line: every case ends in
exit status 2 and one message naming the file and the key, without a traceback, before any
work, and writes nothing (docs/design.md, "Reliability").

Cases: every scenario key with values of the wrong type, out of its bounds and extreme; every
kind of path for scenario, network, route, SUMO configuration and controller files; every
output path kind of every command; the ``.sumocfg`` options that open ports or move SUMO's
files. They run in-process through :func:`enn_traffic.cli.main`, so a traceback would fail
the test with the exception itself.
"""

from __future__ import annotations

import math
import tomllib
import typing
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from pydantic import BaseModel
from refusals import refusal

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
# The shipped scenario each section's keys are edited in: one where the key is in use.
BASE = {"track": "navigation_narrow", "vehicle": "navigation_narrow",
        "sensor": "navigation_narrow", "network": "navigation_narrow", "ga": "navigation_narrow",
        "episode": "navigation_narrow", "traffic": "arena_strategy1",
        "lane_keeping": "lane_keeping", "traffic.drivers": "sumo_strategy1"}
SECTIONS = {"track": "TrackConfig", "vehicle": "VehicleConfig", "sensor": "SensorConfig",
            "network": "NetworkConfig", "ga": "GAConfig", "episode": "EpisodeConfig",
            "traffic": "TrafficConfig", "lane_keeping": "LaneKeepingConfig",
            "traffic.drivers": "DriversConfig"}
SUMO_KEYS = {"routes", "sumocfg", "learners", "mode", "begin_s", "warmup_s", "sumo_outputs",
             "warmup_states"}  # edited in a scenario of SUMO traffic
SKIPPED = {("track", "traffic"), ("traffic", "drivers"), ("lane_keeping", "draw")}  # tables


def _model(section: str) -> type[BaseModel]:
    import enn_traffic.config as schema

    return getattr(schema, SECTIONS[section])


def _kinds(annotation) -> set[str]:
    """The kinds of value a field takes: number, integer, boolean, text, list, path."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _kinds(typing.get_args(annotation)[0])
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        return set().union(*(_kinds(arg) for arg in typing.get_args(annotation)))
    if origin in (list, tuple):
        return {"list"}
    if origin is typing.Literal:
        return {"text"}
    return {bool: {"boolean"}, int: {"integer"}, float: {"number"}, str: {"text"},
            Path: {"path"}, type(None): set()}.get(annotation, {"other"})


def _bounds(field) -> tuple[float | None, float | None]:
    """The field's lower and upper bound (``ge``/``gt``, ``le``/``lt``), None where unset."""
    low = high = None
    for item in field.metadata:
        for name in ("ge", "gt"):
            if getattr(item, name, None) is not None:
                low = getattr(item, name)
        for name in ("le", "lt"):
            if getattr(item, name, None) is not None:
                high = getattr(item, name)
    return low, high


def _wrong_values(field) -> list[tuple[str, object]]:
    """Values the field must refuse: of another type, beyond its bounds, extreme."""
    kinds = _kinds(field.annotation)
    cases: list[tuple[str, object]] = [("a table", {"x": 1})]
    if kinds & {"number", "integer"}:
        cases += [("a string", "19"), ("a boolean", True)]
        if "integer" in kinds and "number" not in kinds:
            cases += [("a fraction", 2.5)]
        low, high = _bounds(field)
        if low is not None:
            cases += [("below its bound", low - 1), ("-1e308", -1e308)]
        if high is not None:
            cases += [("above its bound", high + 1 if high >= 1 else high * 2), ("1e308", 1e308)]
        if "number" in kinds:
            cases += [("nan", math.nan), ("inf", math.inf)]
    if kinds == {"boolean"}:
        cases += [("a string", "true"), ("an integer", 1)]
    if "text" in kinds and "list" not in kinds:
        cases += [("an integer", 7)]
    if "path" in kinds:
        cases += [("an integer", 7), ("a boolean", True)]
    if kinds == {"list"}:
        cases += [("a string", "x"), ("a list of strings", ["x", "y"])]
    return cases


def _key_cases() -> list[tuple[str, str, str, object]]:
    cases = []
    for section in SECTIONS:
        for name, field in _model(section).model_fields.items():
            if (section, name) in SKIPPED or section.endswith(name):
                continue
            for label, value in _wrong_values(field):
                cases.append((section, name, label, value))
    for name, value in [("name", 5), ("name", ".."), ("name", "a/b"), ("name", ""),
                        ("seed", -1), ("seed", "1"), ("seed", True), ("description", 3)]:
        cases.append(("", name, repr(value), value))
    return cases


KEY_CASES = _key_cases()


def _edited(tmp_path: Path, section: str, key: str, value) -> Path:
    """The section's base scenario with one value replaced, saved beside its own files."""
    name = "sumo_strategy1" if section == "traffic" and key in SUMO_KEYS else BASE.get(
        section, "navigation_narrow")
    base = SCENARIOS / f"{name}.toml"
    data = tomllib.loads(base.read_text())
    _absolute(data, base)
    target = data
    for part in [p for p in section.split(".") if p]:
        target = target.setdefault(part, {})
    target[key] = value
    path = tmp_path / "edited.toml"
    path.write_text(tomli_w.dumps(data))
    return path


def _absolute(data: dict, base: Path) -> None:
    """The base scenario's relative file paths made absolute, as the edited copy lives
    elsewhere."""
    def fix(value):
        if isinstance(value, str) and not value.startswith("pkg:"):
            return str((base.parent / value).resolve())
        return value

    track, traffic = data.get("track") or {}, data.get("traffic") or {}
    if "net" in track:
        track["net"] = fix(track["net"])
    if "sumocfg" in traffic:
        traffic["sumocfg"] = fix(traffic["sumocfg"])
    if "routes" in traffic:
        traffic["routes"] = [fix(route) for route in traffic["routes"]]


def _refused(capsys, tmp_path: Path, argv: list, file: object, key: str | None) -> str:
    """Run the command line; it must exit 2 with one message naming ``file`` (a path, or
    any of several) and ``key``, and write nothing but into its output folder
    ``tmp_path/out``."""
    before = _outside_out(tmp_path)
    message = refusal(capsys, argv, file, key)
    assert _outside_out(tmp_path) == before, "something was written outside the output folder"
    return message


def _run(scenario: Path, tmp_path: Path) -> list:
    return ["run", scenario, "--out", tmp_path / "out", "--quiet"]


def _outside_out(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*") if "out" not in p.relative_to(folder).parts)


@pytest.mark.parametrize(("section", "key", "label", "value"), KEY_CASES,
                         ids=[f"{s or 'top'}.{k}={label}" for s, k, label, _ in KEY_CASES])
def test_a_wrong_scenario_value_is_refused_naming_file_and_key(
        capsys, tmp_path, monkeypatch, section, key, label, value):
    monkeypatch.chdir(tmp_path)
    path = _edited(tmp_path, section, key, value)
    where = f"{section}.{key}" if section else key
    _refused(capsys, tmp_path, _run(path, tmp_path), path.resolve(), where)


def _lines(count: int, start: float = 0.0) -> list[list[float]]:
    return [[start + 10.0 * i, 0.0] for i in range(count)]


SCENARIO_CASES = {
    # a documented network shape that crashed, memory-sized inputs, stacked starts
    "hidden layers beyond 16": ("network", "hidden", [8] * 17, "network.hidden"),
    "a population of 3 GB": ("network", "hidden", [1024] * 16, "ga.population_size"),
    "20,000 traffic starts": ("traffic", "starts_xy", _lines(20_000), "traffic.starts_xy"),
    "starts at one point": ("traffic", "starts_xy", [[0.0, 0.0], [0.0, 0.0]],
                            "traffic.starts_xy[1]"),
    "a step longer than the body": ("vehicle", "dt", 1.0, "vehicle"),
    "a wheelbase longer than the body": ("vehicle", "wheelbase", 5.0, "vehicle"),
    "no such strategy": ("traffic", "strategy", "teleport", "traffic.strategy"),
    "no strategy at all": ("traffic", "strategy", [], "traffic.strategy"),
    "a step too short for the spin rule": ("vehicle", "dt", 0.001, "episode.spin_window"),
    "a file outside its package": ("track", "net", "pkg:enn_traffic/../../../etc/hosts", "net"),
    "an unknown key": ("ga", "colour", 3, "ga.colour"),
}


@pytest.mark.parametrize("case", list(SCENARIO_CASES))
def test_an_impossible_scenario_is_refused_before_any_work(capsys, tmp_path, monkeypatch, case):
    monkeypatch.chdir(tmp_path)
    section, key, value, where = SCENARIO_CASES[case]
    path = _edited(tmp_path, section, key, value)
    _refused(capsys, tmp_path, _run(path, tmp_path), path.resolve(), where)


def _path_kinds(tmp_path: Path, suffix: str) -> dict[str, Path]:
    """One path of each kind a user may give by mistake, named ``*suffix``."""
    (tmp_path / f"a_folder{suffix}").mkdir()
    (tmp_path / f"empty{suffix}").write_text("")
    (tmp_path / f"junk{suffix}").write_bytes(bytes(range(256)))
    (tmp_path / f"wrong_content{suffix}").write_text("[track]\nnet = 1\n<x>")
    (tmp_path / f"loop_a{suffix}").symlink_to(tmp_path / f"loop_b{suffix}")
    (tmp_path / f"loop_b{suffix}").symlink_to(tmp_path / f"loop_a{suffix}")
    (tmp_path / f"dangling{suffix}").symlink_to(tmp_path / "nowhere")
    kinds = {"missing": "missing", "a folder": "a_folder", "empty": "empty",
             "binary junk": "junk", "wrong content": "wrong_content",
             "a symlink loop": "loop_a", "a dangling symlink": "dangling"}
    return {kind: tmp_path / f"{name}{suffix}" for kind, name in kinds.items()}


PATH_KINDS = ["missing", "a folder", "empty", "binary junk", "wrong content", "a symlink loop",
              "a dangling symlink"]
FILE_KEYS = {"track.net": ("navigation_narrow", "track", "net", False),
             "traffic.routes[0]": ("sumo_strategy1", "traffic", "routes", True),
             "traffic.sumocfg": ("city_cologne3", "traffic", "sumocfg", False)}


@pytest.mark.parametrize("kind", PATH_KINDS)
@pytest.mark.parametrize("where", list(FILE_KEYS))
def test_every_kind_of_bad_input_file_is_refused(capsys, tmp_path, monkeypatch, where, kind):
    monkeypatch.chdir(tmp_path)
    base, section, key, listed = FILE_KEYS[where]
    bad = _path_kinds(tmp_path, ".xml")[kind]
    data = tomllib.loads((SCENARIOS / f"{base}.toml").read_text())
    _absolute(data, SCENARIOS / f"{base}.toml")
    data[section][key] = [str(bad)] if listed else str(bad)
    path = tmp_path / "edited.toml"
    path.write_text(tomli_w.dumps(data))
    _refused(capsys, tmp_path, _run(path, tmp_path),
             (f"{path.resolve()}: {where}", bad.name), None)


@pytest.mark.parametrize("kind", PATH_KINDS + ["invalid TOML", "Latin-1 text"])
def test_every_kind_of_bad_scenario_file_is_refused(capsys, tmp_path, monkeypatch, kind):
    monkeypatch.chdir(tmp_path)
    paths = _path_kinds(tmp_path, ".toml")
    paths["invalid TOML"] = tmp_path / "invalid.toml"
    paths["invalid TOML"].write_text("name = \n[track\n")
    paths["Latin-1 text"] = tmp_path / "latin.toml"
    paths["Latin-1 text"].write_bytes('name = "café"\n'.encode("latin-1"))
    scenario = paths[kind]
    _refused(capsys, tmp_path, _run(scenario, tmp_path), scenario.name,
             None)


@pytest.mark.parametrize("kind", PATH_KINDS + ["a truncated controller", "a wrong suffix",
                                  "a NaN range"])
def test_every_kind_of_bad_controller_file_is_refused(capsys, tmp_path, monkeypatch, kind):
    monkeypatch.chdir(tmp_path)
    paths = _path_kinds(tmp_path, ".npz")
    paths["a truncated controller"] = tmp_path / "truncated.npz"
    paths["a truncated controller"].write_bytes(Path(BEST).read_bytes()[:100])  # cut short
    paths["a NaN range"] = tmp_path / "nan_range.npz"
    with np.load(BEST) as saved:
        np.savez(paths["a NaN range"], **{**dict(saved), "range": np.float64("nan")})
    paths["a wrong suffix"] = tmp_path / "controller.pkl"
    paths["a wrong suffix"].write_text("x")
    controller = paths[kind]
    scenario = SCENARIOS / "navigation_narrow.toml"
    _refused(capsys, tmp_path, ["evaluate", controller, scenario], controller.name, None)


def _output_kinds(tmp_path: Path, suffix: str = ".csv") -> dict[str, Path]:
    """One output path of each kind a user may give by mistake, named ``*suffix``."""
    (tmp_path / "existing_file").write_text("keep me")
    (tmp_path / f"a_folder{suffix}").mkdir()
    (tmp_path / f"loop_a{suffix}").symlink_to(tmp_path / f"loop_b{suffix}")
    (tmp_path / f"loop_b{suffix}").symlink_to(tmp_path / f"loop_a{suffix}")
    (tmp_path / f"dangling{suffix}").symlink_to(tmp_path / "nowhere" / f"x{suffix}")
    return {"a device": Path("/dev/null"), "a folder": tmp_path / f"a_folder{suffix}",
            "under a file": tmp_path / "existing_file" / f"out{suffix}",
            "unwritable": Path(f"/proc/enn-traffic-test/out{suffix}"),
            "a symlink loop": tmp_path / f"loop_a{suffix}",
            "a dangling symlink": tmp_path / f"dangling{suffix}",
            "a wrong suffix": tmp_path / "out.txt"}


OUTPUT_KINDS = ["a device", "a folder", "under a file", "unwritable", "a symlink loop",
                "a dangling symlink", "a wrong suffix"]
NARROW = str(SCENARIOS / "navigation_narrow.toml")
BEST = str(ROOT / "results/paper/controllers/table1/strategy1.npz")
FILE_COMMANDS = {
    "evaluate --out": (["evaluate", BEST, NARROW, "--out"], ".csv", "--out"),
    "render --out": (["render", BEST, NARROW, "--out"], ".png", "--out"),
    "lanes --out": (["lanes", NARROW, "--out"], ".csv", "--out"),
    "lanes --plot": (["lanes", NARROW, "--plot"], ".png", "--plot"),
    "bench --out": (["bench", "--quick", "--out"], ".csv", "--out"),
}


@pytest.mark.parametrize("kind", OUTPUT_KINDS)
@pytest.mark.parametrize("command", list(FILE_COMMANDS))
def test_every_output_file_is_checked_before_any_work(capsys, tmp_path, monkeypatch, command,
                                                      kind):
    monkeypatch.chdir(tmp_path)
    argv, suffix, key = FILE_COMMANDS[command]
    out = _output_kinds(tmp_path, suffix)[kind]
    _refused(capsys, tmp_path, [*argv, out], out, key)


FOLDER_COMMANDS = {
    "run --out": ["run", NARROW, "--generations", "1", "--out"],
    "reproduce --out": ["reproduce", "--quick", "--only", "fig7", "--out"],
    "baseline --out": ["baseline", NARROW, "--plan", "GA:1k:1", "--out"],
}


def test_evaluate_checks_its_matrix_files_before_any_work(capsys, tmp_path, monkeypatch):
    """Several pairs write FILE_matrix.csv and .png beside FILE.csv: a folder in the way was
    found only after the whole evaluation."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m_matrix.csv").mkdir()
    wide = str(SCENARIOS / "navigation_wide.toml")
    _refused(capsys, tmp_path, ["evaluate", BEST, NARROW, wide, "--out", tmp_path / "m.csv"],
             tmp_path / "m_matrix.csv", None)


COMMAND_LINES = {
    "--only of no experiment": ["reproduce", "--only", ",", "--out", "x"],
    "--only empty": ["reproduce", "--only", "", "--out", "x"],
    "--resume with --force": ["run", NARROW, "--resume", "--force"],
    "an empty --out": ["run", NARROW, "--out", ""],
    "--max-steps beyond the cap": ["render", BEST, NARROW, "--max-steps", "99999999999",
                                   "--out", "r.gif"],
    "--episodes beyond the cap": ["evaluate", BEST, NARROW, "--episodes", "1001"],
    "--population beyond the schema": ["run", NARROW, "--population", "100001"],
    "--population not above the elites": ["run", "sumo_strategy1", "--population", "4"],
}


@pytest.mark.parametrize("case", list(COMMAND_LINES))
def test_a_bad_command_line_exits_2_before_any_work(capsys, tmp_path, monkeypatch, case):
    monkeypatch.chdir(tmp_path)
    message = refusal(capsys, COMMAND_LINES[case])
    if "--population" in COMMAND_LINES[case]:  # named as the option given, not a file's key
        assert "--population" in message, message
    assert not list(tmp_path.iterdir()), "something was written"


@pytest.mark.parametrize("kind", ["a device", "an existing file", "under a file",
                                  "unwritable", "a symlink loop"])
@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_every_output_folder_is_checked_before_any_work(capsys, tmp_path, monkeypatch, command,
                                                        kind):
    monkeypatch.chdir(tmp_path)
    outputs = _output_kinds(tmp_path)
    out = {"a device": Path("/dev/null"), "an existing file": tmp_path / "existing_file",
           "under a file": tmp_path / "existing_file" / "run",
           "unwritable": Path("/proc/enn-traffic-test/run"),
           "a symlink loop": outputs["a symlink loop"]}[kind]
    _refused(capsys, tmp_path, [*FOLDER_COMMANDS[command], out], out, "--out")
    assert (tmp_path / "existing_file").read_text() == "keep me"


SUMOCFG_OPTIONS = {"remote-port": "8813", "num-clients": "2",
                   "save-configuration": "saved.sumocfg", "save-template": "t.xml",
                   "save-schema": "s.xsd", "configuration-file": "other.sumocfg",
                   "output-suffix": "/../../x", "save-state.suffix": "/../y.xml",
                   "help": "true", "version": "true", "print-options": "true"}


@pytest.mark.parametrize("option", list(SUMOCFG_OPTIONS))
def test_sumocfg_options_that_open_ports_or_move_files_are_refused(capsys, tmp_path,
                                                                   monkeypatch, road_net,
                                                                   option):
    from sumo_road import road_scenario

    monkeypatch.chdir(tmp_path)
    path = road_scenario(tmp_path, road_net)
    config = tmp_path / "road.sumocfg"
    config.write_text(config.read_text().replace(
        "</configuration>", f'<{option} value="{SUMOCFG_OPTIONS[option]}"/></configuration>'))
    _refused(capsys, tmp_path, _run(path, tmp_path), config, option)


def test_the_corpus_holds_at_least_200_cases():
    """The issue's measure: count every parametrised case above."""
    count = (len(KEY_CASES) + len(SCENARIO_CASES) + len(PATH_KINDS) * len(FILE_KEYS)
             + len(PATH_KINDS) + 2 + len(PATH_KINDS) + 3
             + len(OUTPUT_KINDS) * len(FILE_COMMANDS) + 5 * len(FOLDER_COMMANDS)
             + len(SUMOCFG_OPTIONS) + 1 + len(COMMAND_LINES))
    assert count >= 200, count
