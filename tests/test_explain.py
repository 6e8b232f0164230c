"""Explain a logged contact: the right pair and time, the decisions and predictions of
the step before, the picture, the command."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import imageio.v2 as iio  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

import nao_arena.render.colours as colours  # noqa: E402
from nao_arena.arena import Arena, ArenaOptions  # noqa: E402
from nao_arena.cli import main  # noqa: E402
from nao_arena.episode_log import EpisodeRecorder, read_log, write_log  # noqa: E402
from nao_arena.explain import explain_contact, explain_figure  # noqa: E402
from nao_arena.maps import map_from_dict  # noqa: E402
from nao_arena.trials import make_map  # noqa: E402


def record(spec, seed: int, tmp_path, options=None, max_steps=None, name="episode"):
    arena = Arena(spec, options)
    arena.recorder = EpisodeRecorder()
    summary = arena.run(seed, max_steps=max_steps)
    return summary, read_log(write_log(arena.recorder.finish(), tmp_path / f"{name}.parquet"))


@pytest.fixture(scope="module")
def goal_crowd(tmp_path_factory):
    """Four goal seekers swapping on a perturbed circle (seed 7): several contacts."""
    spec = make_map("circle_swap_perturbed", 7, {"n": 4})
    return record(
        spec, 7, tmp_path_factory.mktemp("goal"), ArenaOptions(agent="goal"), max_steps=120
    )


def test_explain_names_the_pair_and_time_of_each_goal_contact(goal_crowd):
    summary, log = goal_crowd
    robot_contacts = [c for c in summary.contacts if c.kind_b == "robot"]
    assert len(robot_contacts) >= 2
    for number, event in enumerate(summary.contacts, start=1):
        expl = explain_contact(log, number)
        assert expl.contact == event
        a, b = expl.parties
        assert (a.name, b.name) == (event.name_a, event.name_b)
        assert (a.body, b.body) == (event.a, event.b)
        # the decisions of the step before the contact, which began within the next step
        assert log.time[expl.before] < event.time <= log.time[expl.step] + 1e-9
        assert expl.step - 1 == expl.before and log.contacts_by(expl.before) < number
        assert (
            f"Contact {number} of {len(summary.contacts)} at t = {event.time:.2f} s: "
            f"{event.name_a} (goal) and {event.name_b} (goal) touched" in expl.text
        )
        assert f"At t = {log.time[expl.before]:.2f} s, the step before" in expl.text
        for p in expl.parties:
            assert p.status == "desired" and p.predictor is None
            assert np.array_equal(p.chosen, log.commanded[expl.step, p.body])
            np.testing.assert_allclose(p.desired, p.chosen, atol=1e-12)
        assert expl.text.count("took its desired, goal-seeking acceleration") == 2
    with pytest.raises(ValueError, match=f"expected 1 .. {len(summary.contacts)}"):
        explain_contact(log, len(summary.contacts) + 1)


def test_explain_a_nao_contact_shows_the_predictions(tmp_path):
    """The roundabout's one touch between two NAO robots without stopping plans (seed 16,
    turn-rate predictions): both had nothing admissible and braked; each predicted the
    other. With stopping plans (the default) the same episode has no contact."""
    spec = make_map("roundabout", 16, {"predictor": "turn_rate"})
    planned, _ = record(spec, 16, tmp_path, max_steps=90, name="planned")
    assert planned.contacts == []
    summary, log = record(
        spec, 16, tmp_path, ArenaOptions(agent_options={"stopping_plans": False}), max_steps=90
    )
    assert [(c.name_a, c.name_b) for c in summary.contacts] == [("west_east", "south_north")]
    expl = explain_contact(log, 1)
    for p, q in (expl.parties, expl.parties[::-1]):
        assert p.predictor == "turn_rate" and p.status == "infeasible"
        assert p.predicted_other is not None and p.predicted_other.shape == (31, 2)
        # its prediction, made at the step before, is the one the agent computed then
        inputs = log.decision_inputs(expl.step, p.robot)
        j = int(np.flatnonzero(inputs.observation.neighbours.ids == q.body)[0])
        assert np.array_equal(p.predicted_other, inputs.predicted[j])
        assert p.error_at_contact is not None and p.error_at_contact < 0.1
        assert np.dot(p.chosen, p.velocity) < 0  # braking
        assert f"{p.name} predicted {q.name} on an arc at its current turn rate" in expl.text
    assert expl.text.count("nothing admissible from t = ") == 2
    assert expl.text.count("braked (|a| = 3.00 m/s^2 against its velocity)") == 2


def test_explain_a_wall_contact(tmp_path):
    spec = map_from_dict(
        {
            "name": "wall",
            "bounds": {"min": [-2, -4], "max": [12, 4]},
            "walls": [{"type": "segment", "a": [5, -3], "b": [5, 3], "thickness": 0.4}],
            "robots": [{"name": "bumper", "start": [0, 0], "goal": [10, 0], "agent": "goal"}],
        }
    )
    summary, log = record(spec, 0, tmp_path, max_steps=80)
    event = summary.contacts[0]
    assert event.kind_b == "wall"
    expl = explain_contact(log, 1)
    assert [p.kind for p in expl.parties] == ["robot", "wall"]
    assert expl.text.startswith(
        f"Contact 1 of {len(summary.contacts)} at t = "
        f"{event.time:.2f} s: bumper (goal) and wall {event.b} touched"
    )


@pytest.mark.slow
def test_cli_lists_explains_and_draws(goal_crowd, tmp_path, capsys):
    summary, log = goal_crowd
    path = str(log.path)
    assert main(["explain", path]) == 0
    listing = capsys.readouterr().out
    assert listing.count(" t = ") == len(summary.contacts)
    out = tmp_path / "why.png"
    assert main(["explain", path, "--contact", "1", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"Contact 1 of {len(summary.contacts)}") and f"wrote {out}" in printed
    picture = iio.imread(out)
    assert picture.shape[0] >= 800 and picture.shape[1] >= 1400
    assert len(np.unique(picture.reshape(-1, picture.shape[-1]), axis=0)) > 100
    assert main(["explain", path, "--contact", "99"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"nao-arena: error: {path}: --contact: expected 1 .. ")
    assert err.count("\n") == 1


# --------------------------------------------------------------------------- the left plot


def _unit(colour) -> np.ndarray:
    return np.array(colour[:3], dtype=float) / 255.0


def _same_colour(a, b) -> bool:
    return bool(np.allclose(np.asarray(to_rgb(a)), np.asarray(b), atol=1e-6))


def _segment_distance(points, a, b) -> np.ndarray:
    """Distance (m) of points (n, 2) to segment a-b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    s = np.clip((points - a) @ d / (d @ d), 0.0, 1.0)
    return np.hypot(*(points - (a + s[:, None] * d)).T)


