"""Writing an episode log: the Parquet file with its metadata (see
:mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import hashlib
import inspect
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from nao_arena._log_data import EpisodeLog
from nao_arena._log_schema import (
    _SCHEMA,
    CONTENT_KEY,
    LOG_FORMAT,
    LOG_VERSION,
    META_KEY,
    META_SHA_KEY,
    SELECTIONS,
    STATUSES,
    table_digest,
)
from nao_arena.atomic import atomic_write_with


def _checksum_options() -> tuple[dict[str, bool], dict[str, bool]]:
    """(write, read) keyword arguments for Parquet page checksums, where pyarrow has them."""
    write = "write_page_checksum" in inspect.signature(pq.write_table).parameters
    read = "page_checksum_verification" in inspect.signature(pq.ParquetFile).parameters
    return (
        {"write_page_checksum": True} if write else {},
        {"page_checksum_verification": True} if read else {},
    )


def _metadata(log: EpisodeLog) -> dict[str, Any]:
    grids: list[list[float]] = []
    for r in log.robots:
        if r.times is not None and r.times.tolist() not in grids:
            grids.append(r.times.tolist())
    return {
        "format": LOG_FORMAT,
        "version": LOG_VERSION,
        "nao_arena": log.written_by,
        "map": log.spec.model_dump(mode="json"),
        "seed": log.seed,
        "run": log.run,
        "options": log.options,
        "time_grids": grids,
        "robots": [
            {
                "name": r.name,
                "body": r.body,
                "agent": r.agent,
                "label": r.label,
                "predictor": r.predictor,
                "times": None if r.times is None else grids.index(r.times.tolist()),
                "margin": r.margin,
                "v_pref": r.v_pref,
                "neighbours": bool(logged),
            }
            for r, logged in zip(log.robots, log.nb_logged, strict=True)
        ],
        "steps": log.n_steps,
        "contact_steps": log.contact_steps.tolist(),
        "fault_steps": log.fault_steps.tolist(),
        "summary": log.summary,
    }


def _dictionary(
    codes: NDArray[np.int8], mask: NDArray[np.bool_], names: Sequence[str]
) -> pa.DictionaryArray:
    indices = pa.array(np.where(mask, 0, codes).astype(np.int8), mask=mask)
    return pa.DictionaryArray.from_arrays(indices, pa.array(list(names), pa.string()))


def to_table(log: EpisodeLog) -> pa.Table:
    """The log's rows as an Arrow table (the file's columns, without its metadata)."""
    n_rows, n, n_robots = log.n_steps, log.n_bodies, len(log.robots)
    robot_of = np.full(n, -1, dtype=np.int64)
    robot_of[log.robot_ids] = np.arange(n_robots)
    is_robot = robot_of >= 0
    # per (row, body): the robot columns spread over the bodies (traffic: masked)
    take = np.where(is_robot, robot_of, 0)
    status = log.status[:, take]
    selection = log.selection[:, take]
    detour = log.detour[:, take]
    traffic = np.broadcast_to(~is_robot, (n_rows, n))
    columns: dict[str, Any] = {
        "step": pa.array(np.repeat(np.arange(n_rows, dtype=np.int32), n)),
        "time": pa.array(np.repeat(log.time, n)),
        "body": pa.array(np.tile(np.arange(n, dtype=np.int16), n_rows)),
    }
    for name, arr, j in (
        ("x", log.positions, 0),
        ("y", log.positions, 1),
        ("vx", log.velocities, 0),
        ("vy", log.velocities, 1),
        ("ax", log.accelerations, 0),
        ("ay", log.accelerations, 1),
        ("cmd_x", log.commanded, 0),
        ("cmd_y", log.commanded, 1),
    ):
        columns[name] = pa.array(np.ascontiguousarray(arr[:, :, j]).ravel())
    columns["reached"] = pa.array(log.reached.ravel())
    columns["status"] = _dictionary(status.ravel(), (traffic | (status < 0)).ravel(), STATUSES)
    columns["selection"] = _dictionary(
        selection.ravel(), (traffic | (selection < 0)).ravel(), SELECTIONS
    )
    columns["detour"] = pa.array(detour.ravel(), mask=(traffic | np.isnan(detour)).ravel())
    # neighbours: the robots' CSR lists spread over the bodies
    counts = np.diff(log.nb_offsets).reshape(n_rows, n_robots)
    has = np.zeros((n_rows, n), dtype=bool)
    has[1:, log.robot_ids] = log.nb_logged[None, :]
    body_counts = np.where(is_robot[None, :], counts[:, take], 0) * has
    offsets = np.zeros(n_rows * n + 1, dtype=np.int32)
    np.cumsum(body_counts.ravel(), out=offsets[1:])
    columns["neighbours"] = pa.ListArray.from_arrays(
        pa.array(offsets),
        pa.array(log.nb_index.astype(np.int32), pa.int32()),
        mask=pa.array(~has.ravel()),
    )
    return pa.Table.from_pydict(columns, schema=_SCHEMA)


def write_log(log: EpisodeLog, path: str | Path) -> Path:
    """Write the log to ``path`` (Parquet, see :mod:`nao_arena.episode_log`) atomically; returns
    the path."""
    path = Path(path)
    table = to_table(log)
    meta = json.dumps(
        {**_metadata(log), CONTENT_KEY: table_digest(table)}, separators=(",", ":"), allow_nan=False
    )
    kv = {
        META_KEY: meta.encode("utf-8"),
        META_SHA_KEY: hashlib.sha256(meta.encode("utf-8")).hexdigest().encode("ascii"),
    }
    # the file's own key-value pairs; where pyarrow cannot add them, the schema's (which
    # pyarrow then also keeps in its serialized schema)
    own_kv = hasattr(pq.ParquetWriter, "add_key_value_metadata")
    if not own_kv:
        table = table.replace_schema_metadata(kv)
    write_checks, _ = _checksum_options()

    def write(tmp: str) -> None:
        # plain float64 pages compress better with zstd here than byte-stream-split ones
        with pq.ParquetWriter(
            tmp,
            table.schema,
            compression="zstd",
            compression_level=3,
            use_dictionary=["step", "time", "status", "selection", "neighbours"],
            write_statistics=False,
            **write_checks,
        ) as writer:
            writer.write_table(table, row_group_size=max(table.num_rows, 1))
            if own_kv:
                writer.add_key_value_metadata(kv)

    atomic_write_with(path, write, suffix=".tmp.parquet")
    return path
