"""Why did these two touch? The step before a logged contact, for both parties.

:func:`explain_contact` reads contact K (1 = first, in the order of the
episode's summary) of an :class:`~nao_arena.episode_log.EpisodeLog`: the
decision each robot took at the last state before the contact (the state
of the row before the one that reported it), the acceleration it chose and
its status, and, for robots whose agent predicts its neighbours (``nao``,
``ao``), where it predicted the other would be against where the other
went. :attr:`Explanation.text` sums it up in one paragraph (what ``nao-arena
explain`` prints); :func:`explain_figure` draws it: the two paths against
the predictions, among the walls and the other bodies near them (world
frame, m, in the viewer's colours, :mod:`nao_arena.render.colours`), beside
each robot's acceleration panel as the viewer draws it at that step, with the
decision taken there.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Collection
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from nao_arena.agents.goal import goal_seeking_accel
from nao_arena.episode_log import EpisodeLog
from nao_arena.maps import MapSpec, SegmentWall
from nao_arena.stats import ContactEvent

if TYPE_CHECKING:  # matplotlib and the viewer load only when a picture is drawn
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from nao_arena.render.colours import Colour
    from nao_arena.render.viewer import ViewerOptions

__all__ = [
    "Explanation",
    "Party",
    "explain_contact",
    "explain_figure",
    "explain_picture",
    "on_map",
    "write_explanation",
]

LOOK_BACK = 1.0
"""How long before the contact (s) the earlier prediction of the text was made."""

_PREDICTOR_PHRASE = {
    "constant_velocity": "on a straight line at constant speed",
    "constant_acceleration": "under constant acceleration",
    "turn_rate": "on an arc at its current turn rate",
    "known_path": "along its known path",
    "shared_plan": "under its shared plan",
}


@dataclass(frozen=True)
class Party:
    """One side of a contact.

    body: body index (for a wall: the wall index); kind: "robot", "traffic" or "wall";
    robot: robot index (None: not a robot); agent: the agent's label; status: the
    decision status at the step before the contact (see
    :data:`~nao_arena.episode_log.STATUSES`), selection: the status of its last full
    selection; chosen, desired: the acceleration it chose there and its goal-seeking
    one (m/s^2); velocity (m/s) there; predictor: the predictor it used (None: it
    predicts nothing); times (s, from the step before) and predicted_other (T, 2) m:
    where it predicted the other would be (None: not sensed, or no predictions);
    error_at_contact: distance (m) between that prediction and where the other was at
    the contact's start; status_since: time (s) of the state from which its current
    status (the same status, or nothing admissible) holds without a break; neighbour:
    the other's index among the neighbours it sensed then, nearest first (the viewer
    colours that neighbour's prediction and NAO by it; None: not sensed).
    """

    body: int
    name: str
    kind: str
    robot: int | None = None
    agent: str | None = None
    status: str | None = None
    selection: str | None = None
    chosen: NDArray[np.float64] | None = None
    desired: NDArray[np.float64] | None = None
    velocity: NDArray[np.float64] | None = None
    predictor: str | None = None
    times: NDArray[np.float64] | None = None
    predicted_other: NDArray[np.float64] | None = None
    error_at_contact: float | None = None
    status_since: float | None = None
    neighbour: int | None = None


@dataclass(frozen=True)
class Explanation:
    """Contact ``number`` (1-based) of a log: the event, the row that reported it
    (``step``), the row of the state before it (``before`` = step - 1, the state the
    decisions were taken at), both parties and the one-paragraph summary ``text``."""

    number: int
    contact: ContactEvent
    step: int
    before: int
    parties: tuple[Party, ...]
    text: str


# --------------------------------------------------------------------------- analysis


def _position_at(log: EpisodeLog, body: int, t: float) -> NDArray[np.float64]:
    """A body's centre (m) at time t (s), linear between rows."""
    p = log.positions[:, body]
    return np.array([np.interp(t, log.time, p[:, 0]), np.interp(t, log.time, p[:, 1])])


