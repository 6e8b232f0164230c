"""The map file format as plain text (what ``nao-arena maps --schema`` prints): the
description in :mod:`nao_arena.maps`' docstring, then every field with its type and
default, generated from the schema's models."""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

from nao_arena.maps.errors import show_value
from nao_arena.maps.layouts import LAYOUTS
from nao_arena.maps.schema import (
    Actuation,
    Bounds,
    CircleLaneSpec,
    CommunicationSpec,
    Episode,
    LayoutSpec,
    MapFile,
    Physics,
    PolygonWall,
    PolylineLaneSpec,
    RecordedPeople,
    RobotSpec,
    RobotTemplate,
    SegmentWall,
    Sensing,
    SensingNoise,
    TrafficGroup,
)

__all__ = ["format_reference", "sections"]


def sections() -> list[tuple[str, type[BaseModel]]]:
    """(where in a map file, model) of every part of the format, in reading order."""
    return [
        ("top level", MapFile),
        ("bounds", Bounds),
        ("walls[] with type: segment", SegmentWall),
        ("walls[] with type: polygon", PolygonWall),
        ("robots[]", RobotSpec),
        ("layouts[]", LayoutSpec),
        ("layouts[].robot", RobotTemplate),
        *[
            (f"layouts[].args with builder: {name}", model)
            for name, (model, _) in sorted(LAYOUTS.items())
        ],
        ("traffic[]", TrafficGroup),
        ("traffic[] with type: recorded", RecordedPeople),
        ("traffic[].lane with type: circle", CircleLaneSpec),
        ("traffic[].lane with type: polyline", PolylineLaneSpec),
        ("physics", Physics),
        ("episode", Episode),
        ("sensing", Sensing),
        ("sensing.noise", SensingNoise),
        ("actuation", Actuation),
        ("communication", CommunicationSpec),
    ]


def _kind(prop: Mapping[str, Any]) -> str:
    """A JSON-schema property as a short type text, e.g. ``number > 0`` or ``[x, y]``."""
    if "anyOf" in prop:
        return " or ".join(_kind(p) for p in prop["anyOf"] if p.get("type") != "null")
    if "oneOf" in prop:
        if "discriminator" not in prop:  # a lane group, or type: recorded
            return "mapping (a lane group, or type: recorded)"
        return f"mapping (type: {'|'.join(prop['discriminator']['mapping'])})"
    if "$ref" in prop:
        return "mapping"
    if "const" in prop:
        return str(prop["const"])
    if "enum" in prop:
        return "|".join(map(str, prop["enum"]))
    kind = prop.get("type")
    if kind == "array":
        if "prefixItems" in prop:
            return "[x, y]"
        text = f"list of {_kind(prop.get('items', {}))}"
        return text + (f" (>= {prop['minItems']})" if "minItems" in prop else "")
    if kind == "object":
        return "mapping"
    if kind in ("number", "integer"):
        limits = [
            f"{op} {prop[key]}"
            for key, op in (
                ("gt", ">"),
                ("exclusiveMinimum", ">"),
                ("ge", ">="),
                ("minimum", ">="),
                ("lt", "<"),
                ("exclusiveMaximum", "<"),
                ("le", "<="),
                ("maximum", "<="),
            )
            if key in prop
        ]
        return " ".join([kind, ", ".join(limits)]).strip()
    return {"boolean": "true|false", "string": "string"}.get(str(kind), str(kind))


def _default(model: type[BaseModel], name: str) -> str:
    info = model.model_fields[name]
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if value is None:
        return "optional"
    if isinstance(value, BaseModel):
        return "section below"
    if isinstance(value, bool | float | int):
        return show_value(value)
    return json.dumps(value)


def _field_tables() -> str:
    """Every field of the format: name, type and default, from the models themselves."""
    out = []
    for where, model in sections():
        props = model.model_json_schema()["properties"]
        rows = [(name, _kind(props[name]), _default(model, name)) for name in model.model_fields]
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        out += ["", where]
        out += [f"  {a.ljust(w0)}  {b.ljust(w1)}  {c}".rstrip() for a, b, c in rows]
    return "\n".join(out)


def format_reference() -> str:
    """The map file format as plain text: the description of :mod:`nao_arena.maps`' docstring,
    then every field with its type and default, generated from the schema's models (what
    ``nao-arena maps --schema`` prints)."""
    from nao_arena import maps

    prose = (maps.__doc__ or "").split("\n\n", 1)[1]
    prose = re.sub(r":\w+:`~?([^`]+)`", r"\1", prose).replace("``", "`")
    head = "Every field (generated from the schema; optional: absent or null, see above)"
    return "\n".join(
        [
            "nao-arena map files",
            "===================",
            "",
            prose.strip(),
            "",
            head,
            "-" * len(head) + _field_tables(),
        ]
    )
