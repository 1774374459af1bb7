"""An adversarial corpus (issue 64): input a tester builds to break a command, grouped as the
failures it once found. Every case runs the real command (in-process through
:func:`enn_traffic.cli.main`, so a traceback fails the test with the exception itself) and
asserts its exit status and its one-line message; none may hang, lose or overwrite a file, or
pass silently.

Groups: inputs that are not regular files of bounded size (pipes, devices, sockets, folders,
oversized and compressed bombs) in every place a file is named; XML and TOML built to choke a
reader; a controller's own values; edited checkpoints; damaged cache entries (rebuilt, same
result); links and a second writer in the way of outputs; scenarios that share a name; every
file SUMO reads in a cache key; every number of the command line; what an interrupted command
leaves behind.
"""

from __future__ import annotations

import gzip
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from refusals import refusal

from enn_traffic import cli
from enn_traffic.core.io import MAX_INPUT_MB_VARIABLE, file_lock

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
NARROW = SCENARIOS / "navigation_narrow.toml"
NARROW_NET = ROOT / "sumo_nets" / "track_narrow.net.xml"
BEST = ROOT / "results/paper/controllers/table1/strategy1.npz"


# --- inputs that are not regular files of bounded size, in every place a file is named ------

def _special(tmp_path: Path, kind: str, suffix: str) -> Path:
    """A path of ``kind`` named ``*suffix`` (the input cap is 1 MB in these tests)."""
    path = tmp_path / f"bad_{kind.replace(' ', '_').replace('/', '')}{suffix}"
    if kind == "a pipe":
        os.mkfifo(path)
    elif kind == "a link to a pipe":
        os.mkfifo(tmp_path / "pipe")
        path.symlink_to(tmp_path / "pipe")
    elif kind == "/dev/zero":
        path.symlink_to("/dev/zero")
    elif kind == "/dev/urandom":
        path.symlink_to("/dev/urandom")
    elif kind == "a socket":
        server = socket.socket(socket.AF_UNIX)
        server.bind(str(path))  # closed at the end of the test: the name stays
        server.close()
    elif kind == "a folder":
        path.mkdir()
    elif kind == "a link to a folder":
        (tmp_path / "folder").mkdir()
        path.symlink_to(tmp_path / "folder")
    elif kind == "oversized":
        with open(path, "wb") as handle:  # sparse: 2 MB long, no disk used
            handle.truncate(2 * 2**20)
    elif kind == "a gzip bomb":
        path = path.with_name(path.name + ".gz")
        with gzip.open(path, "wb", compresslevel=9) as handle:
            handle.write(b"<!--" + b" " * (3 * 2**20) + b"-->")
    elif kind == "a cut gzip":
        path = path.with_name(path.name + ".gz")
        data = gzip.compress(b"<net>" + b" " * 10_000 + b"</net>")
        path.write_bytes(data[: len(data) // 2])
    else:
        raise ValueError(kind)
    return path


SPECIAL_KINDS = ["a pipe", "a link to a pipe", "/dev/zero", "/dev/urandom", "a socket",
                 "a folder", "a link to a folder", "oversized", "a gzip bomb", "a cut gzip"]
# Where a file is named: how a case puts the bad path there, and what the message names.
SLOTS = ["scenario file", "track.net", "traffic.routes[0]", "traffic.sumocfg",
         "sumocfg net-file", "sumocfg route-files", "sumocfg additional-files",
         "sumocfg weight-files", "sumocfg load-state", "an include of a route file",
         "controller of evaluate", "controller of render", "scenario of crowd",
         "sumocfg of lanes"]
NOT_GZ = {"scenario file", "controller of evaluate", "controller of render",
          "scenario of crowd", "sumocfg of lanes"}  # known by their suffix


def _road(tmp_path: Path, road_net: Path) -> Path:
    from sumo_road import road_scenario

    return road_scenario(tmp_path, road_net)


def _placed(tmp_path: Path, road_net: Path, slot: str, bad: Path) -> tuple[list, tuple]:
    """The command line that reads ``bad`` in ``slot``, and what its message may name."""
    out = ["--out", tmp_path / "out", "--quiet"]
    if slot == "scenario file":
        return ["run", bad, *out], (bad.name,)
    if slot == "scenario of crowd":
        return ["crowd", bad, *out], (bad.name,)
    if slot == "sumocfg of lanes":
        return ["lanes", bad], (bad.name,)
    if slot.startswith("controller of"):
        command = slot.split()[-1]
        extra = ["--out", tmp_path / "r.png"] if command == "render" else []
        return [command, bad, NARROW, *extra], (bad.name,)
    if slot == "track.net":
        data = tomllib.loads(NARROW.read_text())
        data["track"]["net"] = str(bad)
        path = tmp_path / "edited.toml"
        path.write_text(tomli_w.dumps(data))
        return ["run", path, *out], (path.name,)
    scenario = _road(tmp_path, road_net)
    config = tmp_path / "road.sumocfg"
    if slot in ("traffic.routes[0]", "traffic.sumocfg"):
        key = slot.split(".")[1].split("[")[0]
        text = scenario.read_text()
        value = f'["{bad}"]' if key == "routes" else f'"{bad}"'
        text = text.replace('sumocfg = "road.sumocfg"', f"{key} = {value}" if key == "sumocfg"
                            else f'sumocfg = "road.sumocfg"\n{key} = {value}')
        scenario.write_text(text)
        return ["run", scenario, *out], (scenario.name,)
    if slot.startswith("sumocfg "):
        option = slot.split()[1]
        text = config.read_text()
        if option in ("net-file", "route-files"):
            text = text.replace(f'<{option} value="', f'<{option} value="{bad},' if option ==
                                "route-files" else f'<{option} value="{bad}"/><x a="')
        else:
            text = text.replace("</input>", f'<{option} value="{bad}"/></input>')
        config.write_text(text)
        return ["run", scenario, *out], (config.name, "road.sumocfg")
    if slot == "an include of a route file":
        routes = tmp_path / "buses.rou.xml"
        routes.write_text(routes.read_text().replace(
            "</routes>", f'<include href="{bad}"/></routes>'))
        return ["run", scenario, *out], ("buses.rou.xml",)
    raise ValueError(slot)


SPECIAL_CASES = [(slot, kind) for slot in SLOTS for kind in SPECIAL_KINDS
                 if not (slot in NOT_GZ and "gzip" in kind)]


@pytest.mark.parametrize(("slot", "kind"), SPECIAL_CASES,
                         ids=[f"{s}-{k}" for s, k in SPECIAL_CASES])
def test_an_input_that_is_no_regular_file_of_bounded_size_is_refused_before_it_is_read(
        capsys, tmp_path, monkeypatch, road_net, slot, kind):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MAX_INPUT_MB_VARIABLE, "1")
    suffix = {"scenario file": ".toml", "scenario of crowd": ".toml",
              "sumocfg of lanes": ".sumocfg"}.get(slot, ".npz" if slot.startswith(
                  "controller") else ".xml")
    bad = _special(tmp_path, kind, suffix)
    argv, names = _placed(tmp_path, road_net, slot, bad)
    started = time.monotonic()
    refusal(capsys, argv, names)
    assert time.monotonic() - started < 30, "a refusal must not wait on the file"
    assert not (tmp_path / "out" / "best.npz").exists()


def test_a_compressed_bomb_names_the_file_that_inflates(capsys, tmp_path, monkeypatch):
    """The scenario's key and the file that inflates, both (the key alone was named)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MAX_INPUT_MB_VARIABLE, "1")
    bomb = _special(tmp_path, "a gzip bomb", ".net.xml")
    argv, names = _placed(tmp_path, None, "track.net", bomb)
    message = refusal(capsys, argv, names, key="track.net")
    assert bomb.name in message, message


# --- XML and TOML built to choke a reader ---------------------------------------------------

XML_BODIES = {
    "an unknown encoding": b'<?xml version="1.0" encoding="x-no-such"?><net/>',
    "UTF-16 bytes declared UTF-8": '<?xml version="1.0" encoding="UTF-8"?><net/>'.encode(
        "utf-16"),
    "cut mid-element": b"<net><edge id=",
    "a billion laughs": (b'<?xml version="1.0"?><!DOCTYPE l [<!ENTITY a "aaaaaaaaaa">'
                         + b"".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">'
                                    .encode() for i in range(9))
                         + b"]><net>&j;</net>"),
    "an external entity": (b'<?xml version="1.0"?><!DOCTYPE n [<!ENTITY e SYSTEM '
                           b'"file:///etc/passwd">]><net>&e;</net>'),
    "nested 100,000 deep": b"<a>" * 100_000 + b"</a>" * 100_000,
    "not XML at all": bytes(range(256)) * 4,
}
XML_SLOTS = ["track.net", "traffic.routes[0]", "traffic.sumocfg", "sumocfg route-files",
             "sumocfg additional-files", "an include of a route file"]
XML_CASES = [(slot, kind) for slot in XML_SLOTS for kind in XML_BODIES]


@pytest.mark.parametrize(("slot", "kind"), XML_CASES, ids=[f"{s}-{k}" for s, k in XML_CASES])
def test_xml_built_to_choke_a_reader_is_one_clear_message(capsys, tmp_path, monkeypatch,
                                                          road_net, slot, kind):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.xml"
    bad.write_bytes(XML_BODIES[kind])
    argv, names = _placed(tmp_path, road_net, slot, bad)
    refusal(capsys, argv, (*names, bad.name))


def _deep(depth: int, open_: str, close: str) -> str:
    return open_ * depth + close * depth


def _narrow_with(top: str = "", ga: str = "", name: str | None = None) -> str:
    """The narrow track's scenario (its network by absolute path) with ``top`` lines before
    its first table, ``ga`` lines at the top of its ``[ga]`` table, another ``name``."""
    text = NARROW.read_text().replace('net = "', f'net = "{SCENARIOS}/')
    if name is not None:
        text = text.replace('name = "navigation_narrow"', f"name = '{name}'")
    first = text.index("\n[")
    text = text[:first] + "\n" + top + text[first:]
    return text.replace("[ga]\n", f"[ga]\n{ga}", 1)


TOML_BODIES = {
    "arrays nested 10,000 deep": lambda: _narrow_with(f"deep = {_deep(10_000, '[', ']')}\n"),
    "inline tables nested 10,000 deep": lambda: _narrow_with(
        "deep = " + "{a = " * 10_000 + "1" + "}" * 10_000 + "\n"),
    "a key of 100,000 dotted parts": lambda: _narrow_with(".".join(["a"] * 100_000)
                                                          + " = 1\n"),
    "a NUL in a key": lambda: _narrow_with('"se\\u0000ed" = 1\n'),
    "a 10 MB name": lambda: _narrow_with(name="x" * 10_000_000),
    "a seed of 10,000 digits": lambda: _narrow_with().replace("seed = 1", "seed = "
                                                              + "9" * 10_000),
    "a seed past 64 bits": lambda: _narrow_with().replace("seed = 1", f"seed = {2**64}"),
    "a float beyond range": lambda: _narrow_with().replace("mutation_probability = 0.1",
                                                           "mutation_probability = 1e999"),
    "a table of 100,000 keys": lambda: _narrow_with(ga="".join(f"k{i} = 1\n"
                                                               for i in range(100_000))),
    "Latin-1 bytes": None,
    "a byte-order mark then NUL bytes": None,
}


@pytest.mark.parametrize("command", ["run", "evaluate", "crowd"])
@pytest.mark.parametrize("kind", list(TOML_BODIES))
def test_toml_built_to_choke_a_reader_is_one_clear_message(capsys, tmp_path, monkeypatch,
                                                           kind, command):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "bad.toml"
    if kind == "Latin-1 bytes":
        path.write_bytes('name = "café"\n'.encode("latin-1"))
    elif kind == "a byte-order mark then NUL bytes":
        path.write_bytes(b"\xef\xbb\xbf" + b"\x00" * 1000)
    else:
        path.write_text(TOML_BODIES[kind]())
    argv = {"run": ["run", path, "--out", tmp_path / "out"],
            "evaluate": ["evaluate", BEST, path],
            "crowd": ["crowd", path, "--out", tmp_path / "out"]}[command]
    refusal(capsys, argv, path.name)


# --- a controller's own values: reported as the controller's, not the scenario's -------------

def _controller(tmp_path: Path, **edits) -> Path:
    from enn_traffic.core.neural import NetworkSpec

    with np.load(BEST) as saved:
        data = dict(saved)
    inputs = int(data["layer_sizes"][0])
    data.update(edits)
    if "layer_sizes" in edits and edits["layer_sizes"].ndim == 1:  # 0: the saved inputs
        data["layer_sizes"] = np.where(np.arange(len(edits["layer_sizes"])) == 0, inputs,
                                       edits["layer_sizes"])
    if "layer_sizes" in edits or "layout" in edits:
        try:
            sizes = tuple(int(n) for n in np.atleast_1d(data["layer_sizes"]))
            length = NetworkSpec(sizes, str(data["layout"])).chromosome_length
        except (ValueError, TypeError):
            length = 10
        data["chromosome"] = np.zeros(length)
    path = tmp_path / "edited_controller.npz"
    np.savez(path, **data)
    return path


CONTROLLER_EDITS = {
    "a gain of text": ({"steering_gain_deg": np.str_("90")}, "steering_gain_deg"),
    "a boolean gain": ({"steering_gain_deg": np.bool_(True)}, "steering_gain_deg"),
    "a fractional spin window": ({"spin_window": np.float64(300.7)}, "spin_window"),
    "an unknown layout": ({"layout": np.str_("bogus")}, "layout"),
    "a layout of bytes": ({"layout": np.bytes_(b"source")}, "layout"),
    "a fitness of text": ({"fitness": np.str_("lots")}, "fitness"),
    "a generation of text": ({"generation": np.str_("x")}, "generation"),
    "layer sizes of 2 rows": ({"layer_sizes": np.array([[19, 3, 2], [19, 3, 2]])},
                              "layer_sizes"),
    "range -5": ({"range": np.float64(-5)}, "range"),
    "range 0": ({"range": np.float64(0)}, "range"),
    "span 400°": ({"span_deg": np.float64(400)}, "span_deg"),
    "span -1°": ({"span_deg": np.float64(-1)}, "span_deg"),
    "a hidden layer of 2000": ({"layer_sizes": np.array([0, 2000, 2])}, "layer_sizes"),
    "3 outputs": ({"layer_sizes": np.array([0, 3])}, "layer_sizes"),
    "17 hidden layers": ({"layer_sizes": np.array([0, *[4] * 17, 2])}, "layer_sizes"),
    "a spin window of 0": ({"spin_window": np.int64(0)}, "spin_window"),
    "a negative spin variance": ({"spin_variance": np.float64(-1)}, "spin_variance"),
    "rings of 3 columns": ({"rings": np.ones((1, 3))}, "rings"),
    "a ring of -4 beams": ({"rings": np.array([[-4.0, 90.0, 10.0, 0.0]])}, "rings"),
    "a steering gain of NaN": ({"steering_gain_deg": np.float64("nan")}, "steering_gain_deg"),
}


@pytest.mark.parametrize("command", ["evaluate", "render"])
@pytest.mark.parametrize("edit", list(CONTROLLER_EDITS))
def test_a_bad_value_inside_a_controller_names_the_controller(capsys, tmp_path, monkeypatch,
                                                              edit, command):
    monkeypatch.chdir(tmp_path)
    edits, field = CONTROLLER_EDITS[edit]
    path = _controller(tmp_path, **edits)
    extra = ["--out", tmp_path / "r.png"] if command == "render" else []
    message = refusal(capsys, [command, path, NARROW, *extra], path.name)
    assert str(NARROW) not in message, message
    assert not (tmp_path / "r.png").exists()


# --- edited checkpoints never resume, and best.npz is never rewritten from them --------------

@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("checkpointed") / "run"
    assert cli.main(["run", str(NARROW), "--population", "10", "--generations", "2",
                     "--out", str(out), "--quiet"]) == 0
    return out


def _edited_checkpoint(run: Path, tmp_path: Path, edit) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(run, copy)
    path = copy / "checkpoint.npz"
    with np.load(path) as saved:
        data = dict(saved)
    edit(data)
    np.savez(path, **data)
    return copy


CHECKPOINT_EDITS = {
    "3 rows": (lambda d: d.update(population=d["population"][:3]), "population"),
    "5 genes": (lambda d: d.update(population=d["population"][:, :5]), "population"),
    "a NaN gene": (lambda d: d["population"].__setitem__((0, 0), np.nan), "population"),
    "complex genes": (lambda d: d.update(population=d["population"] * (1 + 1j)),
                      "population"),
    "text genes": (lambda d: d.update(population=d["population"].astype(str)), "checkpoint"),
    "a best chromosome of 5 genes": (lambda d: d.update(best_chromosome=np.zeros(5)),
                                     "best_chromosome"),
    "a NaN best chromosome": (lambda d: d.update(
        best_chromosome=np.full_like(d["best_chromosome"], np.nan)), "best_chromosome"),
    "champions of 4 genes": (lambda d: d.update(champions=np.zeros((2, 4))), "champions"),
    "generation -1": (lambda d: d.update(generation=np.int64(-1)), "generation"),
    "no population": (lambda d: d.pop("population"), "checkpoint"),
    "a garbled generator": (lambda d: d.update(rng_state=np.str_("{")), "checkpoint"),
    "an infinite best fitness": (lambda d: d.update(best_fitness=np.float64(np.inf)),
                                 "best_fitness"),
}


@pytest.mark.parametrize("edit", list(CHECKPOINT_EDITS))
def test_an_edited_checkpoint_is_refused_and_best_npz_is_left_as_it_was(
        capsys, tmp_path, monkeypatch, finished_run, edit):
    monkeypatch.chdir(tmp_path)
    change, field = CHECKPOINT_EDITS[edit]
    run = _edited_checkpoint(finished_run, tmp_path, change)
    best = (run / "best.npz").read_bytes()
    message = refusal(capsys, ["run", NARROW, "--population", "10", "--generations", "3",
                               "--resume", "--out", run, "--quiet"], "checkpoint.npz")
    assert field in message, message
    assert (run / "best.npz").read_bytes() == best


# --- damaged cache entries are built again, with the same result ----------------------------

def _damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "cut short":
        path.write_bytes(data[: len(data) // 2])
    elif how == "a flipped bit":
        middle = len(data) // 2
        path.write_bytes(data[:middle] + bytes([data[middle] ^ 0x10]) + data[middle + 1:])
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "text":
        path.write_bytes(np.savez.__doc__.encode())
    else:
        raise ValueError(how)


@pytest.mark.parametrize("how", ["cut short", "a flipped bit", "empty", "text"])
@pytest.mark.parametrize("kind", ["walls", "grids"])
def test_a_damaged_cache_entry_is_built_again(capsys, tmp_path, monkeypatch, kind, how):
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))
    argv = ["evaluate", BEST, NARROW, "--quiet"]
    assert cli.main([str(a) for a in argv]) == 0
    clean = capsys.readouterr().out
    entries = list((tmp_path / "cache" / kind).glob("*.npz"))
    assert entries
    for entry in entries:
        _damage(entry, how)
    assert cli.main([str(a) for a in argv]) == 0
    assert capsys.readouterr().out == clean


@pytest.mark.parametrize("how", ["cut short", "a flipped bit", "empty", "text"])
def test_a_damaged_compiled_kernel_is_compiled_again(tmp_path, how):
    """numba's cache entry of a kernel (its index and its data file) damaged: the kernel
    compiles again and gives the same value (a cut index or data file stopped every command
    with numba's unpickling traceback)."""
    code = ("import numpy as np, enn_traffic; from enn_traffic.core.geometry import body_corners; "
            "out = np.empty((4, 2)); body_corners(1.0, 2.0, 0.5, 4.0, 2.0, out); "
            "print(repr(out.sum()))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}

    def run() -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, cwd=tmp_path)

    first = run()
    assert first.returncode == 0, first.stderr
    entries = sorted((tmp_path / "numba").rglob("*body_corners*.nb[ic]"))
    assert {p.suffix for p in entries} == {".nbi", ".nbc"}
    for entry in entries:
        _damage(entry, how)
    again = run()
    assert again.returncode == 0, again.stderr
    assert again.stdout == first.stdout
    assert run().stdout == first.stdout  # and its entry was written anew


def test_a_damaged_saved_warm_up_is_simulated_again(capsys, tmp_path, monkeypatch, road_net):
    """A saved warm-up cut short was handed to SUMO, which refused it ("traffic.routes: SUMO
    failed to start"), and never rebuilt."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ENN_TRAFFIC_CACHE", str(tmp_path / "cache"))
    scenario = _road(tmp_path, road_net)
    scenario.write_text(scenario.read_text().replace("max_steps = 400", "max_steps = 50")
                        .replace("episodes = 2", "episodes = 1") + 'mode = "closed-loop"\n')
    argv = ["evaluate", BEST, scenario, "--quiet"]
    from enn_traffic.config import load_scenario
    from enn_traffic.runs.controller import Controller

    assert load_scenario(scenario).inputs == Controller.load(BEST).layer_sizes[0]
    assert cli.main([str(a) for a in argv]) == 0
    clean = capsys.readouterr().out
    states = list((tmp_path / "cache" / "sumo-states").glob("*.xml.gz"))
    assert states
    for state in states:
        _damage(state, "cut short")
    assert cli.main([str(a) for a in argv]) == 0
    assert capsys.readouterr().out == clean


# --- outputs: links inside the output folder, and a second writer ---------------------------

OUTPUT_LINKS = ["best.npz", "generations.csv", "learning_curve.png", "scenario.toml",
                "outputs.npz"]


@pytest.mark.parametrize("name", OUTPUT_LINKS)
def test_a_link_inside_the_run_folder_is_replaced_never_written_through(tmp_path, monkeypatch,
                                                                        capsys, name):
    monkeypatch.chdir(tmp_path)
    outside = tmp_path / "precious.txt"
    outside.write_text("keep me")
    out = tmp_path / "run"
    out.mkdir()
    (out / name).symlink_to(outside)
    assert cli.main(["run", str(NARROW), "--population", "10", "--generations", "1", "--out",
                     str(out), "--quiet", "--force"]) == 0
    capsys.readouterr()
    assert outside.read_text() == "keep me"
    assert not (out / name).is_symlink()


def test_two_evaluations_writing_one_file_at_once_are_refused_not_lost(capsys, tmp_path,
                                                                       monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "table.csv"
    with file_lock(out):  # as a first evaluate holds it while it runs
        message = refusal(capsys, ["evaluate", BEST, NARROW, "--out", out, "--quiet"],
                          out.name, "--out")
    assert "another command is writing" in message
    assert not out.exists() and not (tmp_path / ".table.csv.lock").exists()
    assert cli.main(["evaluate", str(BEST), str(NARROW), "--out", str(out), "--quiet"]) == 0
    assert out.exists() and not (tmp_path / ".table.csv.lock").exists()


# --- scenarios that share a name ------------------------------------------------------------

def test_evaluate_refuses_two_scenarios_of_one_name(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    data = tomllib.loads((SCENARIOS / "navigation_wide.toml").read_text())
    data["name"] = "navigation_narrow"
    data["track"]["net"] = str((SCENARIOS / data["track"]["net"]).resolve())
    other = tmp_path / "wide_named_narrow.toml"
    other.write_text(tomli_w.dumps(data))
    refusal(capsys, ["evaluate", BEST, NARROW, other], other.name, "name")


def test_baseline_refuses_a_scenario_whose_name_its_folder_knows_with_other_content(
        capsys, tmp_path, monkeypatch):
    from enn_traffic.config import load_scenario
    from enn_traffic.experiments.gradient_rl import protocol

    monkeypatch.chdir(tmp_path)
    out = tmp_path / "baseline"
    out.mkdir()
    protocol.check_protocol(out)
    protocol.check_scenarios(out, [load_scenario(NARROW)])
    data = tomllib.loads(NARROW.read_text())
    data["track"]["net"] = str((SCENARIOS / "navigation_wide.toml").parent
                               / tomllib.loads((SCENARIOS / "navigation_wide.toml")
                                               .read_text())["track"]["net"])
    other = tmp_path / "same_name.toml"
    other.write_text(tomli_w.dumps(data))
    refusal(capsys, ["baseline", other, "--plan", "GA:1k:1", "--out", out],
            "scenarios.json", "navigation_narrow")


# --- every file SUMO reads is in the keys of caches and resumed runs -------------------------

def _read_options() -> list[str]:
    from enn_traffic.roads.sumocfg import FILE_OPTIONS, REFUSED, sumo_options

    return sorted({o.name for o in sumo_options().values() if o.reads_file}
                  - set(FILE_OPTIONS) - set(REFUSED) - {"phemlight-path"})


@pytest.mark.parametrize("option", _read_options())
def test_every_file_a_sumocfg_option_names_keys_the_caches(tmp_path, road_net, option):
    """A ``load-state`` or ``weight-files`` replaced after a run left the cached warm-up
    and the resumed run stale: only network, routes, additional and included files counted."""
    from enn_traffic.config import load_scenario, read_files
    from enn_traffic.runs.run import fingerprint
    from enn_traffic.sumo import states

    scenario_path = _road(tmp_path, road_net)
    named = tmp_path / f"named_by_{option.replace('.', '_')}.xml"
    named.write_text("<x/>")
    config = tmp_path / "road.sumocfg"
    config.write_text(config.read_text().replace(
        "</input>", f'<{option} value="{named.name}"/></input>'))
    scenario = load_scenario(scenario_path)
    assert named in read_files(scenario)
    before = (fingerprint(scenario), states.state_path(scenario, 1, True))
    named.write_text("<y/>")
    os.utime(named, ns=(1, 1))
    scenario = load_scenario(scenario_path)
    assert fingerprint(scenario) != before[0]
    assert states.state_path(scenario, 1, True) != before[1]


# --- every number of the command line --------------------------------------------------------

def _numeric_options() -> list[tuple[str, str]]:
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    found = []
    for name, command in commands.choices.items():
        for action in command._actions:
            kind = getattr(action.type, "__qualname__", "")
            if action.option_strings and kind.startswith("int_in"):
                found.append((name, action.option_strings[0]))
    return found


BAD_NUMBERS = ["-1", "nan", "inf", "1e999", "", "1.5", "0x10", "9" * 30, "1e3", "2 3"]
NUMBER_CASES = [(c, o, v) for c, o in _numeric_options() for v in BAD_NUMBERS
                if not (o == "--top" and v == "9" * 30)]  # every lane: a fine request
MINIMAL = {"run": ["run", NARROW], "evaluate": ["evaluate", BEST, NARROW],
           "render": ["render", BEST, NARROW, "--out", "r.png"], "crowd": ["crowd", NARROW],
           "lanes": ["lanes", NARROW], "baseline": ["baseline", NARROW],
           "reproduce": ["reproduce"], "bench": ["bench"]}


@pytest.mark.parametrize(("command", "option", "value"), NUMBER_CASES,
                         ids=[f"{c} {o}={v[:6]!r}" for c, o, v in NUMBER_CASES])
def test_every_number_of_the_command_line_refuses_what_is_not_one(capsys, tmp_path,
                                                                  monkeypatch, command,
                                                                  option, value):
    monkeypatch.chdir(tmp_path)
    refusal(capsys, [*MINIMAL[command], option, value], option)
    assert not list(tmp_path.iterdir()), "something was written"


# --- a tester's second probe ----------------------------------------------------------------

@pytest.mark.parametrize("value", ["nan", "inf", "abc", "-1", "0"])
def test_a_bad_input_limit_in_the_environment_is_one_message(capsys, tmp_path, monkeypatch,
                                                              value):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MAX_INPUT_MB_VARIABLE, value)
    refusal(capsys, ["run", NARROW, "--out", tmp_path / "out"], MAX_INPUT_MB_VARIABLE)


def test_an_input_limit_below_a_megabyte_is_said_in_bytes(capsys, tmp_path, monkeypatch):
    """A limit of 0.0001 MB read "scenario file is 0 MB, more than the 0 MB an input may be"."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MAX_INPUT_MB_VARIABLE, "0.0001")
    message = refusal(capsys, ["run", NARROW, "--out", tmp_path / "out"], NARROW.name)
    assert f"is {NARROW.stat().st_size:,} bytes, more than the 104 bytes" in message, message


def test_render_never_writes_over_a_file_it_reads(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scenario = tmp_path / "scenario.png"  # a scenario file of an odd name
    scenario.write_text(_narrow_with())
    refusal(capsys, ["render", BEST, scenario, "--out", scenario], scenario.name, "--out")
    assert scenario.read_text() == _narrow_with()


def test_a_controller_archive_that_inflates_past_the_limit_is_refused_unread(capsys, tmp_path,
                                                                             monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(MAX_INPUT_MB_VARIABLE, "1")
    with np.load(BEST) as saved:
        data = dict(saved)
    data["chromosome"] = np.zeros(1_000_000)  # 8 MB, a few kB compressed
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, **data)
    refusal(capsys, ["evaluate", path, NARROW], path.name, "chromosome")


def test_a_numpy_array_file_named_npz_is_not_a_controller(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "array.npz"
    with open(path, "wb") as handle:
        np.save(handle, np.zeros(68))
    refusal(capsys, ["evaluate", path, NARROW], path.name)


@pytest.mark.parametrize("cycle", ["itself", "each other"])
def test_files_that_include_each_other_are_refused_before_sumo_crashes(capsys, tmp_path,
                                                                       monkeypatch, road_net,
                                                                       cycle):
    """SUMO crashed (exit -11) on an additional file that includes itself."""
    monkeypatch.chdir(tmp_path)
    scenario = _road(tmp_path, road_net)
    first, second = tmp_path / "a.add.xml", tmp_path / "b.add.xml"
    first.write_text(f'<additional><include href="{"a" if cycle == "itself" else "b"}'
                     '.add.xml"/></additional>')
    second.write_text('<additional><include href="a.add.xml"/></additional>')
    config = tmp_path / "road.sumocfg"
    config.write_text(config.read_text().replace(
        "</input>", '<additional-files value="a.add.xml"/></input>'))
    message = refusal(capsys, ["run", scenario, "--out", tmp_path / "out"], "a.add.xml")
    assert "includes" in message


# --- said against the wrong key, or too late ----------------------------------------------

@pytest.mark.parametrize("kind", ["route", "network"])
def test_a_file_whose_own_name_holds_a_comma_is_refused_naming_it(capsys, tmp_path, monkeypatch,
                                                                  road_net, kind):
    """SUMO splits a list of files at commas (the network's option too), so it failed at its
    start, a network named as ``traffic.routes`` (a folder so named is passed through a
    link: tests/sumo/test_sumo_scenarios.py)."""
    monkeypatch.chdir(tmp_path)
    scenario = _road(tmp_path, road_net)
    if kind == "route":
        (tmp_path / "more,buses.rou.xml").write_text("<routes/>")
        line, name, key = 'routes = ["more,buses.rou.xml"]', "more,buses.rou.xml", \
            "traffic.routes[0]"
        scenario.write_text(scenario.read_text().replace(
            'sumocfg = "road.sumocfg"', f'sumocfg = "road.sumocfg"\n{line}'))
    else:
        shutil.copy(road_net, tmp_path / "road,net.net.xml")
        name, key = "road,net.net.xml", "track.net"
        scenario.write_text(scenario.read_text().replace(
            "[track]\n", '[track]\nnet = "road,net.net.xml"\n'))
    message = refusal(capsys, ["run", scenario, "--out", tmp_path / "out"], scenario.name, key)
    assert name in message and "comma" in message
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("body", "key"), [
    ('name = "x"\n"track.net" = "a.net.xml"\n', '"track.net"'),
    ('name = "x"\n[track]\n"start.lane" = "a"\nstart_anywhere = true\n', 'track."start.lane"'),
])
def test_a_quoted_key_with_a_dot_is_named_as_written(capsys, tmp_path, monkeypatch, body, key):
    """A quoted TOML key with a dot is one name: it was said as the dotted key it is not."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "quoted.toml"
    path.write_text(body.replace("[track]\n", f"[track]\nnet = {str(NARROW_NET)!r}\n"))
    message = refusal(capsys, ["run", path, "--out", tmp_path / "out"], path.name, key)
    assert "unknown key" in message and "quoted" in message


@pytest.mark.parametrize("start", ["start_anywhere = true", 'start_lane = "auto"'])
@pytest.mark.parametrize("command", ["run", "evaluate"])
def test_an_unreadable_network_is_said_as_the_key_that_names_it(capsys, tmp_path, monkeypatch,
                                                                start, command):
    """The network's own read error named the network file alone, or ``track.start_lane``."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "broken.net.xml").write_text('<net version="1.9"><edge id="a">')
    path = tmp_path / "broken.toml"
    path.write_text(f'name = "broken"\n[track]\nnet = "broken.net.xml"\n{start}\n')
    argv = {"run": ["run", path, "--out", tmp_path / "out"],
            "evaluate": ["evaluate", BEST, path, "--quiet"]}[command]  # no bar before it
    message = refusal(capsys, argv, path.name, "track.net")
    assert "broken.net.xml" in message and "not a readable SUMO network" in message


@pytest.mark.parametrize("command", ["run", "crowd"])
@pytest.mark.parametrize("held", ["the user's files", "a run, without --resume"])
def test_a_refused_out_folder_is_said_before_the_network_is_read(capsys, tmp_path, monkeypatch,
                                                                  command, held):
    """A refused ``--out`` waited for the network's read (11–15 s on a city): with a network
    that cannot be read, the folder is what the refusal names."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "broken.net.xml").write_text('<net version="1.9"><edge id="a">')
    path = tmp_path / "broken.toml"
    path.write_text('name = "broken"\n[track]\nnet = "broken.net.xml"\nstart_lane = "auto"\n')
    out = tmp_path / "out"
    out.mkdir()
    (out / ("notes.txt" if held == "the user's files" else
            {"run": "checkpoint.npz", "crowd": "crowd.toml"}[command])).write_text("mine")
    message = refusal(capsys, [command, path, "--out", out], out.name)
    assert "network" not in message
    assert (out / ("notes.txt" if held == "the user's files" else
                   {"run": "checkpoint.npz", "crowd": "crowd.toml"}[command])).read_text() == "mine"


def test_the_corpus_holds_at_least_350_cases():
    """The issue's measure: every case of this file, counted from its tests'
    parametrisations (this count itself left out)."""
    count = 0
    for name, test in globals().items():
        if name.startswith("test_") and name != "test_the_corpus_holds_at_least_350_cases":
            cases = 1
            for mark in getattr(test, "pytestmark", []):
                if mark.name == "parametrize":
                    cases *= len(mark.args[1])
            count += cases
    assert count >= 350, count


# --- what an interrupted command leaves behind ----------------------------------------------

def _interrupt_when(argv: list, appears, cwd: Path, timeout_s: float = 120.0
                    ) -> subprocess.CompletedProcess:
    """Start the command, send it Ctrl-C (SIGINT) once ``appears()`` is true, and wait."""
    process = subprocess.Popen([sys.executable, "-m", "enn_traffic", *map(str, argv)],
                               cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    deadline = time.monotonic() + timeout_s
    while not appears() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    return subprocess.CompletedProcess(process.args, process.returncode, out, err)


def test_ctrl_c_during_a_gif_leaves_no_partial_gif(tmp_path):
    gif = tmp_path / "drive.gif"
    done = _interrupt_when(["render", BEST, NARROW, "--out", gif, "--max-steps", "3000"],
                           lambda: any(tmp_path.glob(".drive.tmp*")), tmp_path)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("enn-traffic: interrupted")
    assert sorted(p.name for p in tmp_path.iterdir()) == [], list(tmp_path.iterdir())


def test_ctrl_c_of_a_closed_loop_evaluation_leaves_no_sumo_folder(tmp_path, road_net):
    scenario = _road(tmp_path, road_net)
    scenario.write_text(scenario.read_text().replace("episodes = 2", "episodes = 6")
                        + 'mode = "closed-loop"\n')
    temp = tmp_path / "temp"
    temp.mkdir()
    env = {**os.environ, "TMPDIR": str(temp)}
    process = subprocess.Popen([sys.executable, "-m", "enn_traffic", "evaluate", str(BEST),
                                str(scenario), "--quiet"], cwd=tmp_path, env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while (not list(temp.glob("enn-sumo-*")) and process.poll() is None
           and time.monotonic() < deadline):
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert not list(temp.glob("enn-sumo-*")), list(temp.iterdir())


def test_a_full_disk_leaves_no_partial_cache_entry(tmp_path):
    """A cache write that fails (here: a file-size limit, as a full disk gives) keeps no
    entry and leaves no ``*.partial.npz``; the arrays are still returned."""
    code = ("import resource, signal, sys, numpy as np; from enn_traffic.core import cache; "
            "signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
            "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096)); "
            "arrays = cache.cached_arrays('walls', 'k', lambda: {'w': np.ones(100_000)}); "
            "sys.exit(0 if arrays['w'].sum() == 100_000 else 1)")
    env = {**os.environ, "ENN_TRAFFIC_CACHE": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "cache" / "walls").is_dir()
    assert not list((tmp_path / "cache").rglob("*.partial*"))
    assert not list((tmp_path / "cache").rglob("*.npz"))
