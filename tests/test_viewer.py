"""What the viewer shows: legend, panel axes, cut regions, short arrows, scale bar, keys,
and frames that depend on the simulation only (headless, no display needed)."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import dataclasses  # noqa: E402
import itertools  # noqa: E402
import re  # noqa: E402
from pathlib import Path  # noqa: E402

import imageio.v2 as iio  # noqa: E402
import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra.numpy import arrays  # noqa: E402

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.obstacles import RADIUS_CUT  # noqa: E402
from nao_arena.render import Viewer, record_episode  # noqa: E402
from nao_arena.render import viewer as viewer_module  # noqa: E402
from nao_arena.render.colours import (  # noqa: E402
    GOOD_COLOUR,
    PALETTE,
    WALL_COLOUR,
    WALL_REGION_COLOUR,
    mix,
)
from nao_arena.render.viewer import (  # noqa: E402
    KEYS,
    EdgeRun,
    PanelAgent,
    _trail_colour,
    edge_runs,
    panel_agent,
)
from nao_arena.sensing import Neighbours, Observation  # noqa: E402

VIEWER_DOCS = Path(__file__).resolve().parents[1] / "docs" / "how-to" / "replay-explain.md"


def _arena(name: str, steps: int, **params) -> Arena:
    arena = Arena(load_map(name, **params))
    arena.reset(0)
    for _ in range(steps):
        arena.step()
    return arena


@pytest.fixture(scope="module")
def crowd() -> tuple[Arena, Viewer, np.ndarray]:
    """The crowd map at 6 s, robot 3 selected: NAO regions reach the panel's edge, and the
    map's bottom wall runs under the scale bar."""
    arena = _arena("crowd", 60)
    viewer = Viewer()
    frame = viewer.draw(arena, selected=3)
    return arena, viewer, frame


def test_legend_explains_every_symbol_with_the_drawn_colours(crowd):
    _, viewer, _ = crowd
    legend = {e.label: e for e in viewer.info.legend}
    assert "nao" in legend
    path = next(e for e in legend.values() if e.symbol == "line")
    nao = next(e for e in legend.values() if e.symbol == "swatch" and "NAO" in e.label)
    # one colour per neighbour: the legend says so and shows several, the paths' and the
    # regions' colours (regions are the paths' colours lightened)
    assert "colour = neighbour" in path.label and "colour = neighbour" in nao.label
    assert len(path.colours) > 1 and path.colours == tuple(PALETTE[: len(path.colours)])
    assert nao.colours == tuple(mix(c, 0.55) for c in path.colours)
    ring = next(e for e in legend.values() if "hollow ring" in e.label)
    assert ring.symbol == "ring" and ring.colours == path.colours
    walls = next(e for e in legend.values() if e.colours == (WALL_REGION_COLOUR,))
    assert walls.symbol == "swatch" and "wall" in walls.label
    assert any(e.symbol == "cut" for e in legend.values())
    assert any(e.symbol == "zero" for e in legend.values())
    # trails: dotted, in a colour that no predicted path uses
    trail = next(e for e in legend.values() if e.label.startswith("trail"))
    assert trail.symbol == "dotted" and trail.colours[0] not in PALETTE
    # every label is written in the frame
    assert set(legend) <= set(viewer.info.texts)


def test_trails_are_drawn_in_their_own_colour():
    arena = _arena("circle_swap", 0, n=4)
    viewer = Viewer()
    for _ in range(15):
        arena.step()
        frame = viewer.draw(arena)
    trail = _trail_colour(viewer_module.AGENT_COLOURS["nao"])
    world = frame[:, :800]
    assert np.all(world == trail, axis=-1).sum() > 30
    assert trail not in PALETTE


def test_panel_axes_are_named_and_every_tick_labelled(crowd):
    arena, viewer, _ = crowd
    a_max = arena.observations()[3].a_max
    assert a_max == 2.0  # panel extent 2.6 m/s^2: ticks every 1 m/s^2
    texts = viewer.info.texts
    assert "a_x (m/s^2)" in texts and "a_y (m/s^2)" in texts
    assert {"-2", "-1", "0", "1", "2"} <= set(texts)