def _prediction_of(
    log: EpisodeLog, step: int, robot: int, other: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], int] | None:
    """(times (T,) s from the state of row step - 1, predicted centres (T, 2) m, the
    other's index among the sensed neighbours) of body ``other`` by robot ``robot`` for
    its decision of row ``step``; None if it predicts nothing or did not sense the other."""
    inputs = log.decision_inputs(step, robot)
    if inputs.predicted is None or inputs.times is None:
        return None
    ids = inputs.observation.neighbours.ids
    hit = np.flatnonzero(ids == other)
    if not len(hit):
        return None
    j = int(hit[0])
    return inputs.times, inputs.predicted[j], j


def _predicted_at(
    times: NDArray[np.float64], path: NDArray[np.float64], tau: float
) -> NDArray[np.float64] | None:
    """The predicted centre (m) tau s after the prediction (None beyond its horizon)."""
    if tau > float(times[-1]) + 1e-9:
        return None
    return np.array([np.interp(tau, times, path[:, 0]), np.interp(tau, times, path[:, 1])])


def _status_since(log: EpisodeLog, step: int, robot: int) -> float | None:
    """Time (s) of the state from which robot ``robot``'s decisions up to row ``step``
    have had its row-``step`` status (for "kept" and "repaired": since its last full
    selection), None in row 0."""
    status = log.status_of(step, robot)
    if status is None:
        return None
    same = {status} if status not in ("kept", "repaired") else {"kept", "repaired"}
    r = step
    while r > 1 and log.status_of(r - 1, robot) in same:
        r -= 1
    if status in ("kept", "repaired") and r > 1:
        r -= 1  # the full selection it kept
    return float(log.time[r - 1])


def _party(log: EpisodeLog, step: int, body: int, kind: str, name: str) -> Party:
    """A party of the contact reported in row ``step`` (its decision at row step - 1)."""
    if kind != "robot":
        return Party(body=body, name=name, kind=kind)
    robot = int(np.flatnonzero(log.robot_ids == body)[0])
    info = log.robots[robot]
    obs = log.decision_inputs(step, robot).observation
    detour = float(log.detour[step, robot])
    desired = goal_seeking_accel(
        obs, info.v_pref, heading_offset=0.0 if detour != detour else detour
    )
    return Party(
        body=body,
        name=name,
        kind=kind,
        robot=robot,
        agent=info.label,
        status=log.status_of(step, robot),
        selection=log.selection_of(step, robot),
        chosen=np.array(log.commanded[step, body]),
        desired=desired,
        velocity=np.array(log.velocities[step - 1, body]),
        predictor=info.predictor,
        times=info.times,
        status_since=_status_since(log, step, robot),
    )


def _with_prediction(
    log: EpisodeLog, step: int, party: Party, other: Party, t_contact: float
) -> Party:
    if party.robot is None or other.kind == "wall":
        return party
    pred = _prediction_of(log, step, party.robot, other.body)
    if pred is None:
        return party
    times, path, j = pred
    tau = t_contact - float(log.time[step - 1])
    at = _predicted_at(times, path, tau)
    err = None if at is None else float(np.hypot(*(at - _position_at(log, other.body, t_contact))))
    return replace(party, times=times, predicted_other=path, error_at_contact=err, neighbour=j)


def explain_contact(log: EpisodeLog, number: int) -> Explanation:
    """Explain contact ``number`` (1 = the first) of the log; ValueError naming the
    contacts there are if it has no such contact."""
    contacts = log.contacts
    if not contacts:
        raise ValueError("the episode has no contact to explain")
    if not 1 <= number <= len(contacts):
        raise ValueError(
            f"--contact: expected 1 .. {len(contacts)} (the episode's contacts), got {number}"
        )
    ev = contacts[number - 1]
    step = int(log.contact_steps[number - 1])
    if step < 1:
        raise ValueError(f"contact {number} was reported at the reset: no step before it")
    a = _party(log, step, ev.a, ev.kind_a, ev.name_a)
    b = _party(log, step, ev.b, ev.kind_b, ev.name_b if ev.kind_b != "wall" else f"wall {ev.b}")
    a, b = (_with_prediction(log, step, a, b, ev.time), _with_prediction(log, step, b, a, ev.time))
    text = _summary(log, number, ev, step, (a, b))
    return Explanation(number, ev, step, step - 1, (a, b), text)