def _is_capsule(outline, a, b, half) -> bool:
    """Whether outline (K, 2) m is the capsule of radius half around segment a-b: every
    vertex at half from the segment, reaching half beyond both ends along it."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if not np.allclose(_segment_distance(outline, a, b), half, atol=1e-9):
        return False
    u = (b - a) / np.hypot(*(b - a))
    along = (outline - a) @ u
    length = float(np.hypot(*(b - a)))
    return bool(np.isclose(along.min(), -half) and np.isclose(along.max(), length + half))


def _left_axes(log, expl):
    fig = explain_figure(log, expl)
    return fig.axes[0]


def _legend_texts(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


@pytest.fixture(scope="module")
def walled(tmp_path_factory):
    """A goal seeker driving into a segment wall between bound walls, a polygon wall
    beside its path and a segment wall far beyond it."""
    spec = map_from_dict(
        {
            "name": "walled",
            "bounds": {"min": [-2, -1.2], "max": [12, 1.2], "walls": True, "wall_thickness": 0.2},
            "walls": [
                {"type": "segment", "a": [5, -1.1], "b": [5, 1.1], "thickness": 0.4},
                {"type": "polygon", "points": [[3.5, 0.6], [4.0, 0.6], [4.0, 1.0], [3.5, 1.0]]},
                {"type": "segment", "a": [11, -0.5], "b": [11, 0.5], "thickness": 0.2},
            ],
            "robots": [{"name": "bumper", "start": [0, 0], "goal": [10, 0], "agent": "goal"}],
        }
    )
    summary, log = record(spec, 0, tmp_path_factory.mktemp("walled"), max_steps=80)
    assert [(c.name_a, c.kind_b, c.b) for c in summary.contacts][:1] == [("bumper", "wall", 0)]
    return log


def test_the_picture_draws_the_walls_near_the_contact_as_the_viewer_does(walled):
    log = walled
    ax = _left_axes(log, explain_contact(log, 1))
    walls = [p for p in ax.patches if isinstance(p, Polygon)]
    assert walls and all(_same_colour(p.get_facecolor(), _unit(colours.WALL_COLOUR)) for p in walls)
    outlines = [p.get_xy() for p in walls]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 4.8 < 5.2 < x1 and y0 < 1.0 and y1 > 0.6  # the wall hit, the polygon beside
    # the segment wall hit: a capsule of half its thickness around its end points
    assert sum(_is_capsule(o, (5, -1.1), (5, 1.1), 0.2) for o in outlines) == 1
    # the polygon wall: its vertices
    square = np.array([[3.5, 0.6], [4.0, 0.6], [4.0, 1.0], [3.5, 1.0]])
    assert sum(o.shape == (5, 2) and np.allclose(o[:4], square) for o in outlines) == 1
    # the bound walls within reach (y = +-1.2, 0.1 m thick); not the far wall at x = 11
    bottom, top = ((12, -1.2), (-2, -1.2)), ((12, 1.2), (-2, 1.2))
    for a, b in (bottom, top):
        assert sum(_is_capsule(o, a, b, 0.1) or _is_capsule(o, b, a, 0.1) for o in outlines) == 1
    assert x1 < 10.9 and not any(_is_capsule(o, (11, -0.5), (11, 0.5), 0.1) for o in outlines)
    assert len(walls) == 4
    texts = _legend_texts(ax)
    assert "walls" in texts and not any(t.startswith("traffic") for t in texts)
    # the robot in its viewer colour (agent goal)
    goal = _unit(colours.AGENT_COLOURS["goal"])
    went = [line for line in ax.get_lines() if line.get_label().startswith("bumper: where")]
    assert len(went) == 1 and _same_colour(went[0].get_color(), goal)


@pytest.fixture(scope="module")
def car_contact(tmp_path_factory):
    """The roundabout's robot-car contact (seed 3, constant-velocity predictions)."""
    spec = make_map("roundabout", 3, {"predictor": "constant_velocity"})
    summary, log = record(spec, 3, tmp_path_factory.mktemp("car"), max_steps=140)
    assert [(c.name_a, c.name_b, c.kind_b) for c in summary.contacts] == [
        ("west_east", "outer_5", "traffic")
    ]
    return log


