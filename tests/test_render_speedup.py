"""The viewer's compiled panel labels (nao_arena.render._panel_kernel) against their
definition (tests/reference/viewer_reference.py): frames of maps without walls are the
frames first drawn, pixel for pixel; frames of maps with walls are those of the exact
walls' region (the segment kernel at every acceleration, every wall), which a forward
simulation of the robot's path confirms; only the walls' region differs from the
region first drawn (the path sampled at 41 times)."""

from __future__ import annotations

import math
import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

from types import SimpleNamespace  # noqa: E402

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from reference.viewer_reference import _own_paths as own_paths_reference  # noqa: E402
from reference.viewer_reference import (  # noqa: E402
    panel_labels_reference,
    wall_clearance_exact,
    wall_clearance_sampled,
)

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.geometry._kernel.exact import piece_sweep  # noqa: E402
from nao_arena.geometry.clearance import path_clearance, sampled_path  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.obstacles import RADIUS_CUT  # noqa: E402
from nao_arena.render import Viewer  # noqa: E402
from nao_arena.render._panel_kernel import BAND, panel_labels, wall_clearances  # noqa: E402
from nao_arena.render.colours import WALL_REGION_COLOUR as _WALL_REGION  # noqa: E402
from nao_arena.render.viewer import _own_paths  # noqa: E402


class SampledReferenceViewer(Viewer):
    """The viewer as first written: every clearance at every acceleration, the walls'
    region from the path sampled at 41 times."""

    @staticmethod
    def _panel_labels(grid, obs, path, walls, reach):
        return panel_labels_reference(grid, obs, path, walls, reach, wall_clearance_sampled)


class ExactReferenceViewer(Viewer):
    """The viewer with every clearance at every acceleration, walls included (exact)."""

    _panel_labels = staticmethod(panel_labels_reference)


