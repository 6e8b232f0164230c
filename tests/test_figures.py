"""The paper's figures explain what they draw: legends (matplotlib objects) and captions."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402
from matplotlib.patches import FancyArrow  # noqa: E402

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
    assert grazing_side(a, np.array([5.0]), (1.0, 0.0), moving((-10.0, 1.0), (3.0, 0.0))) \
        == "right"
    t = np.linspace(0.0, 10.0, 11)
    assert grazing_side(a, np.array([5.0]), (1.0, 0.0),
                        sampled(t, np.stack([np.full(11, 5.0), np.full(11, 1.0)], 1))) == "left"
    assert grazing_side(np.full((1, 2), np.nan), np.array([1.0]), (1.0, 0.0),
                        moving((1.0, 1.0))) is None


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
    return {t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles,
                                             strict=True)}


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


def test_ao_trajectories_legend_names_both_colours():
    fig, ax, caption = _draw("ao_trajectories")
    try:
        labels = _labels(ax)
        paths = {t: h for t, h in labels.items() if t.startswith("path of")}
        assert len(paths) == 2
        colours = {to_rgba(h.get_color()) for h in paths.values()}
        drawn = {to_rgba(line.get_color()) for line in ax.get_lines()
                 if len(line.get_xdata()) > 2}
        assert colours == drawn and len(colours) == 2  # blue and purple, both explained
        assert {t.rsplit(" ", 1)[-1] for t in paths} == {"left", "right"}
        assert any("obstacle" in t for t in labels) and any("t = 0" in t for t in labels)
        assert "8 s" in caption
    finally:
        plt.close(fig)


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
