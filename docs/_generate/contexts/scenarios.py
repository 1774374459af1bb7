"""docs/scenarios.md: the scenario reference, a row per key of the schema, from the fields'
own descriptions and defaults (a new section is documented without being listed here), and
the shipped scenarios with the descriptions their files give."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import get_args

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from enn_traffic.config import Scenario


def models(annotation) -> list[type[BaseModel]]:
    """The pydantic models an annotation names (``X``, ``X | None``, ``list[X]``, ...)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [model for argument in get_args(annotation) for model in models(argument)]


def sections(model: type[BaseModel] = Scenario, prefix: str = "") -> dict[str, type[BaseModel]]:
    """Every section of the schema by its dotted name (``track``, ``sensor.rings``,
    ``traffic.drivers``, ...), found in the models' own fields."""
    found = {}
    for name, field in model.model_fields.items():
        for section in models(field.annotation)[:1]:
            found[prefix + name] = section
            found.update(sections(section, f"{prefix}{name}."))
    return found


def toml_value(value) -> str:
    """A default as it is written in TOML."""
    if value is PydanticUndefined:
        return "—"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def keys(model: type[BaseModel], section: str | None) -> list[dict[str, str]]:
    """The keys a file may set in one section: key, default, meaning."""
    return [{"key": f"[{section}] {name}" if section else name,
             "default": toml_value(field.default), "meaning": field.description}
            for name, field in model.model_fields.items()
            if field.description is not None and not isinstance(field.default, BaseModel)
            and not field.exclude]  # a section (listed by its own keys); set by a command


def context(root: Path) -> dict:
    found = sections()
    scenario = keys(Scenario, None)
    scenario += [row for name, model in found.items() if not name.startswith("lane_keeping")
                 for row in keys(model, name)]
    lane_keeping = [row for name, model in found.items() if name.startswith("lane_keeping")
                    for row in keys(model, name)]
    shipped = [{"name": path.stem, "description": tomllib.loads(
                   path.read_text(encoding="utf-8")).get("description", "")}
               for path in sorted((root / "scenarios").glob("*.toml"))]
    return {"scenario_keys": scenario, "lane_keeping_keys": lane_keeping, "shipped": shipped}