def _frames(name: str, reference: type[Viewer], **params):
    """Frames of map ``name`` (several times, several selected robots) from the viewer and
    from ``reference``; yields (frame, reference frame, viewer, where)."""
    arena = Arena(load_map(name, **params))
    arena.reset(0)
    n = len(arena.robots)
    viewer, ref = Viewer(), reference()
    for frame_no in range(3):
        for _ in range(7):
            arena.step()
        for selected in sorted({0, n // 2, n - 1, (5 * frame_no + 1) % n}):
            yield (
                viewer.draw(arena, selected=selected),
                ref.draw(arena, selected=selected),
                viewer,
                (name, frame_no, selected),
            )


@pytest.mark.parametrize("name", ["circle_swap", "crossing", "roundabout", "dense_swap"])
def test_frames_without_walls_are_pixel_identical_to_the_first_written(name):
    neighbour_colours = Viewer._region_colours()[:-1]
    regions = 0
    for frame, expected, viewer, where in _frames(name, SampledReferenceViewer):
        assert np.array_equal(frame, expected), where
        surface = pygame.surfarray.array3d(viewer.surface).transpose(1, 0, 2)
        assert np.array_equal(frame, surface) and frame.flags.writeable
        panel = frame[:, frame.shape[0] :].reshape(-1, 1, 3)
        regions += int(np.any(np.all(panel == neighbour_colours[None], axis=-1)))
    assert regions > 0  # some neighbour's region was drawn, so it was compared


@pytest.mark.parametrize("name", ["two_lane_road", "corridor", "crowd"])
def test_frames_with_walls_are_pixel_identical_to_the_exact_walls_region(name):
    wall_region_seen = 0
    for frame, expected, _, where in _frames(name, ExactReferenceViewer):
        assert np.array_equal(frame, expected), where
        panel = frame[:, frame.shape[0] :]
        wall_region_seen += int(np.all(panel == _WALL_REGION, axis=-1).sum() > 0)
    assert wall_region_seen > 0  # the walls' region was drawn, so it was compared


def _panel_scenes(name: str):
    """(grid, obs, path, walls, reach) of the panels of map ``name`` at a few times."""
    arena = Arena(load_map(name))
    arena.reset(0)
    viewer = Viewer()
    g = viewer.options.panel_grid
    for _ in range(4):
        for _ in range(7):
            arena.step()
        for selected in range(len(arena.robots)):
            obs = arena.observations()[selected]
            ext = viewer.options.panel_extent * obs.a_max
            xs = np.linspace(-ext, ext, g)
            gx, gy = np.meshgrid(xs, xs[::-1])
            grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
            _, _, path, walls = viewer._predictions(arena, selected, obs)
            yield grid, obs, path, walls, ext * math.sqrt(2)


@pytest.mark.parametrize("name", ["two_lane_road", "corridor"])
def test_only_the_walls_region_differs_from_the_first_written(name):
    """Labels differ from those first drawn only where one of the two shows the walls; there
    (a few per panel) a forward simulation confirms the exact walls' clearance, which the
    path sampled at 41 times misjudged."""
    changed = misjudged = 0
    for grid, obs, path, walls, reach in _panel_scenes(name):
        lab, shown = Viewer._panel_labels(grid, obs, path, walls, reach)
        old, old_shown = panel_labels_reference(
            grid, obs, path, walls, reach, wall_clearance_sampled
        )
        assert shown == old_shown
        differ = lab != old
        assert np.all((lab[differ] == -2) | (old[differ] == -2))
        horizon = float(path.t[-1])
        for a in grid[differ][:3]:  # the walls' clearance there, against a forward simulation
            exact = wall_clearance_exact(a[None], obs.velocity, obs.v_max, horizon, walls)[0]
            sampled = wall_clearance_sampled(a[None], obs.velocity, obs.v_max, horizon, walls)[0]
            samples = 20001
            sim = _simulated_wall_clearance(obs.velocity, a, obs.v_max, horizon, *walls, samples)
            tol = 0.5 * obs.v_max * horizon / (samples - 1) + 1e-9
            assert exact < 0 and sim - tol <= exact <= sim + 1e-9
            misjudged += abs(sampled - sim) > tol
        changed += int(differ.sum())
    assert changed > 0  # the exact region is not the sampled one on these maps
    assert misjudged > 0  # where the sampled path misjudged the walls' clearance


def _simulated_wall_clearance(v, a, v_max, horizon, segs, grown, samples):
    """Least over fine times of (distance from the path to each wall - grown) (m), the path
    x(t) = v t + a t^2 / 2 saturating at v_max (|v| <= v_max), from the speed's quadratic
    |v + a t|^2 = v_max^2 solved here."""
    t = np.linspace(0.0, horizon, samples)
    aa, av, vv = a @ a, a @ v, v @ v
    tau = np.inf
    if aa > 0 and np.isfinite(v_max):
        tau = (-av + math.sqrt(max(av * av - aa * (vv - v_max * v_max), 0.0))) / aa
    ts = np.minimum(t, tau)[:, None]
    x = (
        v * ts
        + 0.5 * a * ts * ts
        + (v + a * (tau if np.isfinite(tau) else 0.0)) * np.maximum(t - tau, 0.0)[:, None]
    )
    best = np.inf
    for (p, q), r in zip(segs, grown, strict=True):
        u = q - p
        ll = u @ u
        s = np.clip(((x - p) @ u) / ll, 0.0, 1.0) if ll > 0 else np.zeros(len(x))
        d = np.hypot(*(x - p - s[:, None] * u).T)
        best = min(best, float(d.min()) - r)
    return best


_coord = st.floats(-6.0, 6.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    speed=st.floats(0.0, 1.0),
    heading=st.floats(0.0, 2 * math.pi),
    v_max=st.floats(0.3, 2.5),
    a_max=st.floats(0.3, 3.0),
    segs=st.lists(st.tuples(_coord, _coord, _coord, _coord), min_size=1, max_size=4),
    grown=st.lists(st.floats(0.1, 1.0), min_size=4, max_size=4),
    horizon=st.sampled_from([1.0, 3.0, 6.0]),
)
def test_walls_region_matches_a_forward_simulation(
    speed, heading, v_max, a_max, segs, grown, horizon
):
    """The walls' clearance of the panel's accelerations against the robot's path simulated
    on a fine time grid: the same sign except within the sampling's tolerance (half the
    most the path moves between samples, m) of the boundary, and where negative the same
    value up to that tolerance."""
    v = speed * v_max * np.array([math.cos(heading), math.sin(heading)])
    xs = np.linspace(-1.3 * a_max, 1.3 * a_max, 9)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    walls = np.array(segs, dtype=float).reshape(-1, 2, 2)
    grown_w = np.array(grown[: len(walls)])
    got = wall_clearances(grid, v, v_max, horizon, walls, grown_w)
    samples = 20001
    tol = 0.5 * v_max * horizon / (samples - 1) + 1e-9  # the path moves <= v_max between
    for a, c in zip(grid, got, strict=True):
        sim = _simulated_wall_clearance(v, a, v_max, horizon, walls, grown_w, samples)
        if c < 0:
            assert sim - tol <= c <= sim + 1e-9  # exact: below every sample, near the least
        if sim < -tol:
            assert c < 0
        if sim > tol:
            assert not c < 0


@settings(max_examples=60, deadline=None)
@given(
    velocity=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)),
    v_max=st.floats(0.3, 2.5),
    segs=st.lists(st.tuples(_coord, _coord, _coord, _coord), min_size=1, max_size=6),
    grown=st.lists(st.floats(0.0, 1.5), min_size=6, max_size=6),
    horizon=st.sampled_from([1.0, 3.0, 4.5]),
)
def test_wall_clearances_are_the_segment_kernel_where_negative(
    velocity, v_max, segs, grown, horizon
):
    xs = np.linspace(-2.0, 2.0, 21)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    walls = (np.array(segs, dtype=float).reshape(-1, 2, 2), np.array(grown[: len(segs)]))
    v = np.array(velocity)
    got = wall_clearances(grid, v, v_max, horizon, *walls)
    want = wall_clearance_exact(grid, v, v_max, horizon, walls)
    inside = want < 0
    assert np.array_equal(got < 0, inside)
    assert np.array_equal(got[inside], want[inside])  # bit for bit where it is drawn
    assert np.all(got[~inside] >= 0)