# --------------------------------------------------------------------------- the text


def _angle(v: NDArray[np.float64]) -> float:
    return math.atan2(float(v[1]), float(v[0]))


def _motion(log: EpisodeLog, body: int, t0: float, t1: float) -> str:
    """How body moved between t0 and t1 (s): turned, braked, sped up or kept its course."""
    r0, r1 = log.step_at(t0), log.step_at(t1)
    v0, v1 = log.velocities[r0, body], log.velocities[r1, body]
    s0, s1 = float(np.hypot(*v0)), float(np.hypot(*v1))
    parts = []
    if s0 > 0.05 and s1 > 0.05:
        turn = math.degrees((_angle(v1) - _angle(v0) + math.pi) % (2 * math.pi) - math.pi)
        if abs(turn) >= 10.0:
            parts.append(f"turned {'left' if turn > 0 else 'right'} by {abs(turn):.0f} deg")
    if s1 < 0.8 * s0 - 0.05:
        parts.append(f"braked from {s0:.2f} to {s1:.2f} m/s")
    elif s1 > 1.2 * s0 + 0.05:
        parts.append(f"sped up from {s0:.2f} to {s1:.2f} m/s")
    if not parts:
        return f"kept its course ({s1:.2f} m/s)"
    return " and ".join(parts)


def _decision_phrase(p: Party) -> str:
    """What a robot decided at the step before, and why (its status)."""
    assert p.chosen is not None and p.velocity is not None
    a = float(np.hypot(*p.chosen))
    since = "" if p.status_since is None else f" from t = {p.status_since:.1f} s"
    status = p.status
    if status == "infeasible":
        braking = float(np.dot(p.chosen, p.velocity)) < 0.0
        then = (
            f"braked (|a| = {a:.2f} m/s^2 against its velocity)"
            if braking
            else f"took the acceleration that postponed the contact longest (|a| = {a:.2f} m/s^2)"
        )
        return f"nothing admissible{since}; {then}"
    if status == "yielded":
        return (
            f"braked{since} (|a| = {a:.2f} m/s^2 against its velocity): its choice "
            f"would have met another robot's stopping plan (status yielded)"
        )
    if status == "fault":
        return "its agent failed at that step (fault): zero acceleration"
    if status == "external":
        return "it was driven from outside (external action)"
    if p.predictor is None and status == "desired":
        return (
            f"took its desired, goal-seeking acceleration ({a:.2f} m/s^2; "
            f"status desired{since}: the {p.agent} agent did not deviate from it)"
        )
    if p.predictor is None:
        return f"deviated from goal seeking (status adjusted{since}, |a| = {a:.2f} m/s^2)"
    what = {
        "desired": "its desired acceleration was admissible: took it",
        "adjusted": "took the admissible acceleration nearest its desired one (adjusted)",
        "kept": f"kept its acceleration (still admissible; last full selection: {p.selection})",
        "repaired": "repaired its adjustment locally (it had become inadmissible)",
    }.get(status or "", f"status {status}")
    return f"{what}{since}, |a| = {a:.2f} m/s^2"