@settings(max_examples=60, deadline=None)
@given(arrays(np.int64, (6, 6), elements=st.integers(-2, 2)))
def test_edge_runs_cover_exactly_the_regions_on_each_edge(labels):
    runs = edge_runs(labels)
    edges = {"top": labels[0], "bottom": labels[-1], "left": labels[:, 0], "right": labels[:, -1]}
    for name, line in edges.items():
        covered = np.full(len(line), -1)
        mine = [r for r in runs if r.edge == name]
        for r in mine:
            assert r.stop > r.start and np.all(line[r.start : r.stop] == r.label)
            covered[r.start : r.stop] = r.label
        assert np.array_equal(covered, line)
        for a, b in itertools.pairwise(mine):  # maximal runs
            assert a.stop <= b.start and (a.stop < b.start or a.label != b.label)


def test_edge_runs_example():
    lab = np.full((4, 4), -1)
    lab[0, 1:3] = 0
    lab[:, 3] = -2
    assert edge_runs(lab) == [
        EdgeRun("top", 1, 3, 0),
        EdgeRun("top", 3, 4, -2),
        EdgeRun("bottom", 3, 4, -2),
        EdgeRun("right", 0, 4, -2),
    ]


def test_regions_cut_by_the_panel_edge_are_marked(crowd):
    _, viewer, frame = crowd
    runs = viewer.info.cut_edges
    assert runs, "the crowd scene has NAO regions beyond the panel"
    # the band above (or left of) the panel's frame shows the region's darkened colour
    region = [tuple(int(v * 0.6) for v in c) for c in viewer._region_colours()]
    band_colours = {tuple(px) for px in frame[:, 800:].reshape(-1, 3)}
    for run in runs:
        assert region[len(PALETTE) if run.label < 0 else run.label % len(PALETTE)] in band_colours


def test_short_accelerations_are_rings_that_both_show():
    viewer = Viewer()
    surf = viewer.surface
    surf.fill((255, 255, 255))
    # both accelerations about zero (a robot cruising at v_max): green under black
    viewer._arrow((100, 100), (101, 100), GOOD_COLOUR, "desired")
    viewer._arrow((100, 100), (100, 101), (0, 0, 0), "commanded")
    px = pygame.surfarray.array3d(surf)
    assert np.all(px == GOOD_COLOUR, axis=-1).sum() > 20
    assert np.all(px == (0, 0, 0), axis=-1).sum() > 10
    assert viewer.info.short_arrows == ["desired", "commanded"]


def test_at_v_max_the_panel_shows_both_accelerations():
    arena = _arena("roundabout_crossing", 60)
    viewer = Viewer()
    frame = viewer.draw(arena)
    obs = arena.observations()[0]
    assert np.hypot(*obs.velocity) == pytest.approx(obs.v_max, abs=0.05)
    assert viewer.info.short_arrows == ["desired", "commanded"]
    assert np.all(frame[:, 800:] == GOOD_COLOUR, axis=-1).sum() > 20


def _fake_clock(monkeypatch, step: float) -> None:
    ticks = itertools.count()
    monkeypatch.setattr(viewer_module.time, "perf_counter", lambda: step * next(ticks))


@pytest.mark.parametrize("step", [0.001, 2.0])
def test_headless_frames_carry_no_wall_clock(monkeypatch, step):
    arena = Arena(load_map("circle_swap", n=3))
    arena.reset(0)
    reference = Viewer()
    viewer = Viewer()
    for _ in range(3):
        arena.step()
        _fake_clock(monkeypatch, 0.5)
        expected = reference.draw(arena)
        _fake_clock(monkeypatch, step)
        frame = viewer.draw(arena)
        assert np.array_equal(frame, expected)
    assert not any("real time" in t or "steps/s" in t for t in viewer.info.texts)