def _scene(data, n_neighbours: int, n_walls: int):
    """A random panel scene: robot velocity, neighbours on sampled paths (some already
    inside their grown radius, which is then cut as the agents cut it), walls."""
    v_max = data.draw(st.floats(0.4, 2.0), "v_max")
    a_max = data.draw(st.floats(0.4, 2.5), "a_max")
    speed = data.draw(st.floats(0.0, 1.0), "speed") * v_max
    heading = data.draw(st.floats(0.0, 2 * math.pi), "heading")
    times = np.linspace(0.0, 3.0, 16)
    centres, radii = [], []
    for _ in range(n_neighbours):
        start = np.array([data.draw(st.floats(-4.0, 4.0)), data.draw(st.floats(-4.0, 4.0))])
        vel = np.array([data.draw(st.floats(-1.5, 1.5)), data.draw(st.floats(-1.5, 1.5))])
        turn = data.draw(st.floats(-0.8, 0.8))
        ang = turn * times
        rot = np.stack([np.cos(ang), -np.sin(ang), np.sin(ang), np.cos(ang)], 1).reshape(-1, 2, 2)
        path = start + np.cumsum(
            np.concatenate([[np.zeros(2)], (rot[:-1] @ vel) * np.diff(times)[:, None]]), axis=0
        )
        r = data.draw(st.floats(0.2, 1.2))
        centres.append(path)
        radii.append(min(r, float(np.hypot(*start)) * RADIUS_CUT))
    path = (
        sampled_path(times, np.array(centres).reshape(n_neighbours, len(times), 2), np.array(radii))
        if n_neighbours
        else None
    )
    walls = None
    if n_walls:
        segs = np.array([[data.draw(_coord) for _ in range(4)] for _ in range(n_walls)])
        walls = (
            segs.reshape(-1, 2, 2),
            np.array([data.draw(st.floats(0.2, 1.0)) for _ in range(n_walls)]),
        )
    obs = SimpleNamespace(
        velocity=speed * np.array([math.cos(heading), math.sin(heading)]), v_max=v_max, a_max=a_max
    )
    return obs, path, walls, times


