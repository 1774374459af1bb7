"""The import graph runs one way (docs/design.md, "Architecture"): every module of the package
belongs to a part (a folder, or the package's own ``__init__`` and ``__main__``), the parts
stand in layers (``enn_traffic.LAYERS``), and a module imports only from its own part or from
parts listed before its own. Checked over every
module's every import (at the top or inside a function), so that no circle can form."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from enn_traffic import LAYERS  # the layers, lowest first: the package's folders

PACKAGE = Path(__file__).resolve().parents[1] / "enn_traffic"
# The package's ``__init__`` sets up numba's cache from core; ``__main__`` runs the command line.
ORDER = ["core", "enn_traffic", *LAYERS[1:], "__main__"]


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = ("enn_traffic", *path.relative_to(PACKAGE).with_suffix("").parts)
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def part_of(module: str) -> str:
    """The part a module belongs to: ``enn_traffic.sim.arena`` → ``sim``."""
    names = module.split(".")
    return names[1] if len(names) > 1 else "enn_traffic"


def imported(module: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package's modules that ``module`` imports, anywhere in its source."""
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            # ``from a import b``: the module a.b where there is one, else a itself
            names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base
                     for alias in node.names]
        else:
            continue
        found.update(name for name in names if name in known and name != module)
    return found


def test_every_folder_installs():
    """Each folder of the package is one of the packages ``pyproject.toml`` installs."""
    import tomllib

    listed = set(tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())
                 ["tool"]["setuptools"]["packages"])
    folders = {".".join(("enn_traffic", *path.parent.relative_to(PACKAGE).parts))
               for path in PACKAGE.rglob("__init__.py")}
    assert folders <= listed, sorted(folders - listed)


def test_the_package_holds_only_its_layers():
    """``ls enn_traffic/`` shows the layers' folders and the package's two own files."""
    names = {path.name for path in PACKAGE.iterdir() if path.name != "__pycache__"}
    assert names == {*LAYERS, "__init__.py", "__main__.py"}


def test_every_part_has_a_layer():
    unplaced = {part_of(name) for name in modules()} - set(ORDER)
    assert not unplaced, f"place these in LAYERS: {sorted(unplaced)}"


def test_every_import_runs_down_the_layers():
    known = modules()
    wrong = []
    for module, path in known.items():
        rank = ORDER.index(part_of(module))
        for target in imported(module, path, known):
            target_part = part_of(target)
            if target_part != part_of(module) and ORDER.index(target_part) > rank:
                wrong.append(f"{module} imports {target} (part {target_part!r} is above)")
    assert not wrong, "\n".join(sorted(wrong))


def test_no_import_circles_within_a_part():
    known = modules()
    graph = {module: imported(module, path, known) for module, path in known.items()}
    state: dict[str, int] = {}  # 1: on the path being walked, 2: done

    def walk(module: str, path: list[str]) -> list[str] | None:
        state[module] = 1
        for target in sorted(graph[module]):
            if state.get(target) == 1:
                return [*path[path.index(target):], target] if target in path else [target]
            if target not in state and (circle := walk(target, [*path, target])):
                return circle
        state[module] = 2
        return None

    for module in known:
        if module not in state:
            circle = walk(module, [module])
            assert circle is None, " → ".join(circle)


def test_the_checker_sees_an_import_that_runs_up(tmp_path):
    """The check itself: a lower part importing a higher one, inside a function, is found."""
    source = tmp_path / "enn_traffic" / "core" / "geometry.py"
    source.parent.mkdir(parents=True)
    source.write_text("def f():\n    from enn_traffic.sim import arena\n")
    known = {"enn_traffic.core.geometry": source, "enn_traffic.sim.arena": source,
             "enn_traffic.sim": source}
    assert imported("enn_traffic.core.geometry", source, known) == {"enn_traffic.sim.arena"}
    assert ORDER.index("sim") > ORDER.index(part_of("enn_traffic.core.geometry"))


@pytest.mark.parametrize("module", ["enn_traffic.runs.run", "enn_traffic.sim.world",
                                    "enn_traffic.envs", "enn_traffic.runs.evaluate",
                                    "enn_traffic.experiments", "enn_traffic.cli"])
