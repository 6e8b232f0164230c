"""Every overlap the physics produces is a recorded contact.

An independent monitor samples each physics substep of real arena episodes
densely (no closed forms shared with nao_arena.stats) and checks that every
sampled overlap of two discs, or of a disc and a wall, lies inside a contact
episode that the arena recorded for that pair, and that every recorded
contact is a real overlap.
"""

from __future__ import annotations

import numpy as np
import pytest

from nao_arena.arena import Arena, ArenaOptions
from nao_arena.maps import load_map, map_from_dict

SAMPLES = 16  # samples per physics substep, ends included
DEPTH = 1e-6  # sampled overlaps deeper than this (m) must be recorded


def _sample(path: np.ndarray) -> np.ndarray:
    """(S * (SAMPLES - 1) + 1, N, 2) points on the straight lines between the rows of path."""
    f = np.linspace(0.0, 1.0, SAMPLES)[:-1, None, None]
    pieces = [path[s] + (path[s + 1] - path[s]) * f for s in range(len(path) - 1)]
    return np.concatenate([*pieces, path[-1:]])


def _wall_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    u = np.clip(((points - a) @ ab) / max(ab @ ab, 1e-300), 0.0, 1.0)
    d = points - a - u[..., None] * ab
    return np.hypot(d[..., 0], d[..., 1])


def monitored_episode(arena: Arena, seed: int, steps: int) -> tuple[list, list]:
    """Run ``steps`` steps; returns (sampled overlaps as (time, key, depth), contacts) with
    key (a, b, False) for two bodies and (body, wall, True) for a wall."""
    arena.reset(seed)
    radii = arena.world.radii
    segs, half = arena.walls, arena.wall_radius
    reach = radii[:, None] + radii[None, :]
    iu = np.triu_indices(len(radii), 1)
    overlaps = []
    for _ in range(steps):
        t0 = arena.time
        arena.step()
        pts = _sample(arena.world.substep_positions)
        times = t0 + np.linspace(0.0, arena.world.dt, len(pts))
        d = pts[:, :, None, :] - pts[:, None, :, :]
        gap = np.hypot(d[..., 0], d[..., 1]) - reach  # (samples, N, N)
        worst = gap[:, iu[0], iu[1]].min(axis=0)
        for k in np.flatnonzero(worst < -DEPTH):
            a, b = int(iu[0][k]), int(iu[1][k])
            first = int(np.argmax(gap[:, a, b] < -DEPTH))
            overlaps.append((times[first], (a, b, False), -worst[k]))
        for w in range(len(half)):
            wgap = _wall_distance(pts, segs[w, 0], segs[w, 1]) - (radii + half[w])
            for body in np.flatnonzero(wgap.min(axis=0) < -DEPTH):
                first = int(np.argmax(wgap[:, body] < -DEPTH))
                overlaps.append((times[first], (int(body), w, True), -wgap[:, body].min()))
        if arena.done:
            break
    return overlaps, arena.summary().contacts


def _covered(time: float, key: tuple, contacts: list, dt: float) -> bool:
    for c in contacts:
        if (c.a, c.b, c.kind_b == "wall") != key:
            continue
        end = np.inf if np.isnan(c.end_time) else c.end_time
        if c.time - dt <= time <= end + 1e-9:
            return True
    return False


CASES = [
    ("crossing", {"agent": "goal"}, 0, 160),
    ("circle_swap", {"agent": "goal", "n": 12}, 1, 160),
    ("corridor", {"agent": "goal", "n": 4}, 2, 200),
    ("roundabout", {"agent": "goal"}, 3, 200),
    ("crossing", {"agent": "orca"}, 4, 120),
]


@pytest.mark.parametrize(("name", "params", "seed", "steps"), CASES)
def test_every_sampled_overlap_is_a_recorded_contact(name, params, seed, steps) -> None:
    agent = params.pop("agent")
    spec = load_map(name, **params)
    arena = Arena(spec, ArenaOptions(agent=agent))
    overlaps, contacts = monitored_episode(arena, seed, steps)
    dt = arena.world.dt
    missed = [o for o in overlaps if not _covered(o[0], o[1], contacts, dt)]
    assert not missed, f"{len(missed)} of {len(overlaps)} overlaps not recorded: {missed[:3]}"
    # and every recorded contact is a real overlap, as deep as recorded (to sampling error)
    for c in contacts:
        key = (c.a, c.b, c.kind_b == "wall")
        depths = [d for t, k, d in overlaps if k == key and abs(t - c.time) <= dt]
        assert c.max_penetration <= DEPTH or depths, c
    if agent == "goal":
        assert overlaps, "the scene should produce overlaps (goal agents collide)"


def test_head_on_bounce_inside_one_step_is_a_contact() -> None:
    """Two discs meeting head-on at 1.5 m/s each with zero commands bounce off (fully
    elastic): apart again at the step's end, yet a contact with a 3 m/s impact."""

    spec = map_from_dict(
        {
            "name": "head_on",
            "bounds": {"min": [-10, -10], "max": [10, 10]},
            "physics": {"elasticity": 1.0},
            "episode": {"time_limit": 2.0},
            "robots": [
                {
                    "start": [-1.0, 0.0],
                    "goal": [5.0, 0.0],
                    "velocity": [1.5, 0.0],
                    "radius": 0.3,
                    "agent": "goal",
                },
                {
                    "start": [1.0, 0.0],
                    "goal": [-5.0, 0.0],
                    "velocity": [-1.5, 0.0],
                    "radius": 0.3,
                    "agent": "goal",
                },
            ],
        }
    )
    arena = Arena(spec, ArenaOptions(agent=str(__file__) + ":Idle"))
    summary = arena.run(0)
    assert [(c.a, c.b) for c in summary.contacts] == [(0, 1)]
    c = summary.contacts[0]
    assert c.impact_speed == pytest.approx(3.0, rel=1e-6)
    assert 0.005 < c.max_penetration < 0.05
    assert c.time == pytest.approx(0.7 / 1.5, abs=0.011)  # surfaces meet after 0.467 s
    assert np.all(arena.state.velocities[:, 0] * [-1, 1] > 1.4)  # they bounced apart
    assert summary.robots[0].collisions == 1 and summary.robots[0].success is False


class Idle:
    """Commands zero acceleration."""

    def reset(self, spec, rng) -> None:
        pass

    def act(self, obs) -> np.ndarray:
        return np.zeros(2)
