"""The documentation: the site builds without a warning, its examples run, its commands
parse.

- The site (``mkdocs.yml``, pages in ``docs/``) builds with ``mkdocs build --strict``:
  a broken link or anchor, a page missing from the navigation or a docstring
  mkdocstrings cannot read fails the build. Without mkdocs (the ``docs`` extra:
  ``pip install ".[docs]"``) that test skips, unless ``NAO_ARENA_REQUIRE_DOCS=1``.
- Every ```` ```python ```` block of the pages and of README.md runs, each in a fresh
  Python process from an empty temporary folder, headless (``MPLBACKEND=Agg``,
  ``SDL_VIDEODRIVER=dummy``), within 120 s. The convention: a block whose first line is
  ``# no-run: REASON`` is only compiled, not run (it needs a display, a file of its
  own, a long run ...); the reason is required.
- Every ``nao-arena ...`` command shown in a ```` ```bash ````, ```` ```console ```` or
  ```` ```sh ```` block (and every ``$ nao-arena ...`` line of a ```` ```text ```` block)
  parses with the program's own parser, ``nao_arena.cli.build_parser()``; a command that
  is elided (``nao-arena trial ... --backend ray``), piped or built from shell variables
  is listed with its reason instead (``SKIPPED``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import io
import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from nao_arena.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md"] + sorted(p for p in DOCS.rglob("*.md") if "_hooks" not in p.parts)
TIMEOUT = 120  # s, per Python block
NO_RUN = "# no-run"
SHELL = ("bash", "console", "sh", "shell")

_FENCE = re.compile(r"^```([\w+-]*)[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)


@dataclass(frozen=True)
class Block:
    page: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def _blocks(lang: tuple[str, ...]) -> list[Block]:
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in _FENCE.finditer(text):
            if m.group(1) in lang:
                line = text.count("\n", 0, m.start()) + 1
                found.append(Block(page, line, m.group(1), m.group(2)))
    return found


PYTHON = _blocks(("python", "py"))
RUNNABLE = [b for b in PYTHON if not b.code.lstrip().startswith(NO_RUN)]


# --------------------------------------------------------------------------- the site


def _missing_docs_tools() -> list[str]:
    return [
        m for m in ("mkdocs", "material", "mkdocstrings") if importlib.util.find_spec(m) is None
    ]


@pytest.mark.slow
def test_the_site_builds_strict(tmp_path):
    missing = _missing_docs_tools()
    if missing:
        message = (
            f"the docs tools are not installed ({', '.join(missing)}): "
            'pip install ".[docs]" to build the site'
        )
        if os.environ.get("NAO_ARENA_REQUIRE_DOCS") == "1":
            pytest.fail(message + " (NAO_ARENA_REQUIRE_DOCS=1)")
        pytest.skip(message)
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-5000:]
    assert "WARNING" not in proc.stderr, proc.stderr[-5000:]
    # the generated reference pages hold what the code defines
    cli = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for command in _subcommands():
        assert f'id="nao-arena-{command}"' in cli, command
    assert "--csv" in cli and "--episode-timeout" in cli
    schema = (site / "reference" / "map-schema" / "index.html").read_text(encoding="utf-8")
    assert "goal_tolerance" in schema and "max_neighbours" in schema
    columns = (site / "reference" / "results-columns" / "index.html").read_text(encoding="utf-8")
    assert "deadlocks: episodes with a time at which" in columns  # the trial table's legend
    api = (site / "reference" / "api" / "nao_arena" / "index.html").read_text(encoding="utf-8")
    import nao_arena

    for name in nao_arena.__all__:
        if not name.startswith("_"):
            assert f'id="nao_arena.{name}"' in api, name
    assert ":class:" not in api  # Sphinx roles are turned into Markdown
    options = (site / "reference" / "options" / "index.html").read_text(encoding="utf-8")
    for name in ("agent_names", "max_faults", "ttc_horizon", "accel_change"):
        assert f"<code>{name}</code>" in options, name


def _generator():
    """The docs build's hook module (docs/_hooks/generate.py), imported from its file."""
    spec = importlib.util.spec_from_file_location("_docs_generate", DOCS / "_hooks" / "generate.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_option_field_is_documented_under_its_field():
    generate = _generator()
    for ref in generate.OPTION_CLASSES:
        cls = generate._option_class(ref)
        docs = generate.field_docs(cls)
        missing = [f.name for f in dataclasses.fields(cls) if not docs.get(f.name)]
        assert not missing, f"{ref}: fields without a docstring under them: {missing}"
    table = generate.options_reference()
    for ref in generate.OPTION_CLASSES:
        for f in dataclasses.fields(generate._option_class(ref)):
            assert f"| `{f.name}` |" in table, f.name


def test_field_docs_reads_only_docstrings_under_fields():
    generate = _generator()

    @dataclasses.dataclass
    class Example:
        """Not a field's."""

        documented: int = 1
        """Its meaning, in m."""
        bare: float = 2.0
        after_bare: str = "x"
        """Two
        lines."""

    assert generate.field_docs(Example) == {
        "documented": "Its meaning, in m.",
        "after_bare": "Two lines.",
    }


def _subcommands() -> list[str]:
    import argparse

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return list(sub.choices)


def test_the_readme_links_to_pages_that_exist():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(((?!https?:|#)[^)\s]+)\)", text)
    assert any(link.startswith("docs/") for link in links)
    for link in links:
        assert (ROOT / link.split("#", 1)[0]).exists(), link


def test_the_readme_stays_short_and_keeps_its_quick_start():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    # .ci/run runs the second command of this block
    section = re.search(r"^## Quick start\n(.*?)^#", text + "\n#", re.M | re.S).group(1)
    block = re.search(r"```[a-z]*\n(.*?)```", section, re.S).group(1)
    assert block.splitlines()[:2] == [
        "pip install . && nao-arena run roundabout",
        'pip install ".[test]" && pytest -q -n auto',
    ]


# --------------------------------------------------------------------------- Python


def test_python_blocks_compile_and_every_no_run_says_why():
    assert RUNNABLE, "no runnable Python block found"
    for block in PYTHON:
        compile(block.code, block.where, "exec")
        first = block.code.lstrip().splitlines()[0]
        if first.startswith(NO_RUN):
            assert re.match(r"# no-run: \S", first), f"{block.where}: '# no-run: REASON'"


def _headless_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(MPLBACKEND="Agg", SDL_VIDEODRIVER="dummy", SDL_AUDIODRIVER="dummy")
    env.pop("PYTHONPATH", None)  # the installed nao_arena, as a reader's would be
    return env


@pytest.mark.slow
@pytest.mark.installed
@pytest.mark.parametrize("block", RUNNABLE, ids=[b.where for b in RUNNABLE])
def test_python_block_runs(block, tmp_path):
    script = tmp_path / "block.py"
    script.write_text(block.code, encoding="utf-8")
    try:
        proc = subprocess.run(
            [sys.executable, str(script)],
            cwd=tmp_path,
            env=_headless_env(),
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{block.where}: ran longer than {TIMEOUT} s (mark it '# no-run: ...')")
    assert proc.returncode == 0, f"{block.where}:\n{proc.stderr[-4000:]}"


# --------------------------------------------------------------------------- commands


SKIPPED: dict[str, str] = {
    "...": "elided: stands for the options of the command above",
    "|": "a shell pipe",
    "$": "built from shell variables",
}
"""What makes a shown command not a literal command line -> why it is not parsed."""


def _shell_lines(block: Block) -> list[str]:
    """The command lines of a block: continuations joined; in a console or text block,
    only the lines after a ``$`` prompt."""
    text = re.sub(r"\\\n\s*", " ", block.code)
    lines = text.splitlines()
    if block.lang in ("console", "text"):
        lines = [ln.strip()[2:] for ln in lines if ln.strip().startswith("$ ")]
    return [ln.strip() for ln in lines if ln.strip()]


def _commands() -> tuple[list[tuple[str, list[str]]], list[tuple[str, str, str]]]:
    """(where, argv) of every `nao-arena` command shown, and (where, command, reason) of
    those not parsed."""
    parsed, skipped = [], []
    for block in _blocks(SHELL + ("text",)):
        for line in _shell_lines(block):
            tokens = shlex.split(line, comments=True)
            command: list[str] = []
            for token in [*tokens, "&&"]:
                if token in ("&&", "||", ";"):
                    if command and command[0] == "nao-arena":
                        text = shlex.join(command)
                        reason = next(
                            (why for mark, why in SKIPPED.items() if _has(command, mark)), None
                        )
                        if reason:
                            skipped.append((block.where, text, reason))
                        else:
                            parsed.append((f"{block.where} {text}", command[1:]))
                    command = []
                else:
                    command.append(token)
    return parsed, skipped


def _has(command: list[str], mark: str) -> bool:
    if mark == "...":
        return "..." in command
    return any(mark in token for token in command)


COMMANDS, NOT_PARSED = _commands()


def test_commands_are_found_and_every_skip_has_a_reason():
    assert len(COMMANDS) >= 30, COMMANDS
    # the ones not parsed, and why (a new one shows up here)
    assert {why for _, _, why in NOT_PARSED} <= set(SKIPPED.values())
    assert all("nao-arena trial ..." in cmd for _, cmd, _ in NOT_PARSED), NOT_PARSED


@pytest.mark.parametrize("argv", [a for _, a in COMMANDS], ids=[w for w, _ in COMMANDS])
def test_command_parses(argv):
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            args = build_parser().parse_args(argv)
    except SystemExit as exc:
        assert exc.code == 0 and argv == ["--version"], err.getvalue()
        return
    if args.command == "run" and not args.map.endswith((".yaml", ".yml")):
        from nao_arena.maps import available_maps

        assert args.map in available_maps(), args.map