def _summary(
    log: EpisodeLog, number: int, ev: ContactEvent, step: int, parties: tuple[Party, Party]
) -> str:
    a, b = parties
    t_before = float(log.time[step - 1])

    def who(p: Party) -> str:
        if p.kind == "robot":
            return f"{p.name} ({p.agent})"
        return p.name if p.kind == "wall" else f"{p.name} ({p.kind})"

    sentences = [
        f"Contact {number} of {len(log.contact_steps)} at t = {ev.time:.2f} s: {who(a)} and "
        f"{who(b)} touched at {ev.impact_speed:.2f} m/s ({1000 * ev.max_penetration:.1f} mm "
        f"deep at most)."
    ]
    parts = []
    early = max(0.0, ev.time - LOOK_BACK)
    for p, q in ((a, b), (b, a)):
        if p.kind == "traffic":
            parts.append(f"{p.name} is a traffic vehicle following its lane")
            continue
        if p.kind != "robot":
            continue
        line = f"{p.name} {_decision_phrase(p)}"
        if q.kind == "wall":
            parts.append(line)
            continue
        if p.predictor is None:
            parts.append(line + "; it predicts nothing of its neighbours")
            continue
        phrase = _PREDICTOR_PHRASE.get(p.predictor, f"with {p.predictor}")
        if p.predicted_other is None:
            parts.append(line + f"; it had not sensed {q.name}")
            continue
        # the prediction LOOK_BACK s before, against what the other then did
        r_early = max(1, log.step_at(early) + 1)
        pred = _prediction_of(log, r_early, p.robot, q.body) if p.robot is not None else None
        earlier = ""
        if pred is not None and r_early < step:
            at = _predicted_at(pred[0], pred[1], ev.time - float(log.time[r_early - 1]))
            if at is not None:
                off = float(np.hypot(*(at - _position_at(log, q.body, ev.time))))
                earlier = (
                    f"; its prediction at t = {log.time[r_early - 1]:.1f} s was {off:.2f} m off"
                )
        err = (
            ""
            if p.error_at_contact is None
            else f" ({p.error_at_contact:.2f} m off at the contact{earlier})"
        )
        moved = _motion(log, q.body, float(log.time[r_early - 1]), ev.time)
        parts.append(
            f"{p.name} predicted {q.name} {phrase}{err}; {q.name} {moved}; "
            f"{line[len(p.name) + 1 :]}"
        )
    if parts:
        sentences.append(f"At t = {t_before:.2f} s, the step before: " + "; ".join(parts) + ".")
    return " ".join(sentences)


# --------------------------------------------------------------------------- the picture


def explain_figure(
    log: EpisodeLog, expl: Explanation, options: ViewerOptions | None = None
) -> Figure:
    """A matplotlib Figure of the explanation: the paths and predictions around the pair
    with the walls and other bodies near them (left, world frame, m, in the viewer's
    colours) and the robots' acceleration panels at the step before, as the viewer draws
    them (with the decision taken there), and the text."""
    from matplotlib.figure import Figure

    from nao_arena.render.replay import Replayer
    from nao_arena.render.viewer import ViewerOptions

    robots = [p for p in expl.parties if p.robot is not None]
    fig = Figure(figsize=(6.0 + 4.2 * len(robots), 9.0), dpi=100, layout="constrained")
    grid = fig.add_gridspec(
        2, 1 + len(robots), height_ratios=[8.2, 1.6], width_ratios=[6.0] + [4.2] * len(robots)
    )
    vopts = options or ViewerOptions()
    replayer = Replayer(log, options=vopts)
    ax = fig.add_subplot(grid[0, 0])
    _draw_paths(ax, log, expl, replayer.arena.controlled)
    h = vopts.size[1]
    for i, p in enumerate(robots):
        assert p.robot is not None
        frame = replayer.frame(expl.before, selected=p.robot, decision=True)
        pax = fig.add_subplot(grid[0, 1 + i])
        pax.imshow(frame[:, h:])
        pax.set_axis_off()
        pax.set_title(
            f"{p.name} ({p.agent}): decision at t = {log.time[expl.before]:.2f} s"
            f"\nstatus {p.status}",
            fontsize="medium",
        )
    tax = fig.add_subplot(grid[1, :])
    tax.set_axis_off()
    chars = int((6.0 + 4.2 * len(robots)) * 100 / 8.0)  # about 8 px per character
    tax.text(
        0.0,
        1.0,
        textwrap.fill(expl.text, chars),
        va="top",
        ha="left",
        fontsize="medium",
        transform=tax.transAxes,
    )
    return fig