def _at(log, body: int, t: float) -> np.ndarray:
    p = log.positions[:, body]
    return np.array([np.interp(t, log.time, p[:, 0]), np.interp(t, log.time, p[:, 1])])


def _discs_at(ax, centre, radius) -> list[Circle]:
    return [
        c
        for c in ax.patches
        if isinstance(c, Circle)
        and np.allclose(c.center, centre, atol=1e-9)
        and np.isclose(c.radius, radius)
    ]


def test_the_picture_draws_the_traffic_near_the_contact_in_the_viewer_colours(car_contact):
    log = car_contact
    expl = explain_contact(log, 1)
    ev = expl.contact
    ax = _left_axes(log, expl)
    radii = log.scene().world.radii
    traffic = _unit(colours.AGENT_COLOURS["traffic"])
    # the car touched: its disc at the contact, in the traffic colour
    car = _discs_at(ax, _at(log, ev.b, ev.time), radii[ev.b])
    assert car and all(_same_colour(c.get_edgecolor(), traffic) for c in car)
    # every other car whose disc at the contact lies in the plot: drawn there, in traffic colour
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    robots = set(log.robot_ids.tolist())
    others = []
    for i in range(log.n_bodies):
        at = _at(log, i, ev.time)
        if i in robots or i == ev.b or not (x0 < at[0] < x1 and y0 < at[1] < y1):
            continue
        others.append(i)
        discs = _discs_at(ax, at, radii[i])
        assert len(discs) == 1 and _same_colour(discs[0].get_edgecolor(), traffic)
    assert others
    assert any(t.startswith("traffic nearby (") for t in _legend_texts(ax))
    assert "walls" not in _legend_texts(ax)
    # the robot in its viewer colour (agent nao), the contact ring in the viewer's red
    nao = _unit(colours.AGENT_COLOURS["nao"])
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert _same_colour(lines["west_east: where it went (3.0 s)"].get_color(), nao)
    assert _same_colour(lines["outer_5: where it went (3.0 s)"].get_color(), traffic)
    ring = lines[f"contact at t = {ev.time:.2f} s"]
    assert _same_colour(ring.get_markeredgecolor(), _unit(colours.CONTACT_COLOUR))
    # the prediction in the viewer's colour of that neighbour (its path and its NAO)
    robot = expl.parties[0]
    ids = log.decision_inputs(expl.step, robot.robot).observation.neighbours.ids
    j = int(np.flatnonzero(ids == ev.b)[0])
    assert robot.neighbour == j
    predicted = lines["outer_5 as west_east predicted it (constant_velocity)"]
    assert _same_colour(predicted.get_color(), _unit(colours.PALETTE[j % len(colours.PALETTE)]))


