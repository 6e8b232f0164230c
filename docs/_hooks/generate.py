"""mkdocs hook: the reference parts of the docs that are generated from the code at build
time, so that they cannot drift from it.

A page asks for a part with a marker line of its own, e.g. ``<!-- generated: cli -->``:

- ``cli``: every ``nao-arena`` command, from the argparse parser
  (``nao_arena.cli.build_parser()``): usage, arguments and options, defaults, choices;
- ``map-schema``: the map file format (``nao_arena.maps.format_reference()``, what
  ``nao-arena maps --schema`` prints);
- ``trial-legend``: the legend ``nao-arena trial`` prints under its table
  (``nao_arena.trials.TABLE_LEGEND``, and ``PEOPLE_LEGEND`` on maps with people);
- ``options``: every field of the settings dataclasses (:data:`OPTION_CLASSES`: the env's,
  its rewards', the control loop's and the statistics'), its type, default and meaning,
  from the docstring written under each field (:func:`field_docs`).

The hook imports nao_arena from the checkout that holds mkdocs.yml (put first on
``sys.path``), so the site documents the source it is built from.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import re
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

MARKER = re.compile(r"^<!-- generated: ([a-z-]+) -->$", re.M)


def on_config(config: Any) -> Any:
    root = str(Path(config.config_file_path).resolve().parent)
    if root not in sys.path:
        sys.path.insert(0, root)
    return config


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    def part(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in PARTS:
            raise ValueError(f"{page.file.src_uri}: unknown generated part {name!r}")
        return PARTS[name]()

    return MARKER.sub(part, markdown)


# --------------------------------------------------------------------------- the CLI


def _cell(text: str) -> str:
    """Text for one cell of a Markdown table."""
    return " ".join(text.split()).replace("|", "\\|")


def _help(action: argparse.Action, prog: str) -> str:
    text = action.help or ""
    if "%" in text:
        text = text % {**vars(action), "prog": prog}
    return text


def _value(action: argparse.Action) -> str:
    """What the option takes: its metavar, its choices, or nothing (a flag)."""
    if action.nargs == 0:
        return ""
    if action.choices is not None:
        shown = "{" + ",".join(str(c) for c in action.choices) + "}"
    elif action.metavar is not None:
        shown = str(action.metavar)
    else:
        shown = action.dest.upper()
    if action.nargs == "?":
        shown = f"[{shown}]"
    elif action.nargs == "+":
        shown = f"{shown} [{shown} ...]"
    return f"`{shown}`"


def _default(action: argparse.Action) -> str:
    if action.required or action.nargs == 0 or action.default in (None, argparse.SUPPRESS):
        return "required" if action.required and action.option_strings else ""
    if isinstance(action.default, str) and action.default == "":
        return '`""`'
    return f"`{action.default}`"


def _usage(parser: argparse.ArgumentParser) -> str:
    formatter = argparse.HelpFormatter(parser.prog, width=88)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups)
    return formatter.format_help().strip()


def _command(name: str, parser: argparse.ArgumentParser, summary: str) -> str:
    lines = [f"## `nao-arena {name}`", "", f"{summary[:1].upper()}{summary[1:]}.", ""]
    lines += ["```text", _usage(parser), "```", ""]
    positional = [a for a in parser._actions if not a.option_strings]
    options = [
        a for a in parser._actions if a.option_strings and not isinstance(a, argparse._HelpAction)
    ]
    if positional:
        lines += ["| argument | meaning |", "| --- | --- |"]
        lines += [f"| `{a.dest}` | {_cell(_help(a, parser.prog))} |" for a in positional]
        lines.append("")
    if options:
        lines += ["| option | value | default | meaning |", "| --- | --- | --- | --- |"]
        for a in options:
            flags = ", ".join(f"`{s}`" for s in a.option_strings)
            lines.append(
                f"| {flags} | {_value(a)} | {_default(a)} | {_cell(_help(a, parser.prog))} |"
            )
        lines.append("")
    return "\n".join(lines)


def cli_reference() -> str:
    from nao_arena.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    helps = {choice.dest: choice.help or "" for choice in sub._choices_actions}
    top = [
        "```text",
        _usage(parser),
        "```",
        "",
        "| option | meaning |",
        "| --- | --- |",
    ]
    for a in parser._actions:
        if a.option_strings:
            flags = ", ".join(f"`{s}`" for s in a.option_strings)
            top.append(f"| {flags} | {_cell(_help(a, parser.prog))} |")
    top += ["", "| command | what it does |", "| --- | --- |"]
    top += [f"| [`{n}`](#nao-arena-{n}) | {_cell(helps.get(n, ''))} |" for n in sub.choices]
    parts = ["\n".join(top)]
    parts += [_command(n, p, helps.get(n, "")) for n, p in sub.choices.items()]
    return "\n\n".join(parts)


# --------------------------------------------------------------------------- the rest


def map_schema() -> str:
    from nao_arena.maps import format_reference

    return "```text\n" + format_reference().rstrip("\n") + "\n```"


def trial_legend() -> str:
    from nao_arena.trials.table import PEOPLE_LEGEND, TABLE_LEGEND

    return "```text\n" + TABLE_LEGEND.rstrip("\n") + "\n" + PEOPLE_LEGEND + "\n```"


OPTION_CLASSES = (
    "nao_arena.environment:EnvOptions",
    "nao_arena.environment:RewardWeights",
    "nao_arena.arena:ArenaOptions",
    "nao_arena.stats:StatsConfig",
)
"""The settings dataclasses the ``options`` part documents, as ``module:Class``."""


def field_docs(cls: type) -> dict[str, str]:
    """The docstring written under each field of the dataclass ``cls`` (field name -> text
    on one line); a field without one is missing from the result."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    docs = {}
    for stmt, after in zip(body, body[1:], strict=False):
        if (
            isinstance(stmt, ast.AnnAssign)
            and isinstance(stmt.target, ast.Name)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)
        ):
            docs[stmt.target.id] = " ".join(after.value.value.split())
    return docs


