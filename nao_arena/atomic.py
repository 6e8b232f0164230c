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
import tempfile
from collections.abc import Callable
from pathlib import Path

__all__ = [
    "atomic_write_text",
    "atomic_write_with",
    "replace_synced",
    "temporary_sibling",
]


def temporary_sibling(path: str | Path, suffix: str = ".tmp") -> tuple[int, str]:
    """(fd, name) of a new temporary file next to ``path`` (its folder is created if
    missing) with the permissions an ordinary new file gets (mkstemp's 0600 widened to
    0666 minus the umask). The caller owns the descriptor."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    umask = os.umask(0o022)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return fd, tmp


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


def atomic_write_with(path: str | Path, write: Callable[[str], None],
                      suffix: str = ".tmp") -> None:
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