@dataclass(frozen=True)
class _Window:
    """What the left plot shows: log rows first <= before <= last (the look-back, the
    state before the contact, the end of the longest horizon), the contact's time (s)
    and the square box lo .. hi (m) around the pair."""

    first: int
    before: int
    last: int
    t_contact: float
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]

    def holds(self, points: NDArray[np.float64], margin: float = 0.0) -> bool:
        """Whether any of points (n, 2) m lies in the box grown by margin (m)."""
        inside = (points >= self.lo - margin) & (points <= self.hi + margin)
        return bool(np.any(np.all(inside, axis=1)))


def _body_colour(log: EpisodeLog, body: int, controlled: Collection[int] = ()) -> Colour:
    """The viewer's fill colour of a body: a robot's by its agent's label (red when
    driven from outside, robot indices ``controlled``), else a recorded person's or the
    traffic's colour."""
    from nao_arena.render.colours import body_colour, robot_colour

    hit = np.flatnonzero(log.robot_ids == body)
    if not len(hit):
        return body_colour(log.state(0).kinds[body])
    k = int(hit[0])
    return robot_colour(log.robots[k].label, k in set(controlled))


def _capsule(a: NDArray[np.float64], b: NDArray[np.float64], half: float) -> NDArray[np.float64]:
    """The outline (K, 2) m of the capsule of radius ``half`` (m) around segment a-b (m)."""
    d = b - a
    theta = math.atan2(float(d[1]), float(d[0])) if float(np.hypot(*d)) > 0.0 else 0.0
    arc = theta + np.linspace(-0.5 * math.pi, 0.5 * math.pi, 13)
    around_b = b + half * np.stack([np.cos(arc), np.sin(arc)], axis=1)
    around_a = a + half * np.stack([np.cos(arc + math.pi), np.sin(arc + math.pi)], axis=1)
    return np.vstack([around_b, around_a])


def _wall_outlines(spec: MapSpec) -> list[NDArray[np.float64]]:
    """The map's walls as the viewer draws them, as closed outlines (K, 2) m: segment
    walls and the bound walls as capsules of half their thickness, polygon walls as
    their polygons."""
    out = []
    for wall in spec.walls:
        if isinstance(wall, SegmentWall):
            out.append(_capsule(np.array(wall.a), np.array(wall.b), wall.thickness / 2))
        else:
            out.append(np.asarray(wall.points, dtype=float))
    half = spec.bounds.wall_thickness / 2
    for a, b in spec.bound_wall_segments():
        out.append(_capsule(np.array(a, dtype=float), np.array(b, dtype=float), half))
    return out


def _draw_walls(ax: Axes, spec: MapSpec, win: _Window) -> None:
    """The walls that reach into the window's box, filled in the viewer's wall colour."""
    from matplotlib.patches import Polygon

    from nao_arena.render.colours import WALL_COLOUR, to_unit

    colour = to_unit(WALL_COLOUR)
    near = [
        w
        for w in _wall_outlines(spec)
        if np.all(w.max(axis=0) >= win.lo) and np.all(w.min(axis=0) <= win.hi)
    ]
    for n, outline in enumerate(near):
        ax.add_patch(
            Polygon(
                outline,
                closed=True,
                facecolor=colour,
                edgecolor=colour,
                label="walls" if n == 0 else None,
                zorder=1,
            )
        )