def _option_class(ref: str) -> type:
    import importlib

    module, name = ref.split(":")
    return getattr(importlib.import_module(module), name)  # type: ignore[no-any-return]


def _field_default(f: dataclasses.Field[Any]) -> str:
    if f.default is not dataclasses.MISSING:
        return f"`{f.default!r}`"
    if f.default_factory is not dataclasses.MISSING:
        made = f.default_factory()
        return "`{}`" if made == {} else f"`{type(made).__name__}()`"
    return "required"


def _roles(text: str) -> str:
    """Sphinx roles (``:class:`~a.b.C` ``) and reST literals (````x````) as Markdown code."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", lambda m: f"`{m.group(1).split('.')[-1]}`", text)
    return text.replace("``", "`")


def options_reference() -> str:
    parts = []
    for ref in OPTION_CLASSES:
        cls = _option_class(ref)
        docs = field_docs(cls)
        module = ref.split(":")[0]
        summary = _roles(" ".join((cls.__doc__ or "").split()))
        lines = [f"## `{cls.__name__}`", "", f"`{module}.{cls.__name__}`: {summary}", ""]
        lines += ["| field | type | default | meaning |", "| --- | --- | --- | --- |"]
        for f in dataclasses.fields(cls):
            kind = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
            lines.append(
                f"| `{f.name}` | `{_cell(str(kind))}` | {_field_default(f)} | "
                f"{_cell(_roles(docs.get(f.name, '')))} |"
            )
        parts.append("\n".join(lines))
    return "\n\n".join(parts)


PARTS: dict[str, Callable[[], str]] = {
    "cli": cli_reference,
    "map-schema": map_schema,
    "trial-legend": trial_legend,
    "options": options_reference,
}
