"""Atomic file writing (nao_arena.atomic): the one place that replaces files."""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nao_arena import atomic
from nao_arena.atomic import atomic_write_text, atomic_write_with

PACKAGE = Path(atomic.__file__).parent


@settings(max_examples=30, deadline=None)
@given(text=st.text())
def test_text_round_trips_exactly(tmp_path_factory: pytest.TempPathFactory, text: str) -> None:
    folder = tmp_path_factory.mktemp("text")
    path = folder / "out.txt"
    path.write_text("old")
    atomic_write_text(path, text)
    assert path.read_bytes() == text.encode("utf-8")  # newlines as given, no translation
    assert [p.name for p in folder.iterdir()] == ["out.txt"]


def test_new_file_has_ordinary_permissions_and_folder_is_created(tmp_path: Path) -> None:
    path = tmp_path / "new" / "folder" / "a.json"
    atomic_write_text(path, "{}\n")
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~umask
    assert path.read_text() == "{}\n"


def test_failed_write_leaves_destination_and_no_temporary(tmp_path: Path) -> None:
    path = tmp_path / "table.parquet"
    path.write_text("previous")

    def write(tmp: str) -> None:
        assert tmp.endswith(".tmp.parquet") and Path(tmp).parent == tmp_path
        Path(tmp).write_text("partial")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        atomic_write_with(path, write, suffix=".tmp.parquet")
    assert path.read_text() == "previous"
    assert [p.name for p in tmp_path.iterdir()] == ["table.parquet"]


def test_data_reach_the_disk_before_the_replace(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    events: list[str] = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: (events.append("fsync"), real_fsync(fd))[1])
    monkeypatch.setattr(
        os, "replace", lambda a, b: (events.append("replace"), real_replace(a, b))[1]
    )
    atomic_write_text(tmp_path / "x.txt", "data")
    assert events[:2] == ["fsync", "replace"]


def test_figures_leave_no_temporary_on_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from matplotlib.figure import Figure

    from nao_arena import figures

    def broken_savefig(self: Figure, fname: str, **kwargs: object) -> None:
        Path(fname).write_bytes(b"\x89PNG partial")
        raise OSError("disk full")

    monkeypatch.setitem(figures.FIGURES, "blank", lambda ax: "")
    monkeypatch.setattr(Figure, "savefig", broken_savefig)
    with pytest.raises(OSError, match="disk full"):
        figures.write_figures(tmp_path, ["blank"])
    assert list(tmp_path.iterdir()) == []


def test_no_other_module_replaces_files() -> None:
    """Every file nao_arena writes in place goes through nao_arena.atomic (a temporary
    folder, as the kernels' manifest recording uses, is no file written in place)."""
    pattern = re.compile(
        r"os\.replace\(|\.replace\(tmp|tempfile\.(?!TemporaryDirectory|mkdtemp)"
        r"|mkstemp\(|\.tmp\""
    )
    offenders = [
        str(p.relative_to(PACKAGE))
        for p in sorted(PACKAGE.rglob("*.py"))
        if p.name != "atomic.py" and pattern.search(p.read_text(encoding="utf-8"))
    ]
    assert offenders == []
