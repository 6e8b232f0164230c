"""Atomic file writing: a temporary file in the destination's folder, flushed to
disk (fsync), then moved onto the destination with ``os.replace``.

A reader sees either the old file or the complete new one, never a partial
write; on an error the temporary file is removed and the destination is left
untouched. The new file gets the permissions an ordinary new file gets
(0666 minus the umask). Every output file of nao_arena (results, logs, figures,
recordings) goes through this module; only a trial folder's lock file does not.
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = [
    "atomic_write_text",
    "atomic_write_with",
    "replace_synced",
    "remove_stale",
    "temporary_sibling",
]


def temporary_sibling(path: str | Path, suffix: str = ".tmp") -> tuple[int, str]:
    """(fd, name) of a new temporary file next to ``path`` (its folder is created if
    missing) with the permissions an ordinary new file gets (mkstemp's 0600 widened to
    0666 minus the umask). The caller owns the descriptor.

    Its name, ``.<name>.<pid>.<random><suffix>``, holds the writing process's id: the
    temporary files of ``path`` left by a process that was killed before it could remove
    them are removed first (see :func:`remove_stale`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale(path)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{path.name}.{os.getpid()}.", suffix=suffix, dir=path.parent
    )
    umask = os.umask(0o022)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return fd, tmp


def remove_stale(path: str | Path) -> list[Path]:
    """Remove the temporary files of ``path`` (see :func:`temporary_sibling`) whose writing
    process has ended (e.g. it was killed during a long write); returns them."""
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.")
    removed: list[Path] = []
    try:
        entries = list(path.parent.iterdir()) if path.parent.is_dir() else []
    except OSError:
        return removed
    for entry in entries:
        match = pattern.match(entry.name)
        if match is None or _alive(int(match.group(1))):
            continue
        try:
            entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    return removed


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (one that is not ours to signal counts)."""
    if pid == os.getpid() or os.name == "nt":  # Windows: os.kill would end it
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    try:  # Linux: a zombie (ended, not yet reaped) has ended
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True
    return state not in ("Z", "X")


def _fsync_file(name: str | Path) -> None:
    # Windows flushes only through a descriptor opened for writing
    fd = os.open(name, os.O_RDWR if os.name == "nt" else os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    """Make a rename in folder durable where the system allows it (POSIX); some file
    systems refuse to sync a folder, which only loses durability, not data."""
    if os.name == "nt":
        return
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def replace_synced(tmp: str | Path, path: str | Path) -> None:
    """Flush the finished temporary file ``tmp`` to disk and move it onto ``path``."""
    _fsync_file(tmp)
    os.replace(tmp, path)
    _fsync_folder(Path(path).parent)


def atomic_write_with(path: str | Path, write: Callable[[str], None], suffix: str = ".tmp") -> None:
    """Call ``write(tmp)`` for a temporary name next to ``path`` (ending in ``suffix``,
    for writers that go by the file name), then move the file onto ``path``."""
    fd, tmp = temporary_sibling(path, suffix=suffix)
    os.close(fd)
    try:
        write(tmp)
        replace_synced(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write text (UTF-8, newlines as given) to ``path`` atomically."""

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)

    atomic_write_with(path, write)
