"""The paper's figures and the report's plots explain what they draw: legends, captions,
intervals and labels that do not overlap (checked on the matplotlib objects)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402
from matplotlib.container import BarContainer, ErrorbarContainer  # noqa: E402
from matplotlib.patches import FancyArrow  # noqa: E402

from nao_arena import report  # noqa: E402
from nao_arena.figures import (  # noqa: E402
    FIGURES,
    SOLID_SIDE,
    grazing_side,
    moving,
    sampled,
    write_figures,
)


def test_grazing_side_of_a_straight_pass():
    # at 1 m/s along x, the robot grazes a disc of radius 1 m centred 1 m off its line at t = 5 s
    a = np.zeros((1, 2))
    assert grazing_side(a, np.array([5.0]), (1.0, 0.0), moving((5.0, 1.0))) == "left"
    assert grazing_side(a, np.array([5.0]), (1.0, 0.0), moving((5.0, -1.0))) == "right"
    # judged along the velocity relative to the obstacle: an obstacle overtaking the robot
    # (at 3 m/s, level with it at t = 5 s) passes on its right
    assert grazing_side(a, np.array([5.0]), (1.0, 0.0), moving((-10.0, 1.0), (3.0, 0.0))) == "right"
    t = np.linspace(0.0, 10.0, 11)
    assert (
        grazing_side(
            a,
            np.array([5.0]),
            (1.0, 0.0),
            sampled(t, np.stack([np.full(11, 5.0), np.full(11, 1.0)], 1)),
        )
        == "left"
    )
    assert (
        grazing_side(np.full((1, 2), np.nan), np.array([1.0]), (1.0, 0.0), moving((1.0, 1.0)))
        is None
    )


def _draw(name: str):
    fig, ax = plt.subplots()
    caption = FIGURES[name](ax)
    return fig, ax, caption


@pytest.fixture(scope="module")
def nao_paths():
    fig, ax, caption = _draw("nao_paths")
    yield ax, caption
    plt.close(fig)


def _labels(ax) -> dict[str, object]:
    legend = ax.get_legend()
    assert legend is not None
    return {t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles, strict=True)}


def test_nao_paths_explains_lines_arrow_and_circle(nao_paths):
    ax, caption = nao_paths
    labels = _labels(ax)
    solid = [h for t, h in labels.items() if t.startswith("boundary") and SOLID_SIDE in t]
    dashed = [h for t, h in labels.items() if t.startswith("boundary") and "left" in t]
    assert solid and solid[0].get_linestyle() == "-"
    assert dashed and dashed[0].get_linestyle() == "--"
    arrow = [t for t, h in labels.items() if isinstance(h, FancyArrow)]
    assert arrow and "selected" in arrow[0]
    circle = [t for t in labels if t.startswith("limit |a|")]
    assert circle and labels[circle[0]].get_linestyle() == "--"
    assert any("colliding" in t for t in labels)
    assert [t for t in labels if t.startswith("NAO B")] == [f"NAO B{i}" for i in range(1, 5)]
    assert "v = (3, 0) m/s" in caption and "t_h = 6 s" in caption


def test_nao_paths_boundary_styles_follow_the_grazing_side(nao_paths):
    # both styles are drawn: every obstacle's two branches differ
    ax, _ = nao_paths
    styles = {line.get_linestyle() for line in ax.get_lines()}
    assert {"-", "--"} <= styles


@pytest.mark.slow
def test_ao_trajectories_legend_names_both_colours():
    fig, ax, caption = _draw("ao_trajectories")
    try:
        labels = _labels(ax)
        paths = {t: h for t, h in labels.items() if t.startswith("path of")}
        assert len(paths) == 2
        colours = {to_rgba(h.get_color()) for h in paths.values()}
        drawn = {to_rgba(line.get_color()) for line in ax.get_lines() if len(line.get_xdata()) > 2}
        assert colours == drawn and len(colours) == 2  # blue and purple, both explained
        assert {t.rsplit(" ", 1)[-1] for t in paths} == {"left", "right"}
        assert any("obstacle" in t for t in labels) and any("t = 0" in t for t in labels)
        assert "8 s" in caption
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_every_figure_has_a_legend_and_a_caption():
    for name in FIGURES:
        fig, ax, caption = _draw(name)
        try:
            assert ax.get_legend() is not None, name
            assert caption and "m/s" in caption, name
        finally:
            plt.close(fig)


def test_write_figures_puts_the_caption_in_the_png(tmp_path):
    paths = write_figures(tmp_path, ["ao_trajectories"])
    assert [p.name for p in paths] == ["ao_trajectories.png"]
    image = plt.imread(paths[0])
    assert image.shape[0] > 6 * 110  # the 6 in x 6 in axes, then legend and caption below


# --------------------------------------------------------------------------- report figures


def _robot_rows(agents, per_cell=100, maps=("roundabout",)):
    """episodes.parquet-like rows: two robots per episode, all arrived."""
    rows = []
    for m in maps:
        for a in agents:
            for k in range(per_cell):
                rows.append(
                    {
                        "map": m,
                        "agent": a,
                        "episode": k // 2,
                        "error": None,
                        "reached_goal": True,
                        "time_to_goal": 15.0 + (k % 7),
                        "duration": 40.0,
                        "adjustments": 20 + k % 5,
                        "min_separation": 0.1,
                    }
                )
    return rows


def test_time_to_goal_tick_labels_do_not_overlap():
    agents = ["nao", "ao", "vo", "orca", "goal"]
    fig = report._time_to_goal(_robot_rows(agents), ["roundabout", "two_lane_road"], agents)
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        ticks = [t for t in ax.get_xticklabels() if t.get_text()]
        assert ticks and all("100/100" in t.get_text() for t in ticks if ax.has_data())
        boxes = [t.get_window_extent(renderer) for t in ticks]
        assert not report._overlapping(boxes)
        assert "arrived" in ax.get_xlabel()


def test_time_to_goal_turns_long_agent_labels():
    agents = [f"custom_agent_number_{k}" for k in range(5)]
    fig = report._time_to_goal(_robot_rows(agents), ["roundabout"], agents)
    assert all(t.get_rotation() == 30 for t in fig.axes[0].get_xticklabels())


def test_adjustment_rate_interval_by_hand():
    rows = [
        {
            "episode": 0,
            "error": None,
            "adjustments": 4,
            "reached_goal": True,
            "time_to_goal": 4.0,
            "duration": 9.0,
        },
        {
            "episode": 0,
            "error": None,
            "adjustments": 6,
            "reached_goal": False,
            "time_to_goal": None,
            "duration": 6.0,
        },  # drove the whole episode
        {
            "episode": 1,
            "error": None,
            "adjustments": 30,
            "reached_goal": True,
            "time_to_goal": 10.0,
            "duration": 20.0,
        },
        {
            "episode": 2,
            "error": "AgentError: boom",
            "adjustments": None,
            "reached_goal": None,
            "time_to_goal": None,
            "duration": None,
        },
    ]
    # episodes: a = 10, 30; driven = 10, 10 s: rate 2/s, residuals -10, 10,
    # variance 2/1 * 200 / 20^2 = 1
    rate, lo, hi = report.adjustment_rate_ci95(rows)
    assert rate == pytest.approx(2.0) and lo == pytest.approx(0.04) and hi == pytest.approx(3.96)
    _, lo4, hi4 = report.adjustment_rate_ci95(rows, repeats=4.0)
    assert hi4 - 2.0 == pytest.approx(2 * (hi - 2.0)) and lo4 == 0.0
    assert report.adjustment_rate_ci95(rows[:2]) is None  # a single episode


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 50), st.floats(0.5, 60.0)), min_size=2, max_size=12))
def test_adjustment_rate_interval_contains_the_summary_rate(episodes):
    rows = [
        {
            "episode": k,
            "error": None,
            "adjustments": a,
            "reached_goal": False,
            "time_to_goal": None,
            "duration": d,
        }
        for k, (a, d) in enumerate(episodes)
    ]
    rate, lo, hi = report.adjustment_rate_ci95(rows)
    assert rate == pytest.approx(sum(a for a, _ in episodes) / sum(d for _, d in episodes))
    assert 0.0 <= lo <= rate <= hi


def test_rates_figure_has_adjustment_intervals_and_definition():
    agents = ["nao", "ao"]
    rows = _robot_rows(agents, per_cell=20)
    summary = []
    for a in agents:
        mine = [r for r in rows if r["agent"] == a]
        driven = sum(r["time_to_goal"] for r in mine)
        summary.append(
            {
                "map": "roundabout",
                "agent": a,
                "episodes": 10,
                "failed_episodes": 0,
                "distinct_episodes": 10,
                "robots": 20,
                "robots_collided": 0,
                "collision_rate": 0.0,
                "collision_rate_ci95": [0.0, 0.16],
                "adjustments_per_s": sum(r["adjustments"] for r in mine) / driven,
            }
        )
    fig = report._rates(summary, rows, ["roundabout"], agents)
    ax_a = fig.axes[1]
    bars = [c for c in ax_a.containers if isinstance(c, BarContainer)]
    whiskers = [c for c in ax_a.containers if isinstance(c, ErrorbarContainer)]
    assert len(bars) == 1 and len(whiskers) == 1
    segments = whiskers[0].lines[2][0].get_segments()
    for a, seg in zip(agents, segments, strict=True):
        _, lo, hi = report.adjustment_rate_ci95([r for r in rows if r["agent"] == a])
        assert seg[0][1] == pytest.approx(lo) and seg[1][1] == pytest.approx(hi) and hi > lo
    assert "per second driven" in ax_a.get_ylabel()
    caption = fig.get_supxlabel()
    assert caption.startswith("Adjustment:") and "0.1 m/s^2" in caption


@given(
    st.lists(
        st.tuples(
            st.sampled_from(["nao", "orca"]),
            st.booleans(),  # among people
            st.one_of(st.none(), st.just(float("nan")), st.floats(-0.3, 0.99)),
        ),
        min_size=1,
        max_size=30,
    )
)
@settings(max_examples=25, deadline=None)
def test_people_distance_histograms_count_the_robot_episodes_among_people(cells):
    """Each panel's note and bars count what an independent tally of the rows gives:
    robot-episodes among people only, contacts below 0, null or NaN as never within."""
    agents = ["nao", "orca"]
    rows = [
        {"map": "eth", "agent": a, "error": None, "among_people": among, "min_person_distance": d}
        for a, among, d in cells
    ]
    fig = report._histograms(rows, ["eth"], agents, report.PEOPLE_DISTANCE)
    for ax, a in zip(fig.axes, agents, strict=True):
        mine = [d for b, among, d in cells if b == a and among]
        measured = [d for d in mine if d is not None and not np.isnan(d)]
        note = f"{len(mine)} robot-episodes, {sum(d < 0 for d in measured)} with contact"
        if len(mine) > len(measured):
            note += f", {len(mine) - len(measured)} never within range"
        assert [t.get_text() for t in ax.texts] == [note]
        assert sum(p.get_height() for p in ax.patches) == len(measured)
    plt.close(fig)
