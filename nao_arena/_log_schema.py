"""The episode log's file format: its name and version, the metadata keys, the decision
statuses and the Arrow schema of its rows (see :mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import pyarrow as pa

LOG_FORMAT = "nao-arena episode log"
LOG_VERSION = 1
META_KEY = b"nao_arena.episode_log"
META_SHA_KEY = b"nao_arena.episode_log.sha256"

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
