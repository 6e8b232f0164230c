"""Reading an episode log back, with the checks that refuse a truncated, corrupt or
other-version file (see :mod:`nao_arena.episode_log`)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from nao_arena import __version__
from nao_arena._log_data import EpisodeLog, RobotInfo
from nao_arena._log_schema import (
    _SCHEMA,
    CONTENT_KEY,
    LOG_FORMAT,
    LOG_VERSION,
    META_KEY,
    META_SHA_KEY,
    SELECTIONS,
    STATUSES,
    LogError,
    table_digest,
)
from nao_arena._log_write import _checksum_options
from nao_arena.maps import MapSpec


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def _codes(column: pa.ChunkedArray, names: Sequence[str], where: str) -> NDArray[np.int8]:
    """Codes (int8, -1 for null) of a dictionary column of strings."""
    arr = column.combine_chunks()
    if isinstance(arr, pa.DictionaryArray):
        values = arr.dictionary.to_pylist()
        indices = arr.indices.fill_null(0).to_numpy(zero_copy_only=False).astype(np.int64)
        valid = arr.is_valid().to_numpy(zero_copy_only=False)
    else:
        values = sorted({v for v in arr.to_pylist() if v is not None})
        lookup = {v: i for i, v in enumerate(values)}
        indices = np.array([lookup.get(v, 0) for v in arr.to_pylist()], dtype=np.int64)
        valid = arr.is_valid().to_numpy(zero_copy_only=False)
    unknown = [v for v in values if v not in names]
    if unknown:
        raise LogError(f"{where}: unknown value {unknown[0]!r}; expected one of {', '.join(names)}")
    lut = np.array([names.index(v) for v in values] or [0], dtype=np.int8)
    return np.where(valid, lut[indices] if len(values) else 0, -1).astype(np.int8)


def read_log(path: str | Path) -> EpisodeLog:
    """Read an episode log (see :mod:`nao_arena.episode_log`). Raises :class:`LogError` with a
    one-line message naming the file for a missing, truncated or corrupt file, a
    Parquet file that is not an episode log, or another format version."""
    path = Path(path)
    if not path.is_file():
        raise LogError(f"{path}: no such file (expected an episode log written with --log)")
    _, read_checks = _checksum_options()
    try:
        pf = pq.ParquetFile(path, **read_checks)
        kv = pf.metadata.metadata or {}  # the file's own key-value pairs
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for a bad file
        raise LogError(
            f"{path}: not a complete episode log (truncated, or not a Parquet "
            f"file: {_first_line(exc)})"
        ) from None
    if META_KEY not in kv:
        raise LogError(
            f"{path}: not an episode log (a Parquet file without the "
            f"{META_KEY.decode()} metadata; expected a file written with --log)"
        )
    raw = kv[META_KEY]
    if kv.get(META_SHA_KEY, b"").decode("ascii", "replace") != hashlib.sha256(raw).hexdigest():
        raise LogError(f"{path}: corrupt episode log (its metadata do not match their checksum)")
    try:
        meta = json.loads(raw.decode("utf-8"))
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except ValueError as exc:
        raise LogError(f"{path}: corrupt episode log (metadata: {_first_line(exc)})") from None
    if meta.get("format") != LOG_FORMAT:
        raise LogError(
            f"{path}: not an episode log (format {meta.get('format')!r}, expected {LOG_FORMAT!r})"
        )
    version = meta.get("version")
    if version != LOG_VERSION:
        raise LogError(
            f"{path}: episode log format version {version!r} (written by "
            f"nao-arena {meta.get('nao_arena', '?')}); this nao-arena "
            f"({__version__}) reads version {LOG_VERSION}"
        )
    try:
        table = pf.read()
    except Exception as exc:  # noqa: BLE001
        raise LogError(f"{path}: corrupt episode log ({_first_line(exc)})") from None
    expected = meta.get(CONTENT_KEY)  # absent in logs written before it was kept
    if expected is not None:
        try:
            found = table_digest(table)
        except Exception as exc:  # noqa: BLE001 - a damaged column of another type
            raise LogError(f"{path}: corrupt episode log ({_first_line(exc)})") from None
        if found != expected:
            raise LogError(f"{path}: corrupt episode log (its rows do not match their checksum)")
    try:
        return _from_table(path, table, meta)
    except LogError:
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise LogError(
            f"{path}: corrupt episode log ({type(exc).__name__}: {_first_line(exc)})"
        ) from None


def _from_table(path: Path, table: pa.Table, meta: dict[str, Any]) -> EpisodeLog:
    missing = [f.name for f in _SCHEMA if f.name not in table.column_names]
    if missing:
        raise LogError(f"{path}: corrupt episode log (missing column {missing[0]!r})")
    from pydantic import ValidationError

    try:
        spec = MapSpec.model_validate(meta["map"])
    except ValidationError as exc:
        raise LogError(
            f"{path}: corrupt episode log (its map does not validate: {_first_line(exc)})"
        ) from None
    n = len(spec.bodies())
    n_rows = int(meta["steps"])
    if table.num_rows != n_rows * n:
        raise LogError(
            f"{path}: corrupt episode log ({table.num_rows} rows, expected "
            f"{n_rows} steps x {n} bodies = {n_rows * n})"
        )

    def col(name: str) -> NDArray[Any]:
        return table.column(name).to_numpy()

    if not (
        np.array_equal(col("step"), np.repeat(np.arange(n_rows), n))
        and np.array_equal(col("body"), np.tile(np.arange(n), n_rows))
    ):
        raise LogError(f"{path}: corrupt episode log (rows out of step/body order)")

    def pair(a: str, b: str) -> NDArray[np.float64]:
        return np.stack([col(a), col(b)], axis=-1).reshape(n_rows, n, 2)

    robots = []
    grids = [np.array(g, dtype=np.float64) for g in meta.get("time_grids", [])]
    for r in meta["robots"]:
        robots.append(
            RobotInfo(
                name=str(r["name"]),
                body=int(r["body"]),
                agent=str(r["agent"]),
                label=str(r["label"]),
                predictor=r.get("predictor"),
                times=None if r.get("times") is None else grids[int(r["times"])],
                margin=float(r.get("margin", 0.0)),
                v_pref=None if r.get("v_pref") is None else float(r["v_pref"]),
            )
        )
    if [r.body for r in robots] != list(range(spec.n_robots)):
        raise LogError(
            f"{path}: corrupt episode log (its robot list names bodies "
            f"{[r.body for r in robots]}, expected the map's {spec.n_robots} "
            f"robots, bodies 0 .. {spec.n_robots - 1})"
        )
    if len(meta["summary"].get("robots", [])) != spec.n_robots:
        raise LogError(
            f"{path}: corrupt episode log (its summary has "
            f"{len(meta['summary'].get('robots', []))} robots, expected the map's "
            f"{spec.n_robots})"
        )
    ids = np.array([r.body for r in robots], dtype=np.intp)
    n_robots = len(robots)
    status = _codes(table.column("status"), STATUSES, f"{path}: column status")
    selection = _codes(table.column("selection"), SELECTIONS, f"{path}: column selection")
    detour_col = table.column("detour").combine_chunks()
    detour = detour_col.fill_null(np.nan).to_numpy(zero_copy_only=False)
    nb_col = table.column("neighbours").combine_chunks()
    offsets_b = nb_col.offsets.to_numpy().astype(np.int64)
    values = nb_col.values.to_numpy(zero_copy_only=False).astype(np.int32)
    # the robots' lists (row-major over (row, robot)), from the lists per (row, body)
    starts = offsets_b[:-1].reshape(n_rows, n)[:, ids]
    ends = offsets_b[1:].reshape(n_rows, n)[:, ids]
    counts = (ends - starts).ravel()
    offsets = np.zeros(n_rows * n_robots + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    gather = np.repeat(starts.ravel() - offsets[:-1], counts) + np.arange(
        offsets[-1], dtype=np.int64
    )
    log = EpisodeLog(
        spec=spec,
        seed=meta.get("seed"),
        options=dict(meta.get("options") or {}),
        robots=robots,
        summary=meta["summary"],
        time=np.ascontiguousarray(col("time").reshape(n_rows, n)[:, 0]),
        positions=pair("x", "y"),
        velocities=pair("vx", "vy"),
        accelerations=pair("ax", "ay"),
        commanded=pair("cmd_x", "cmd_y"),
        reached=col("reached").reshape(n_rows, n).copy(),
        status=status.reshape(n_rows, n)[:, ids].copy(),
        selection=selection.reshape(n_rows, n)[:, ids].copy(),
        detour=detour.reshape(n_rows, n)[:, ids].copy(),
        nb_offsets=offsets,
        nb_index=values[gather] if len(gather) else values[:0],
        nb_logged=np.array([bool(r.get("neighbours")) for r in meta["robots"]], dtype=bool),
        contact_steps=np.array(meta.get("contact_steps", []), dtype=np.int64),
        fault_steps=np.array(meta.get("fault_steps", []), dtype=np.int64),
        run=dict(meta.get("run") or {}),
        version=int(meta["version"]),
        written_by=str(meta.get("nao_arena", "?")),
        path=path,
    )
    if len(log.contact_steps) != len(log.summary.get("contacts", [])):
        raise LogError(
            f"{path}: corrupt episode log (contact_steps and the summary's "
            "contacts differ in number)"
        )
    expected = log.summary.get("trajectory_hash") or ""
    if expected and log.trajectory_hash() != expected:
        raise LogError(
            f"{path}: corrupt episode log (its states do not match the episode's trajectory hash)"
        )
    return log
