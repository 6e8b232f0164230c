"""The viewer's faster walls' region draws the same pixels as the region first written
(tests/reference/viewer_reference.py): whole frames of maps with walls, and the
clearances themselves on random walls and velocities."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from reference.viewer_reference import _own_paths as own_paths_reference  # noqa: E402
from reference.viewer_reference import wall_clearance_reference  # noqa: E402

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.render import Viewer  # noqa: E402
from nao_arena.render.viewer import _WALL_REGION, _own_paths  # noqa: E402


class ReferenceViewer(Viewer):
    """The viewer with the walls' region as first written."""

    _wall_clearance = staticmethod(wall_clearance_reference)


@pytest.mark.parametrize("name", ["two_lane_road", "corridor"])
def test_frames_with_walls_are_pixel_identical_to_the_reference(name):
    arena = Arena(load_map(name))
    arena.reset(0)
    n = len(arena.robots)
    viewer, reference = Viewer(), ReferenceViewer()
    wall_region_seen = 0
    for frame_no in range(3):
        for _ in range(7):
            arena.step()
        for selected in sorted({0, n // 2, n - 1, (5 * frame_no + 1) % n}):
            frame = viewer.draw(arena, selected=selected)
            expected = reference.draw(arena, selected=selected)
            assert np.array_equal(frame, expected), (name, frame_no, selected)
            surface = pygame.surfarray.array3d(viewer.surface).transpose(1, 0, 2)
            assert np.array_equal(frame, surface) and frame.flags.writeable
            panel = frame[:, frame.shape[0]:]
            wall_region_seen += int(np.all(panel == _WALL_REGION, axis=-1).sum() > 0)
    assert wall_region_seen > 0  # the walls' region was drawn, so it was compared


_coord = st.floats(-12.0, 12.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    velocity=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)),
    v_max=st.floats(0.3, 2.5),
    a_max=st.floats(0.3, 3.0),
    segs=st.lists(st.tuples(_coord, _coord, _coord, _coord), min_size=1, max_size=6),
    grown=st.lists(st.floats(0.0, 1.5), min_size=6, max_size=6),
    horizon=st.sampled_from([1.0, 3.0, 4.5]),
)
def test_wall_clearance_is_exact_where_negative(velocity, v_max, a_max, segs, grown, horizon):
    xs = np.linspace(-1.3 * a_max, 1.3 * a_max, 31)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    walls = (np.array(segs, dtype=float).reshape(-1, 2, 2), np.array(grown[:len(segs)]))
    v = np.array(velocity)
    got = Viewer._wall_clearance(grid, v, v_max, horizon, walls)
    want = wall_clearance_reference(grid, v, v_max, horizon, walls)
    inside = want < 0
    assert np.array_equal(got < 0, inside)
    assert np.array_equal(got[inside], want[inside])  # bit for bit where it is drawn
    assert np.all(got[~inside] >= 0)


@settings(max_examples=60, deadline=None)
@given(
    velocity=st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)),
    v_max=st.floats(0.1, 3.0),
    accels=st.lists(st.tuples(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0)), min_size=1,
                    max_size=8),
    horizon=st.floats(0.1, 6.0),
)
def test_own_paths_are_bit_identical_to_the_reference(velocity, v_max, accels, horizon):
    times = np.linspace(0.0, horizon, 31)
    v, a = np.array(velocity), np.array(accels, dtype=float)
    assert np.array_equal(_own_paths(v, a, v_max, times),
                          own_paths_reference(v, a, v_max, times))