@pytest.mark.slow
def test_recordings_do_not_depend_on_the_wall_clock(monkeypatch, tmp_path):
    frames = []
    for k, step in enumerate((0.001, 3.0)):
        _fake_clock(monkeypatch, step)
        out = record_episode(
            Arena(load_map("circle_swap", n=3)), tmp_path / f"{k}.gif", max_steps=3, seed=0
        )
        frames.append(np.asarray(iio.mimread(out)))
    assert np.array_equal(frames[0], frames[1])


def test_the_window_shows_the_rate_and_the_keys(monkeypatch):
    arena = Arena(load_map("circle_swap", n=3))
    arena.reset(0)
    viewer = Viewer(human=True)
    try:
        for _ in range(2):
            arena.step()
            viewer.draw(arena)
        texts = viewer.info.texts
        assert any("real time" in t for t in texts)
        line = viewer.keys_line()
        assert line in texts
        for key, _ in KEYS:
            assert key in line
        assert viewer._small.size(line)[0] <= viewer.options.size[0] - viewer.options.size[1] - 28
    finally:
        viewer.close()


def _press(key: int, mod: int = 0, unicode: str = "") -> None:
    pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, mod=mod, unicode=unicode))


def test_keys_cycle_the_selected_robot_and_toggle_the_keys_line():
    arena = Arena(load_map("circle_swap", n=3))
    arena.reset(0)
    viewer = Viewer(human=True)

    def selected() -> str:
        return next(t for t in viewer.info.texts if t.startswith("selected:"))

    try:
        viewer.draw(arena)
        assert selected().startswith("selected: swap0")
        _press(pygame.K_TAB)
        viewer.draw(arena)
        assert selected().startswith("selected: swap1")
        _press(pygame.K_TAB, pygame.KMOD_LSHIFT)
        _press(pygame.K_TAB, pygame.KMOD_LSHIFT)
        viewer.draw(arena)
        assert selected().startswith("selected: swap2")
        _press(pygame.K_h, unicode="h")
        viewer.draw(arena)
        assert not viewer.show_keys and "H or ?: show keys" in viewer.info.texts
        _press(pygame.K_SLASH, pygame.KMOD_LSHIFT, unicode="?")
        viewer.draw(arena)
        assert viewer.show_keys
    finally:
        viewer.close()


def test_readme_lists_every_key():
    text = VIEWER_DOCS.read_text(encoding="utf-8")
    section = text[text.index("## The viewer") :]
    for key, what in KEYS:
        assert f"`{key}`" in section and what in section, key


def test_scale_label_sits_on_a_light_box(crowd):
    _, viewer, frame = crowd
    x, y, w, h = viewer.info.scale_box
    beside = frame[y : y + h, x + w + 1 : x + w + 40]
    assert np.all(beside == WALL_COLOUR, axis=-1).any(), (
        "the crowd scene's bottom wall runs under the scale bar"
    )
    box = frame[y + 1 : y + h - 1, x + 1 : x + w - 1].astype(float)
    assert np.median(box.mean(axis=-1)) > 200
    assert any(re.fullmatch(r"[0-9.]+ m", t) for t in viewer.info.texts)


def _close_neighbour(arena: Arena) -> Observation:
    """Robot 0 of ``arena`` with one neighbour 0.05 m away (surfaces), inside the margin."""
    obs = arena.observations()[0]
    nb = Neighbours(
        ids=np.array([1]),
        kinds=("robot",),
        positions=(obs.position + [0.65, 0.0])[None],
        velocities=np.zeros((1, 2)),
        accelerations=np.zeros((1, 2)),
        radii=np.array([0.3]),
    )
    return dataclasses.replace(
        obs,
        radius=0.3,
        velocity=np.zeros(2),
        neighbours=nb,
        walls=np.zeros((0, 2, 2)),
        wall_radius=np.zeros(0),
    )