def _draw_others(
    ax: Axes, log: EpisodeLog, parties: Collection[int], win: _Window, controlled: Collection[int]
) -> None:
    """The bodies besides the parties that come into the window's box (m) during its
    rows: their paths over those rows (thin) and their discs at the contact (dotted,
    faintly filled), in their viewer colours."""
    from matplotlib.patches import Circle

    from nao_arena.render.colours import to_unit

    radii = log.scene().world.radii
    robots = {int(b) for b in log.robot_ids}
    rows = slice(win.first, win.last + 1)
    near = [
        i
        for i in range(log.n_bodies)
        if i not in parties and win.holds(log.positions[rows, i], float(radii[i]))
    ]
    span = f"t = {log.time[win.first]:.1f} .. {log.time[win.last]:.1f} s"
    kinds = log.state(0).kinds
    people = [i for i in near if i not in robots and kinds[i] == "person"]
    for kind, group in (
        ("other robots", [i for i in near if i in robots]),
        ("people", people),
        ("traffic", [i for i in near if i not in robots and i not in people]),
    ):
        for n, i in enumerate(group):
            colour = to_unit(_body_colour(log, i, controlled))
            label = f"{kind} nearby ({len(group)}): paths, {span}" if n == 0 else None
            seen = on_map(log, log.positions[rows, i])
            ax.plot(*seen.T, "-", color=colour, lw=1.0, alpha=0.6, label=label)
            at = _position_at(log, i, win.t_contact)
            ax.add_patch(
                Circle(
                    (float(at[0]), float(at[1])),
                    float(radii[i]),
                    facecolor=(*colour, 0.15),
                    edgecolor=colour,
                    ls=":",
                    lw=1.2,
                    zorder=2,
                )
            )


def _draw_party(
    ax: Axes, log: EpisodeLog, p: Party, fill: Colour, win: _Window, horizon: float
) -> None:
    """One party's path before and after the step before the contact, its discs then
    (filled, named) and at the contact (dotted) and its chosen acceleration, in its
    viewer colour ``fill``."""
    from matplotlib.patches import Circle

    from nao_arena.render.colours import outline_colour, to_unit

    colour, edge = to_unit(fill), to_unit(outline_colour(fill))
    before = win.before
    came = on_map(log, log.positions[win.first : before + 1, p.body])
    path = on_map(log, log.positions[before : win.last + 1, p.body])
    back = log.time[before] - log.time[win.first]
    ax.plot(
        *came.T, "-", color=colour, lw=1.0, alpha=0.5, label=f"{p.name}: the {back:.1f} s before"
    )
    ax.plot(*path.T, "-", color=colour, lw=2.0, label=f"{p.name}: where it went ({horizon:.1f} s)")
    r = float(log.scene().world.radii[p.body])
    start = log.positions[before, p.body]
    ax.add_patch(Circle(tuple(start), r, facecolor=(*colour, 0.35), edgecolor=edge, zorder=4))
    at = _position_at(log, p.body, win.t_contact)
    ax.add_patch(Circle(tuple(at), r, fill=False, edgecolor=colour, ls=":", lw=1.2, zorder=4))
    ax.annotate(
        p.name,
        xy=tuple(start),
        xytext=(6, 6),
        textcoords="offset points",
        color=edge,
        fontsize="small",
        zorder=5,
    )
    if p.chosen is not None and p.velocity is not None:
        ax.annotate(
            "",
            xy=tuple(start + 0.5 * p.chosen),
            xytext=tuple(start),
            arrowprops={"arrowstyle": "->", "color": "k", "lw": 1.5},
        )


def _draw_prediction(ax: Axes, p: Party, other: Party) -> None:
    """Where p predicted the other (dashed, in the viewer's colour of that neighbour)."""
    from nao_arena.render.colours import neighbour_colour, to_unit

    if p.predicted_other is None:
        return
    colour = to_unit(neighbour_colour(0 if p.neighbour is None else p.neighbour))
    ax.plot(
        *p.predicted_other.T,
        "--",
        color=colour,
        lw=1.5,
        label=f"{other.name} as {p.name} predicted it ({p.predictor})",
    )