def test_libsumo_loads_only_where_sumo_runs(module):
    """Importing a module that an arena run uses does not start libsumo (a SUMO world,
    environment or experiment loads it when it is first made)."""
    code = (f"import sys, {module}\n"
            "from enn_traffic.sim.world import make_world\n"
            "from enn_traffic.config.shipped import shipped_scenario\n"
            "make_world(shipped_scenario('navigation_narrow'))\n"
            "print('libsumo' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


def test_only_the_registry_imports_by_name():
    """Code is imported by a name in a string only through
    :class:`enn_traffic.core.registry.Registry` (whose tables the next test checks), so that the
    import checks above see every edge."""
    found = []
    for module, path in modules().items():
        source = path.read_text()
        for call in ("import_module(", "__import__("):
            if call in source and module != "enn_traffic.core.registry":
                found.append(f"{module} calls {call}")
    assert not found, found


def registries() -> list[tuple[str, str]]:
    """Every module-level ``NAME = Registry(...)`` of the package: (module, NAME)."""
    found = []
    for module, path in modules().items():
        for node in ast.parse(path.read_text()).body:
            if (isinstance(node, ast.Assign) and isinstance(node.value, ast.Call)
                    and getattr(node.value.func, "id", None) == "Registry"):
                found += [(module, target.id) for target in node.targets]
    return found


def test_every_registry_entry_resolves_within_the_layers():
    """The names that tables bind to code lazily (world kinds, environments, experiments:
    every ``Registry`` of the package) resolve, to parts no higher than the table's own."""
    import importlib

    tables = registries()
    assert len(tables) >= 5
    for module, name in tables:
        holder, table = part_of(module), getattr(importlib.import_module(module), name)
        for name in table:
            assert callable(table[name]), name
            part = part_of(table.target(name).split(":")[0])
            assert ORDER.index(part) <= ORDER.index(holder), (holder, name)
        with pytest.raises(KeyError, match="unknown"):
            table["no such name"]


def test_the_readme_test_install_pulls_no_torch():
    """Issue 65: `pip install -e .[dev]` must not download torch (its CUDA build, several GB,
    on a fresh CPU machine): the dev extra, with the extras it names expanded, holds neither
    torch nor stable-baselines3 (which requires torch); the SB3 tests skip without them."""
    import tomllib

    from packaging.requirements import Requirement

    project = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]

    def expanded(requirements: list[str]) -> set[str]:
        names = set()
        for requirement in map(Requirement, requirements):
            if requirement.name == project["name"]:  # another extra of this package
                names |= {n for extra in requirement.extras for n in expanded(extras[extra])}
            else:
                names.add(requirement.name.lower())
        return names

    pulled = expanded(extras["dev"]) | expanded(project["dependencies"])
    assert not pulled & {"torch", "stable-baselines3", "triton"}
    assert "stable-baselines3" in expanded(extras["rl"])


@pytest.mark.parametrize("old", ["enn_traffic.scenario", "enn_traffic.controller",
                                 "enn_traffic.worlds", "enn_traffic.keys"])
def test_old_module_names_still_import_with_a_warning(old):
    """A user's ``from enn_traffic.scenario import load_scenario`` works for a release after
    the move, warns, and gives the very objects of the new module; ``enn_traffic.envs`` never
    moved."""
    import importlib
    import sys
    import warnings

    from enn_traffic import MOVED

    sys.modules.pop(old, None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        module = importlib.import_module(old)
    new = importlib.import_module(MOVED[old])
    assert any(issubclass(w.category, DeprecationWarning) and MOVED[old] in str(w.message)
               for w in caught)
    public = [name for name in vars(new) if not name.startswith("_")]
    assert public and all(getattr(module, name) is getattr(new, name) for name in public)
    assert importlib.import_module("enn_traffic.envs").__file__.endswith("envs/__init__.py")


def test_a_module_split_in_several_still_gives_each_of_its_names():
    """``enn_traffic.baseline`` became the modules of ``experiments/gradient_rl``: a user's
    ``from enn_traffic.baseline import policy_fitness, ZOO_PPO, ga_run`` finds each where it
    went; a name none of them has is an AttributeError that names them."""
    import importlib
    import sys
    import warnings

    from enn_traffic.experiments.gradient_rl import protocol, runs, scoring

    sys.modules.pop("enn_traffic.baseline", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        old = importlib.import_module("enn_traffic.baseline")
    assert old.policy_fitness is scoring.policy_fitness
    assert old.ZOO_PPO is protocol.ZOO_PPO and old.ga_run is runs.ga_run
    with pytest.raises(AttributeError, match="gradient_rl.scoring"):
        old.no_such_name  # noqa: B018


def test_only_the_sumo_package_imports_libsumo():
    """SUMO lives in one package: no module outside ``enn_traffic/sumo/`` imports libsumo."""
    outside = []
    for module, path in modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            if any(name.split(".")[0] == "libsumo" for name in names) \
                    and part_of(module) != "sumo":
                outside.append(module)
    assert not outside, outside
