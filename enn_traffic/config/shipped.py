"""The scenarios and road networks that ship with enn-traffic.

They install inside the package (``enn_traffic/scenarios``, ``enn_traffic/sumo_nets``), so an
installed enn-traffic finds them from any directory; in a source checkout they are the
top-level ``scenarios/`` and ``sumo_nets/`` folders.
"""

from __future__ import annotations

from pathlib import Path

from enn_traffic.config import Scenario, load_scenario

_PACKAGE = Path(__file__).resolve().parents[1]


def shipped_folder(name: str) -> Path:
    """The installed folder ``name`` (``scenarios``, ``sumo_nets``), or the checkout's."""
    installed = _PACKAGE / name
    return installed if installed.is_dir() else _PACKAGE.parent / name


SCENARIOS = shipped_folder("scenarios")


def shipped_scenario(name: str) -> Scenario:
    """A shipped scenario by name (``scenarios/NAME.toml``)."""
    return load_scenario(SCENARIOS / f"{name}.toml")


def scenario_path(argument: str | Path) -> Path:
    """A scenario file as a user names it: a path, or the bare name of a shipped scenario
    (``navigation_narrow``: no folder, no suffix) when no such file exists here. A path that
    does not exist is an error, even when a shipped scenario has its name."""
    from enn_traffic.core.errors import InputError

    path = Path(argument)
    if path.exists():
        return path
    shipped = SCENARIOS / f"{path.stem}.toml"
    if str(path) == path.stem and shipped.exists():
        return shipped
    if shipped.exists() and path.suffix in ("", ".toml"):
        raise InputError(f"file not found (the shipped scenario of that name is given as "
                         f"{path.stem!r} alone)", path)
    return path
