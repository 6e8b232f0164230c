"""The episode log's file format: its name and version, the metadata keys, the decision
statuses and the Arrow schema of its rows (see :mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import hashlib

import numpy as np
import pyarrow as pa

LOG_FORMAT = "nao-arena episode log"
LOG_VERSION = 1
META_KEY = b"nao_arena.episode_log"
META_SHA_KEY = b"nao_arena.episode_log.sha256"
CONTENT_KEY = "content_sha256"
"""The metadata's entry holding :func:`table_digest` of the rows (the metadata are covered
by their own checksum, so the rows' digest cannot be changed unnoticed either)."""

STATUSES: tuple[str, ...] = (
    "desired",
    "kept",
    "repaired",
    "adjusted",
    "infeasible",
    "fault",
    "external",
    "yielded",
)
"""Decision statuses, in the order of the codes of :attr:`EpisodeLog.status`."""
SELECTIONS: tuple[str, ...] = ("desired", "adjusted", "infeasible", "yielded")
"""Statuses of a full selection (:attr:`EpisodeLog.selection` codes)."""

_CODE = {s: i for i, s in enumerate(STATUSES)}
_SEL_CODE = {s: i for i, s in enumerate(SELECTIONS)}
_FLOATS = ("x", "y", "vx", "vy", "ax", "ay", "cmd_x", "cmd_y")
_SCHEMA = pa.schema(
    [
        pa.field("step", pa.int32(), nullable=False),
        pa.field("time", pa.float64(), nullable=False),
        pa.field("body", pa.int16(), nullable=False),
        *[pa.field(name, pa.float64(), nullable=False) for name in _FLOATS],
        pa.field("reached", pa.bool_(), nullable=False),
        pa.field("status", pa.dictionary(pa.int8(), pa.string())),
        pa.field("selection", pa.dictionary(pa.int8(), pa.string())),
        pa.field("detour", pa.float64()),
        pa.field("neighbours", pa.list_(pa.int32())),
    ]
)


class LogError(ValueError):
    """An episode log cannot be read: missing, truncated, corrupt, or another format version."""


def table_digest(table: pa.Table) -> str:
    """SHA-256 (hex) of the values of ``table``'s columns, in schema order: per column its
    name, which entries are null and the values (dictionary columns decoded to their
    strings, lists as their offsets and values), so that a table written and read back
    has the digest it was written with, whatever Parquet's encoding of it."""
    digest = hashlib.sha256()
    for name in table.column_names:
        digest.update(name.encode("utf-8") + b"\0")
        _column_digest(digest, table.column(name).combine_chunks())
    return digest.hexdigest()


def _column_digest(digest: hashlib._Hash, column: pa.Array) -> None:
    if pa.types.is_dictionary(column.type):
        column = column.cast(column.type.value_type)
    digest.update(_type_name(column.type).encode("utf-8") + b"\0")
    digest.update(np.asarray(column.is_valid()).tobytes())
    if pa.types.is_list(column.type):
        digest.update(np.asarray(column.offsets, dtype=np.int64).tobytes())
        _column_digest(digest, column.values)
    elif pa.types.is_string(column.type):
        texts = column.fill_null("").to_pylist()
        digest.update("\0".join(texts).encode("utf-8"))
    else:
        filled = column.fill_null(pa.scalar(0, column.type)) if column.null_count else column
        digest.update(np.ascontiguousarray(filled.to_numpy(zero_copy_only=False)).tobytes())


def _type_name(kind: pa.DataType) -> str:
    """A column type's name without its list field's name (Parquet renames it)."""
    if pa.types.is_list(kind):
        return f"list<{_type_name(kind.value_type)}>"
    return str(kind)
