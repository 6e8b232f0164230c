"""Recorded pedestrians: the ETH and UCY annotations, replayed exactly.

Two text formats, one annotation per line, whitespace-separated numbers:

- ``obsmat``: ``frame id x z y vx vz vy`` (the EWAP / OpenTraj ``obsmat.txt``; metres,
  m/s; ``z`` unused);
- ``xy``: ``frame id x y``.

A frame's time (s, the recording's clock) is ``frame / fps``; :func:`read_recording`
shifts it by ``time_offset`` (s) so that the episode starts at the recording's time
``time_offset``. Between a person's annotations the position is interpolated linearly
and the velocity is the slope of that segment, so positions and velocities are
consistent: integrating the velocity over any interval gives the change of position
exactly (obsmat's annotated velocities are estimates and are not used). A person is
present from their first annotation to their last, at which they appear and leave.
People do not react to anything.

Every input problem (missing file, a line that is not numbers, a frame that is not
an integer >= 0, a person annotated twice in one frame, non-finite values) is a
:class:`RecordingError`, one line naming the file, the line and what was expected.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FORMATS",
    "Recording",
    "RecordingError",
    "cached_recording",
    "future_paths",
    "read_recording",
]

FORMATS: dict[str, int] = {"obsmat": 8, "xy": 4}
"""Format name -> numbers per line."""

_X_COLUMN: dict[str, tuple[int, int]] = {"obsmat": (2, 4), "xy": (2, 3)}
"""Format name -> the columns of x and y."""


class RecordingError(ValueError):
    """A recording file that cannot be read as the format it was given in."""


@dataclass(frozen=True)
class Recording:
    """People's recorded tracks, person by person (world frame, m; times in s).

    ids (P,): the recording's person ids, ascending; person k's annotations are the
    rows ``offsets[k]:offsets[k + 1]`` of ``times`` (M,) (ascending) and
    ``positions`` (M, 2). ``source``: the file it was read from.
    """

    source: str
    ids: NDArray[np.int64]
    offsets: NDArray[np.int64]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]

    @property
    def people(self) -> int:
        """How many people the recording holds."""
        return len(self.ids)

    @property
    def first_times(self) -> NDArray[np.float64]:
        """(P,) s: when each person appears."""
        return self.times[self.offsets[:-1]]

    @property
    def last_times(self) -> NDArray[np.float64]:
        """(P,) s: when each person leaves."""
        return self.times[self.offsets[1:] - 1]

    def present(self, t: float) -> NDArray[np.bool_]:
        """(P,) whether each person is in the scene at time ``t`` (s)."""
        return (self.first_times <= t) & (t <= self.last_times)

    def states(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Positions (P, 2) m and velocities (P, 2) m/s at time ``t`` (s); NaN rows for the
        people absent then. At an annotation time the velocity is that of the segment
        that starts there (of the last segment at a person's last annotation); a person
        with a single annotation stands still at it."""
        positions = np.full((self.people, 2), np.nan)
        velocities = np.full((self.people, 2), np.nan)
        for k in np.flatnonzero(self.present(t)):
            lo, hi = int(self.offsets[k]), int(self.offsets[k + 1])
            positions[k], velocities[k] = _interpolate(self.times[lo:hi], self.positions[lo:hi], t)
        return positions, velocities

    def path(self, person: int, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """(T, 2) m: person ``person``'s (index, not id) positions at ``times`` (s), NaN
        where absent (the known path a predictor with an oracle reads)."""
        lo, hi = int(self.offsets[person]), int(self.offsets[person + 1])
        own_times, own = self.times[lo:hi], self.positions[lo:hi]
        times = np.asarray(times, dtype=float)
        out = np.full((len(times), 2), np.nan)
        inside = (own_times[0] <= times) & (times <= own_times[-1])
        out[inside, 0] = np.interp(times[inside], own_times, own[:, 0])
        out[inside, 1] = np.interp(times[inside], own_times, own[:, 1])
        return out


def future_paths(
    rec: Recording, people: list[int], t: float, times: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(len(people), T, 2) m: where each of ``people`` (indices) will be at ``t + times``
    (s), interpolated as :meth:`Recording.path` does; after a person's last annotation,
    there (the known path of someone who has left ends where they left); NaN rows for
    the people not in the scene at ``t``."""
    out = np.full((len(people), len(times), 2), np.nan)
    at = t + np.asarray(times, dtype=float)
    firsts, lasts = rec.first_times, rec.last_times
    for row, k in enumerate(people):
        if firsts[k] <= t <= lasts[k]:
            out[row] = rec.path(k, np.minimum(at, lasts[k]))
    return out


def _interpolate(
    times: NDArray[np.float64], positions: NDArray[np.float64], t: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position and velocity at ``t`` on the piecewise-linear track through the
    annotations (``times`` ascending, ``t`` within them)."""
    if len(times) == 1:
        return positions[0].copy(), np.zeros(2)
    i = int(np.searchsorted(times, t, side="right")) - 1
    i = min(max(i, 0), len(times) - 2)
    span = times[i + 1] - times[i]
    velocity = (positions[i + 1] - positions[i]) / span
    return positions[i] + velocity * (t - times[i]), velocity


def read_recording(
    path: str | Path,
    format: Literal["obsmat", "xy"] = "obsmat",  # noqa: A002 - the map key's name
    fps: float = 15.0,
    time_offset: float = 0.0,
) -> Recording:
    """Read a recording (see the module): ``fps`` frames per second of its frame numbers
    (> 0), ``time_offset`` (s) the recording's time at which the episode starts (the
    returned times are the recording's less it). Raises :class:`RecordingError`."""
    file = Path(path)
    if format not in FORMATS:
        raise RecordingError(
            f"{file}: format: expected one of {', '.join(FORMATS)}, got {format!r}"
        )
    if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
        raise RecordingError(f"{file}: fps: expected a finite number > 0, got {fps!r}")
    if not (isinstance(time_offset, int | float) and math.isfinite(time_offset)):
        raise RecordingError(f"{file}: time_offset: expected a finite number, got {time_offset!r}")
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RecordingError(f"{file}: no such recording file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{file}: cannot be read ({exc})") from None
    rows = _parse(file, text, format)
    if not rows:
        raise RecordingError(f"{file}: expected at least one annotation, got none")
    table = np.array(rows, dtype=np.float64)
    order = np.lexsort((table[:, 0], table[:, 1]))  # by person, then frame
    table = table[order]
    frames, people = table[:, 0], table[:, 1].astype(np.int64)
    again = np.flatnonzero((np.diff(people) == 0) & (np.diff(frames) == 0))
    if len(again):
        raise RecordingError(
            f"{file}: person {people[again[0]]} is annotated twice in frame "
            f"{int(frames[again[0]])}; expected one annotation per person and frame"
        )
    ids, starts = np.unique(people, return_index=True)
    offsets = np.append(starts, len(people)).astype(np.int64)
    times = frames / float(fps) - float(time_offset)
    return Recording(str(file), ids, offsets, times, table[:, 2:4].copy())


def _parse(file: Path, text: str, format: str) -> list[tuple[float, float, float, float]]:
    """(frame, id, x, y) per annotation line (blank lines and ``#`` comments skipped)."""
    width = FORMATS[format]
    xc, yc = _X_COLUMN[format]
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split("#", 1)[0].split()
        if not fields:
            continue
        where = f"{file}: line {number}"
        if len(fields) != width:
            raise RecordingError(
                f"{where}: expected {width} numbers ({format} format), got {len(fields)}"
            )
        try:
            values = [float(v) for v in fields]
        except ValueError:
            raise RecordingError(
                f"{where}: expected {width} numbers, got {line.strip()!r}"
            ) from None
        if not all(math.isfinite(v) for v in values):
            raise RecordingError(f"{where}: expected finite numbers, got {line.strip()!r}")
        frame, person = values[0], values[1]
        if frame < 0 or not frame.is_integer():
            raise RecordingError(f"{where}: frame: expected an integer >= 0, got {fields[0]}")
        if not person.is_integer():
            raise RecordingError(f"{where}: person id: expected an integer, got {fields[1]}")
        rows.append((frame, person, values[xc], values[yc]))
    return rows


def cached_recording(
    path: str | Path, format: str = "obsmat", fps: float = 15.0, time_offset: float = 0.0
) -> Recording:
    """:func:`read_recording`, read once per process for each file version (its size and
    modification time) and arguments."""
    try:
        stat = os.stat(path)
    except FileNotFoundError:
        raise RecordingError(f"{path}: no such recording file") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    return _cached(
        str(path), stat.st_size, stat.st_mtime_ns, format, float(fps), float(time_offset)
    )


@functools.lru_cache(maxsize=16)
def _cached(
    path: str, size: int, mtime_ns: int, format: str, fps: float, time_offset: float
) -> Recording:
    return read_recording(path, format, fps, time_offset)  # type: ignore[arg-type]