@settings(max_examples=60, deadline=None)
@given(data=st.data(), n_neighbours=st.integers(1, 5), n_walls=st.integers(0, 3))
def test_panel_labels_are_the_reference_labels(data, n_neighbours, n_walls):
    obs, path, walls, _ = _scene(data, n_neighbours, n_walls)
    ext = 1.3 * obs.a_max
    xs = np.linspace(-ext, ext, 31)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    lab, shown = Viewer._panel_labels(grid, obs, path, walls, ext * math.sqrt(2))
    want, want_shown = panel_labels_reference(grid, obs, path, walls, ext * math.sqrt(2))
    assert shown == want_shown
    np.testing.assert_array_equal(lab, want)


@pytest.mark.parametrize("nudge", [-2, -1, 0, 1, 2])
def test_labels_at_a_neighbours_boundary_follow_the_exact_clearance(nudge):
    """A neighbour's radius set to an acceleration's exact least distance, give or take a
    few ulps: the decision scans leave it to the exact clearance (within BAND), so the
    label is -1 exactly when that clearance is >= 0."""
    times = np.linspace(0.0, 3.0, 31)
    centres = np.stack([np.linspace(2.0, -1.0, 31), np.linspace(1.0, 0.5, 31)], 1)
    v = np.array([0.3, -0.1])
    xs = np.linspace(-1.3, 1.3, 41)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    probe = sampled_path(times, centres[None], np.zeros(1))
    dist = path_clearance(grid, v, probe, v_max=1.0).clearance[:, 0]
    k = len(grid) // 3
    path = sampled_path(times, centres[None], np.array([_nudged(float(dist[k]), nudge)]))
    clear = path_clearance(grid, v, path, v_max=1.0).clearance[:, 0]
    assert np.sum(np.abs(clear) < BAND) >= 1  # the probe lies in the band
    t, c, w, b = path.t, path.c, path.velocity, path.acceleration
    lab = panel_labels(
        grid,
        v,
        1.0,
        t,
        c,
        w,
        b,
        path.radius,
        piece_sweep(t, w, b),
        np.zeros((0, 2, 2)),
        np.zeros(0),
    )
    np.testing.assert_array_equal(lab, np.where(clear < 0, 0, -1))


def _tie_scene():
    """A grid, a velocity, a neighbour's path (radius 0: its clearance is the distance) and
    a wall through the neighbour's way."""
    times = np.linspace(0.0, 3.0, 31)
    centres = np.stack([np.linspace(2.0, -1.0, 31), np.linspace(1.0, 0.5, 31)], 1)
    xs = np.linspace(-1.3, 1.3, 41)
    gx, gy = np.meshgrid(xs, xs[::-1])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    walls = (np.array([[[1.0, -1.0], [1.2, 1.5]]]), np.array([0.4]))
    return times, centres, np.array([0.3, -0.1]), grid, walls


def _nudged(x: float, ulps: int) -> float:
    for _ in range(abs(ulps)):
        x = float(np.nextafter(x, np.inf if ulps > 0 else -np.inf))
    return x


@pytest.mark.parametrize("nudge", [-2, -1, 0, 1, 2])
def test_labels_where_neighbour_and_wall_tie_follow_the_exact_comparison(nudge):
    """A neighbour's radius set so that its clearance equals the walls' at some grid
    accelerations, give or take a few ulps: the walls show exactly where their clearance is
    negative and below the neighbour's."""
    times, centres, v, grid, walls = _tie_scene()
    dist = path_clearance(
        grid, v, sampled_path(times, centres[None], np.zeros(1)), v_max=1.0
    ).clearance[:, 0]
    wall = wall_clearance_exact(grid, v, 1.0, 3.0, walls)
    k = int(np.argmin(np.where(wall < -0.05, np.abs(dist - wall - 0.6), np.inf)))
    path = sampled_path(times, centres[None], np.array([_nudged(float(dist[k] - wall[k]), nudge)]))
    clear = path_clearance(grid, v, path, v_max=1.0).clearance[:, 0]
    assert np.sum(np.abs(clear - wall) < BAND) >= 1  # a tie within the band
    obs = SimpleNamespace(velocity=v, v_max=1.0)
    lab, _ = Viewer._panel_labels(grid, obs, path, walls, 10.0)
    want, _ = panel_labels_reference(grid, obs, path, walls, 10.0)
    np.testing.assert_array_equal(lab, want)
    assert np.any(lab == -2) and np.any(lab == 0)


