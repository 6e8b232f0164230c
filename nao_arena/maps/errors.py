"""Map errors: :class:`MapError` and its one-line messages, each naming the file, the
field path and what was expected (from pydantic's validation errors or the loader's own
checks)."""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Union

from pydantic import BaseModel, ValidationError

__all__ = ["MapError", "field_error", "show_value", "validation_error"]


class MapError(ValueError):
    """A map file that cannot be loaded: the message names file, field path and expectation."""


_TAGS = frozenset({"segment", "polygon", "circle", "polyline", "lane_group", "recorded"})
_UNTYPED = "lane_group"
"""The tag of a tagged union member written without a ``type`` key (a traffic lane group)."""


def _render_path(loc: Sequence[Any], data: Any) -> str:
    """``robots[2].radius`` from a pydantic loc, dropping union tags, following the data."""
    out = ""
    node = data
    for el in loc:
        if isinstance(el, int):
            out += f"[{el}]"
            node = node[el] if isinstance(node, list) and -len(node) <= el < len(node) else None
        elif isinstance(node, dict) and el in node:
            out += f".{el}"
            node = node[el]
        elif isinstance(node, dict) and el in _TAGS and node.get("type", _UNTYPED) == el:
            continue
        else:
            out += f".{el}"
            node = None
    return out.lstrip(".") or "(top level)"


def show_value(x: Any) -> str:
    """A value as a message shows it: YAML booleans, %g numbers, short reprs."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int | float):
        return f"{x:g}" if isinstance(x, float) else str(x)
    text = repr(x)
    return text if len(text) <= 60 else text[:57] + "..."


def _allowed_keys(model: Any, loc: Sequence[Any]) -> list[str] | None:
    """Field names of the model reached by loc (None if it cannot be resolved)."""
    tp: Any = model
    for el in loc:
        tp = _strip(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if el not in tp.model_fields:
                return None
            tp = tp.model_fields[el].annotation
            continue
        origin, targs = typing.get_origin(tp), typing.get_args(tp)
        if origin in (list, tuple) and isinstance(el, int):
            tp = targs[0]
        elif origin is dict:
            tp = targs[1]
        elif origin in (Union, types.UnionType):
            match = [
                t
                for t in targs
                if isinstance(t, type)
                and issubclass(t, BaseModel)
                and "type" in t.model_fields
                and typing.get_args(t.model_fields["type"].annotation) == (el,)
            ]
            if not match:
                return None
            tp = match[0]
        else:
            return None
    tp = _strip(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return list(tp.model_fields)
    return None


def _strip(tp: Any) -> Any:
    while typing.get_origin(tp) is Annotated:
        tp = typing.get_args(tp)[0]
    if typing.get_origin(tp) in (Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return _strip(args[0])
    return tp


def _expectation(err: Mapping[str, Any], model: Any) -> str:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    got = f", got {show_value(err.get('input'))}"
    if kind == "missing":
        return "required field missing"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(model, err["loc"][:-1])
        hint = f"; expected one of: {', '.join(allowed)}" if allowed else ""
        return f"unknown key{hint}"
    if kind == "greater_than":
        return (
            "expected a positive number"
            if ctx.get("gt") == 0
            else f"expected a number greater than {ctx.get('gt')}"
        ) + got
    if kind == "greater_than_equal":
        return (
            "expected a non-negative number"
            if ctx.get("ge") == 0
            else f"expected a number >= {ctx.get('ge')}"
        ) + got
    if kind in ("less_than_equal", "less_than"):
        return f"expected a number <= {ctx.get('le', ctx.get('lt'))}" + got
    if kind in ("float_type", "float_parsing"):
        return "expected a number" + got
    if kind == "finite_number":
        return "expected a finite number" + got
    if kind in ("int_type", "int_parsing", "int_from_float"):
        return "expected an integer" + got
    if kind in ("bool_type", "bool_parsing"):
        return "expected true or false" + got
    if kind == "string_type":
        return "expected a string" + got
    if kind == "literal_error":
        return f"expected {ctx.get('expected')}" + got
    if kind in ("list_type", "tuple_type"):
        return "expected a list" + got
    if kind == "too_short":
        return f"expected at least {ctx.get('min_length')} items" + got
    if kind == "too_long":
        return f"expected at most {ctx.get('max_length')} items" + got
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return "expected a mapping" + got
    if kind == "union_tag_invalid":
        return f"expected type to be one of {ctx.get('expected_tags')}, got {ctx.get('tag')!r}"
    if kind == "union_tag_not_found":
        return f"expected a 'type' key ({ctx.get('expected_tags', 'see the map format')})"
    if kind in ("value_error", "assertion_error"):
        return str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    return str(err["msg"]) + got


def validation_error(
    file: str, exc: ValidationError, data: Any, model: Any, prefix: str = ""
) -> MapError:
    """One line per error of ``exc`` (validating ``data`` against ``model``), the field
    paths following the data and starting with ``prefix``."""
    lines = []
    for err in exc.errors(include_url=False):
        loc = err["loc"]
        if err["type"] == "missing" and loc and isinstance(loc[-1], int):
            # a point given with too few coordinates: name the point, not the coordinate
            err = {**err, "type": "too_short", "ctx": {"min_length": loc[-1] + 1}}
            loc = loc[:-1]
        path = _render_path(loc, data)
        full = path if not prefix else (prefix if path == "(top level)" else f"{prefix}.{path}")
        lines.append(f"{file}: {full}: {_expectation(err, model)}")
    return MapError("\n".join(lines))


def field_error(file: str, path: str, what: str) -> MapError:
    """``<file>: <path>: <what>``."""
    return MapError(f"{file}: {path}: {what}")
