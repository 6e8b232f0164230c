"""Recorded pedestrians (:mod:`nao_arena.pedestrians`): the real ETH and UCY recordings read
as their README describes them, replayed exactly (positions through the annotations,
velocities the slopes), and every bad file a one-line error.

The recordings are not in this repository: the tests that need them read them from
``../shared/data/pedestrians`` and skip, saying so, where it is absent.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nao_arena.pedestrians import Recording, RecordingError, read_recording

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "pedestrians"

# folder -> (people, frames per second of its frame numbers), from its README
RECORDINGS = {"eth_univ": (360, 15.0), "eth_hotel": (390, 25.0), "ucy_zara01": (148, 25.0)}


def recording_file(name: str) -> Path:
    path = SHARED / name / "obsmat.txt"
    if not path.is_file():
        pytest.skip(f"the shared pedestrian recordings are not at {SHARED}")
    return path


@pytest.mark.parametrize("name", sorted(RECORDINGS))
def test_the_shared_recordings_read_as_their_readme_says(name):
    people, fps = RECORDINGS[name]
    path = recording_file(name)
    rec = read_recording(path, "obsmat", fps=fps)
    assert rec.people == people
    # annotations 0.4 s apart (2.5 Hz), the README's rate
    steps = np.concatenate(
        [np.diff(rec.times[a:b]) for a, b in zip(rec.offsets[:-1], rec.offsets[1:], strict=True)]
    )
    assert np.median(steps) == pytest.approx(0.4)
    # the slopes agree with the velocities the annotators estimated (columns vx, vy),
    # an independent check of the time scale: a wrong fps would scale them
    raw = np.loadtxt(path)
    annotated = {(int(r[1]), int(r[0])): (r[5], r[7]) for r in raw}
    gaps = []
    for k, person in enumerate(rec.ids):
        lo, hi = rec.offsets[k], rec.offsets[k + 1]
        for i in range(lo, hi - 1):
            slope = (rec.positions[i + 1] - rec.positions[i]) / (rec.times[i + 1] - rec.times[i])
            frame = int(round((rec.times[i]) * fps))
            gaps.append(np.hypot(*(slope - annotated[(int(person), frame)])))
    assert np.median(gaps) < 0.2  # m/s; walking speeds are about 1.3 m/s


def test_positions_pass_through_the_annotations_and_velocities_integrate(tmp_path):
    path = recording_file("ucy_zara01")
    rec = read_recording(path, "obsmat", fps=25.0, time_offset=10.0)
    raw = np.loadtxt(path)
    k = 7
    person = rec.ids[k]
    mine = raw[raw[:, 1] == person]
    mine = mine[np.argsort(mine[:, 0])]
    times = mine[:, 0] / 25.0 - 10.0
    for t, row in zip(times, mine, strict=True):
        positions, _ = rec.states(float(t))
        np.testing.assert_allclose(positions[k], row[[2, 4]], rtol=0, atol=1e-12)
    # between two annotations: position and velocity are consistent
    t0, t1 = times[2], times[3]
    a, va = rec.states(float(t0 + 0.1))
    b, vb = rec.states(float(t0 + 0.3))
    np.testing.assert_allclose(b[k] - a[k], va[k] * 0.2, atol=1e-12)
    np.testing.assert_array_equal(va[k], vb[k])
    assert t1 - t0 == pytest.approx(0.4)
    # present from the first annotation to the last, absent (NaN) outside
    before, _ = rec.states(float(times[0] - 0.01))
    after, _ = rec.states(float(times[-1] + 0.01))
    assert np.isnan(before[k]).all() and np.isnan(after[k]).all()
    assert rec.present(float(times[0]))[k] and rec.present(float(times[-1]))[k]
    path_k = rec.path(k, np.array([times[0] - 1.0, times[1], times[-1] + 1.0]))
    assert np.isnan(path_k[0]).all() and np.isnan(path_k[2]).all()
    np.testing.assert_allclose(path_k[1], mine[1, [2, 4]], atol=1e-12)


@given(
    st.lists(
        st.tuples(
            st.floats(-50, 50, allow_nan=False),
            st.floats(-50, 50, allow_nan=False),
        ),
        min_size=2,
        max_size=8,
    ),
    st.floats(0.0, 1.0),
)
def test_the_track_is_the_polyline_through_the_annotations(points, fraction):
    """An independent model: the track of one person, written as the polyline through its
    annotations (frames 0, 3, 6, ... at 10 fps), evaluated by hand."""
    frames = np.arange(len(points)) * 3
    text = "".join(f"{f} 4 {x!r} {y!r}\n" for f, (x, y) in zip(frames, points, strict=True))
    rec = _from_text(text, "xy", fps=10.0)
    t = fraction * frames[-1] / 10.0
    segment = min(int(t / 0.3), len(points) - 2)
    a, b = np.array(points[segment]), np.array(points[segment + 1])
    share = (t - segment * 0.3) / 0.3
    positions, velocities = rec.states(t)
    np.testing.assert_allclose(positions[0], a + share * (b - a), atol=1e-9)
    np.testing.assert_allclose(velocities[0], (b - a) / 0.3, rtol=1e-9, atol=1e-9)


def _from_text(text: str, format: str, fps: float = 10.0) -> Recording:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rec.txt"
        path.write_text(text)
        return read_recording(path, format, fps=fps)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "format", "expected"),
    [
        ("1 2 3\n", "xy", "line 1: expected 4 numbers (xy format), got 3"),
        ("1 2 3 x\n", "xy", "line 1: expected 4 numbers, got '1 2 3 x'"),
        ("0 1 0 0\n1 1 nan 0\n", "xy", "line 2: expected finite numbers"),
        ("1.5 1 0 0\n", "xy", "line 1: frame: expected an integer >= 0, got 1.5"),
        ("-3 1 0 0\n", "xy", "line 1: frame: expected an integer >= 0, got -3"),
        ("3 1.5 0 0\n", "xy", "line 1: person id: expected an integer, got 1.5"),
        ("3 1 0 0\n3 1 1 1\n", "xy", "person 1 is annotated twice in frame 3"),
        ("# nothing\n\n", "xy", "expected at least one annotation, got none"),
        ("1 2 3 4\n", "obsmat", "line 1: expected 8 numbers (obsmat format), got 4"),
        ("1 2 3 4\n", "csv", "format: expected one of obsmat, xy, got 'csv'"),
    ],
)
def test_bad_recordings_are_one_line_errors(text, format, expected):
    with pytest.raises(RecordingError) as info:
        _from_text(text, format)
    message = str(info.value)
    assert expected in message and "\n" not in message and "rec.txt" in message


def test_bad_settings_and_missing_files(tmp_path):
    (tmp_path / "r.txt").write_text("0 1 0 0\n")
    for fps in (0, -1.0, float("nan")):
        with pytest.raises(RecordingError, match="fps: expected a finite number > 0"):
            read_recording(tmp_path / "r.txt", "xy", fps=fps)
    with pytest.raises(RecordingError, match="time_offset: expected a finite number"):
        read_recording(tmp_path / "r.txt", "xy", time_offset=float("inf"))
    with pytest.raises(RecordingError, match="no such recording file"):
        read_recording(tmp_path / "missing.txt")
    one = read_recording(tmp_path / "r.txt", "xy")
    positions, velocities = one.states(0.0)
    assert positions.tolist() == [[0.0, 0.0]] and velocities.tolist() == [[0.0, 0.0]]