@pytest.mark.parametrize("nudge", [-2, -1, 0, 1, 2])
@pytest.mark.parametrize("swap", [False, True])
def test_labels_where_two_neighbours_tie_follow_the_exact_comparison(nudge, swap):
    """A second neighbour's radius set so that its clearance equals the first's at some
    grid accelerations (or a few ulps off): the label is the first least by index, as
    numpy's argmin over all clearances has it."""
    times, centres, v, grid, _ = _tie_scene()
    other = centres[::-1] * [1.0, -1.0] + [0.5, 0.8]
    both = np.array([other, centres] if swap else [centres, other])
    dist = path_clearance(grid, v, sampled_path(times, both, np.zeros(2)), v_max=1.0).clearance
    r0 = 0.6
    k = int(np.argmin(np.where(dist[:, 0] < r0 - 0.05, np.abs(dist[:, 1] - dist[:, 0]), np.inf)))
    r1 = _nudged(float(dist[k, 1] - (dist[k, 0] - r0)), nudge)
    path = sampled_path(times, both, np.array([r0, r1]))
    clear = path_clearance(grid, v, path, v_max=1.0).clearance
    assert np.sum((np.abs(clear[:, 0] - clear[:, 1]) < BAND) & (clear[:, 0] < 0)) >= 1
    obs = SimpleNamespace(velocity=v, v_max=1.0)
    lab, _ = Viewer._panel_labels(grid, obs, path, None, 10.0)
    want, _ = panel_labels_reference(grid, obs, path, None, 10.0)
    np.testing.assert_array_equal(lab, want)
    assert np.any(lab == 0) and np.any(lab == 1)


def test_twin_neighbours_show_the_first():
    """Two neighbours on the same path with the same radius tie everywhere: the first shows
    (numpy's argmin), behind a third that lies wholly elsewhere."""
    times, centres, v, grid, _ = _tie_scene()
    far = centres * [-1.0, -1.0]
    path = sampled_path(times, np.array([far, centres, centres]), np.array([0.5, 0.7, 0.7]))
    obs = SimpleNamespace(velocity=v, v_max=1.0)
    lab, _ = Viewer._panel_labels(grid, obs, path, None, 10.0)
    want, _ = panel_labels_reference(grid, obs, path, None, 10.0)
    np.testing.assert_array_equal(lab, want)
    assert np.any(lab == 1) and not np.any(lab == 2)


def test_an_empty_horizon_is_decided_by_the_exact_clearance():
    """Paths over [0, 0] s (a single sample): the start distance decides."""
    centres = np.array([[[0.5, 0.0]], [[3.0, 0.0]]])
    path = sampled_path([0.0], centres, np.array([0.8, 0.5]))
    grid = np.array([[0.0, 0.0], [1.0, 0.0]])
    t, c, w, b = path.t, path.c, path.velocity, path.acceleration
    lab = panel_labels(
        grid,
        np.zeros(2),
        1.0,
        t,
        c,
        w,
        b,
        path.radius,
        piece_sweep(t, w, b),
        np.zeros((0, 2, 2)),
        np.zeros(0),
    )
    clear = path_clearance(grid, np.zeros(2), path, v_max=1.0).clearance
    assert np.all(clear[:, 0] < 0) and np.all(clear[:, 1] > 0)
    np.testing.assert_array_equal(lab, [0, 0])


@settings(max_examples=60, deadline=None)
@given(
    velocity=st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0)),
    v_max=st.floats(0.1, 3.0),
    accels=st.lists(st.tuples(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0)), min_size=1, max_size=8),
    horizon=st.floats(0.1, 6.0),
)
def test_own_paths_are_bit_identical_to_the_reference(velocity, v_max, accels, horizon):
    times = np.linspace(0.0, horizon, 31)
    v, a = np.array(velocity), np.array(accels, dtype=float)
    assert np.array_equal(_own_paths(v, a, v_max, times), own_paths_reference(v, a, v_max, times))
