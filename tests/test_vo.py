"""The ``vo`` baseline leaves out the discs no candidate can reach within its horizon: they
are clear of every candidate (checked against the clearance itself), and its decisions
are those it makes with every disc, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import nao_arena.agents.vo as vo_module
from nao_arena.agents._obstacles import Discs
from nao_arena.arena import Arena, ArenaOptions
from nao_arena.geometry import vo_clearance
from nao_arena.maps import load_map

coord = st.floats(-30.0, 30.0, allow_nan=False)
speed = st.floats(0.0, 3.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.tuples(coord, coord, speed, st.floats(0.0, 6.3), st.floats(0.1, 2.0)), min_size=1),
    st.lists(st.tuples(speed, st.floats(0.0, 6.3)), min_size=1, max_size=20),
    st.floats(0.1, 5.0),
)
def test_an_unreachable_disc_is_clear_of_every_candidate(discs, candidates, horizon) -> None:
    pos = np.array([[x, y] for x, y, *_ in discs])
    vel = np.array([[s * np.cos(a), s * np.sin(a)] for *_, s, a, _ in discs])
    rad = np.array([r for *_, r in discs])
    cand = np.array([[s * np.cos(a), s * np.sin(a)] for s, a in candidates])
    top = float(np.max(np.hypot(*cand.T)))
    near = vo_module.reachable(Discs(pos, vel, rad, np.zeros(len(rad), bool)), top, horizon)
    times = np.array([0.0, horizon])
    for k in np.flatnonzero(~near):
        centers = pos[k] + vel[k] * times[:, None]
        assert np.all(vo_clearance(cand, times, centers, rad[k]) > 0.0)


def _episode(name: str, steps: int) -> str:
    arena = Arena(load_map(name), ArenaOptions(agent="vo"))
    arena.reset(seed=2)
    for _ in range(steps):
        arena.step()
    return arena.summary().trajectory_hash


@pytest.mark.parametrize("name", ["intersection", "dense_swap_perturbed"])
def test_its_decisions_are_those_with_every_disc(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    reachable = vo_module.reachable
    left_out = [0]

    def counted(discs: Discs, top: float, horizon: float) -> np.ndarray:
        near = reachable(discs, top, horizon)
        left_out[0] += int((~near).sum())
        return near

    monkeypatch.setattr(vo_module, "reachable", counted)
    culled = _episode(name, 25)
    assert left_out[0] > 0  # the scene has discs out of reach
    monkeypatch.setattr(
        vo_module, "reachable", lambda discs, top, horizon: np.ones(len(discs.radii), bool)
    )
    assert _episode(name, 25) == culled