def _contact_point(log: EpisodeLog, ev: ContactEvent) -> NDArray[np.float64]:
    """Where the viewer marks a contact (m): the midpoint of the pair (the robot's
    centre against a wall) at the contact's time."""
    hit = _position_at(log, ev.a, ev.time)
    if ev.kind_b != "wall":
        hit = 0.5 * (hit + _position_at(log, ev.b, ev.time))
    return hit


OFF_MAP = 10.0
"""How far (m) outside the map's bounds a logged position counts as off the map: where a
recorded person waits before appearing and after leaving (far outside the bounds)."""


def on_map(log: EpisodeLog, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """``points`` (n, 2) m with NaN rows where a body was off the map (:data:`OFF_MAP`):
    lines break there and boxes leave them out."""
    bounds = log.spec.bounds
    lo = np.asarray(bounds.min, dtype=float) - OFF_MAP
    hi = np.asarray(bounds.max, dtype=float) + OFF_MAP
    out = np.array(points, dtype=float)
    out[~np.all((out >= lo) & (out <= hi), axis=1)] = np.nan
    return out


def _square(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A square box (lo, hi) m around points (n, 2) m with a margin (NaN rows left out)."""
    lo, hi = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    pad = 0.15 * float(max(hi - lo)) + 0.5
    mid = 0.5 * (lo + hi)
    half = 0.5 * float(max(hi - lo)) + pad
    return mid - half, mid + half


def _draw_paths(
    ax: Axes, log: EpisodeLog, expl: Explanation, controlled: Collection[int] = ()
) -> None:
    """World view around the pair (m, axes equal, the viewer's colours): where they
    went, where each predicted the other, and the walls and other bodies near them;
    robot indices ``controlled`` were driven from outside."""
    from nao_arena.render.colours import CONTACT_COLOUR, to_unit

    ev = expl.contact
    before = expl.before
    bodies = [p for p in expl.parties if p.kind != "wall"]
    horizon = max([float(p.times[-1]) for p in bodies if p.times is not None] + [1.5])
    last = min(log.n_steps - 1, before + int(round(horizon / log.dt)))
    first = max(0, before - int(round(LOOK_BACK / log.dt)))
    hit = _contact_point(log, ev)
    shown = [on_map(log, log.positions[first : last + 1, p.body]) for p in bodies] + [hit[None]]
    shown += [p.predicted_other for p in bodies if p.predicted_other is not None]
    lo, hi = _square(np.concatenate(shown))
    win = _Window(first, before, last, ev.time, lo, hi)
    for p in bodies:
        _draw_party(ax, log, p, _body_colour(log, p.body, controlled), win, horizon)
    for p in bodies:
        _draw_prediction(ax, p, next((q for q in bodies if q is not p), p))
    _draw_walls(ax, log.spec, win)
    _draw_others(ax, log, {p.body for p in bodies}, win, controlled)
    ax.plot(
        *hit,
        "o",
        mfc="none",
        mec=to_unit(CONTACT_COLOUR),
        ms=14,
        mew=2.5,
        label=f"contact at t = {ev.time:.2f} s",
        zorder=6,
    )
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    ax.set_title(
        f"contact {expl.number}: discs at t = {log.time[before]:.2f} s (filled) and at the "
        f"contact (dotted);\nblack arrows: the accelerations chosen then "
        f"(0.5 m per m/s^2)",
        fontsize="medium",
    )
    ax.legend(fontsize="small", loc="best")


def explain_picture(log: EpisodeLog, expl: Explanation) -> NDArray[np.uint8]:
    """The explanation's figure as an RGB image (H, W, 3) uint8."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = explain_figure(log, expl)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def write_explanation(log: EpisodeLog, expl: Explanation, path: str | Path) -> Path:
    """Write the explanation's figure as a PNG, atomically; returns the path."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from nao_arena.atomic import atomic_write_with

    path = Path(path)
    fig = explain_figure(log, expl)
    FigureCanvasAgg(fig)
    atomic_write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=100))
    return path