def test_a_person_who_appears_is_drawn_on_the_map_and_named_a_person(tmp_path):
    """A recorded person appears at t = 1 s beside a robot creeping away and walks into it:
    before it appears it waits far off the map, which the picture neither draws nor
    boxes; the text and legend call it a person, not traffic."""
    path = tmp_path / "appear.txt"
    rows = [(f, 9, 0.6 - 0.06 * (f - 10), 0.0) for f in range(10, 40)]
    rows += [(f, 8, -2.0 + 0.05 * f, 1.0) for f in range(0, 40)]  # a person passing by
    path.write_text("\n".join(f"{f} {i} {x} {y}" for f, i, x, y in rows) + "\n")
    spec = map_from_dict(
        {
            "name": "appear",
            "bounds": {"min": [-6, -6], "max": [6, 6]},
            "robots": [
                {
                    "name": "r",
                    "start": [-0.5, 0.0],
                    "goal": [-0.5, -5.0],
                    "agent": "goal",
                    "v_max": 0.1,
                }
            ],
            "traffic": [{"type": "recorded", "file": str(path), "format": "xy", "fps": 10.0}],
            "episode": {"time_limit": 4.0},
        }
    )
    summary, log = record(spec, 0, tmp_path)
    number = next(k for k, c in enumerate(summary.contacts, start=1) if c.kind_b == "person")
    expl = explain_contact(log, number)
    assert " (person) touched" in expl.text and "(traffic)" not in expl.text
    ax = _left_axes(log, expl)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert -16 < x0 < x1 < 16 and -16 < y0 < y1 < 16  # not stretched to the waiting place
    for line in ax.get_lines():
        xy = np.asarray(line.get_xydata(), dtype=float)
        assert np.all(np.abs(xy[np.isfinite(xy).all(axis=1)]) < 16), line.get_label()
    assert any(t.startswith("people nearby (1)") for t in _legend_texts(ax))