def test_the_panel_sees_a_neighbour_inside_the_margin_as_the_agent_does():
    """The panel's obstacles are the agent's (nao_arena.obstacles): a neighbour already
    inside the margin counts with just under its distance (RADIUS_CUT), not with its
    grown radius, which would leave no admissible acceleration on the panel."""
    arena = _arena("circle_swap", 0, n=2, radius=5.0, lo=-8.0, hi=8.0)
    obs = _close_neighbour(arena)
    _, _, path, _ = Viewer()._predictions(arena, 0, obs)
    assert path.radius[0] == pytest.approx(0.65 * RADIUS_CUT) and path.radius[0] < 0.75
    agent = arena.agents[0]
    agent.act(obs)
    np.testing.assert_array_equal(path.radius, agent.last_obstacles().radius)


class _Quiet:
    margin = 0.5  # an attribute, not a panel(): the panel ignores it

    def reset(self, spec, rng):
        pass

    def act(self, obs):
        return np.zeros(2)


class _Shown(_Quiet):
    def panel(self) -> PanelAgent:
        return PanelAgent(margin=0.25, v_pref=0.5, status="adjusted")


def test_the_panel_reads_what_an_agent_reports_through_panel():
    arena = _arena("circle_swap", 1, n=3, radius=5.0, lo=-8.0, hi=8.0)
    assert panel_agent(arena, 0) == arena.agents[0].panel()
    assert panel_agent(arena, 0).status == arena.agents[0].last_selection.status
    arena.agents[1:] = [_Quiet(), _Shown()]
    assert panel_agent(arena, 1) == PanelAgent()
    assert panel_agent(arena, 2) == PanelAgent(margin=0.25, v_pref=0.5, status="adjusted")
    Viewer().draw(arena, selected=2)


def test_the_legend_shows_labels_and_the_walls_region_only_with_walls():
    """An agent given a label is shown by it (not its file reference); a map without
    walls has no walls' region in the legend."""
    arena = Arena(load_map("circle_swap", n=4))
    arena.agent_labels = ["mine"] * 4
    arena.reset(0)
    viewer = Viewer()
    viewer.draw(arena, selected=0)
    labels = [e.label for e in viewer.info.legend]
    assert "mine" in labels and "nao" not in labels
    assert not arena.spec.walls and not arena.spec.bounds.walls
    assert not any("walls' region" in label for label in labels)
    walled = _arena("doorway", 1)
    viewer.draw(walled, selected=0)
    assert any("walls' region" in e.label for e in viewer.info.legend)


@pytest.mark.parametrize(
    "centre", [(50, 50), (1195, 40), (1195, 5), (3, 3), (600, 795), (1199, 799)]
)
def test_a_robots_label_is_never_cut_by_the_views_edge(centre):
    from nao_arena.render.viewer import label_position

    x, y = label_position(centre, 8, (60, 14), (1200, 800))
    assert 0 <= x and x + 60 <= 1200 and 0 <= y and y + 14 <= 800
    if centre == (50, 50):  # room on the upper right: it goes there
        assert (x, y) == (50 + 8 + 5, 50 - 8 - 14)


def test_panel_agents_compare_by_value() -> None:
    """Two reports with equal time grids in distinct arrays are equal (a dataclass's own
    comparison raised on them, and from Python 3.13 on even on the same array)."""
    from nao_arena.agent import PanelAgent

    grid = np.linspace(0.0, 3.0, 31)
    a = PanelAgent(times=grid, margin=0.15, status="kept")
    assert a == PanelAgent(times=grid.copy(), margin=0.15, status="kept")
    assert a == PanelAgent(times=grid, margin=0.15, status="kept")
    assert a != PanelAgent(times=grid + 1e-9, margin=0.15, status="kept")
    assert a != PanelAgent(times=None, margin=0.15, status="kept")
    assert a != PanelAgent(times=grid, margin=0.2, status="kept")
    assert PanelAgent() == PanelAgent()
    assert a != "kept"
