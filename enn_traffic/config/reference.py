"""The scenario reference (docs/scenarios.md), written from the schema's own field descriptions.

``python -m enn_traffic.config.reference`` rewrites the tables between the
``<!-- reference:NAME -->`` and ``<!-- /reference -->`` markers of docs/scenarios.md; a test
keeps the file in step with the schema.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import get_args

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from enn_traffic.config import Scenario

DOCUMENT = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"


def _models(annotation) -> list[type[BaseModel]]:
    """The pydantic models an annotation names (``X``, ``X | None``, ``list[X]``, ...)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [model for argument in get_args(annotation) for model in _models(argument)]


def sections(model: type[BaseModel] = Scenario, prefix: str = "") -> dict[str, type[BaseModel]]:
    """Every section of the schema by its dotted name (``track``, ``sensor.rings``,
    ``traffic.drivers``, ...), found in the models' own fields: a new section is documented
    without being listed here."""
    found = {}
    for name, field in model.model_fields.items():
        for section in _models(field.annotation)[:1]:
            found[prefix + name] = section
            found.update(sections(section, f"{prefix}{name}."))
    return found


SECTIONS = {name: model for name, model in sections().items()
            if not name.startswith("lane_keeping")}
LANE_KEEPING = {name: model for name, model in sections().items()
                if name.startswith("lane_keeping")}
_MARKED = re.compile(r"(<!-- reference:(\w+) -->\n)(.*?)(<!-- /reference -->)", re.S)


def _value(value) -> str:
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
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _rows(model: type[BaseModel], section: str | None) -> list[str]:
    rows = []
    for name, field in model.model_fields.items():
        if (field.description is None or isinstance(field.default, BaseModel)
                or field.exclude):
            continue  # a section (listed by its own keys), or set by a command, not a file
        key = f"[{section}] {name}" if section else name
        rows.append(f"| `{key}` | `{_value(field.default)}` | {field.description} |")
    return rows


def tables() -> dict[str, str]:
    """Each marked table of the reference: ``scenario`` and ``lane_keeping``."""
    head = ["| key | default | meaning |", "|---|---|---|"]
    scenario = _rows(Scenario, None)
    for section, model in SECTIONS.items():
        scenario += _rows(model, section)
    lane_keeping = [row for section, model in LANE_KEEPING.items()
                    for row in _rows(model, section)]
    return {"scenario": "\n".join(head + scenario) + "\n",
            "lane_keeping": "\n".join(head + lane_keeping) + "\n"}


def undocumented() -> list[str]:
    """Fields of the schema without a description (each must have one)."""
    missing = [f"{name}" for name, f in Scenario.model_fields.items()
               if f.description is None and not f.exclude
               and name not in (*SECTIONS, *LANE_KEEPING)]
    for section, model in {**SECTIONS, **LANE_KEEPING}.items():
        missing += [f"{section}.{name}" for name, f in model.model_fields.items()
                    if f.description is None]
    return missing


def rewritten(text: str) -> str:
    """``text`` (docs/scenarios.md) with its marked tables written afresh."""
    generated = tables()
    return _MARKED.sub(lambda m: m[1] + generated[m[2]] + m[4], text)


if __name__ == "__main__":
    DOCUMENT.write_text(rewritten(DOCUMENT.read_text()))
    print(f"wrote {DOCUMENT}", file=sys.stderr)
