"""One code for how an acceleration was chosen (:class:`nao_arena.geometry.Outcome`), the
same in the compiled selection, the batched decision and the selection's status."""

from __future__ import annotations

import numpy as np
import pytest

from nao_arena.agents._nao_bundles import DecidingRobots, GroupPaths, ObstacleLists
from nao_arena.agents._nao_decide import decide
from nao_arena.geometry import AccelLimits, Outcome, PiecewisePath, select_acceleration
from nao_arena.geometry._kernel.bundles import Paths, SearchSettings, Walls
from nao_arena.geometry._kernel.sampled import path_excursions
from nao_arena.geometry._kernel.search import select_disc
from nao_arena.geometry.selection import _ring_radii, _unit_rings


def _wall_ahead(gap: float) -> PiecewisePath:
    """One obstacle at rest ``gap`` m ahead (radius 0.5 m), over 3 s."""
    t = np.array([0.0, 3.0])
    return PiecewisePath(
        t=t,
        c=np.array([[[gap, 0.0]]]),
        velocity=np.zeros((1, 1, 2)),
        acceleration=np.zeros((1, 1, 2)),
        radius=np.array([0.5]),
    )


def _select_disc(desired: tuple[float, float], path: PiecewisePath) -> Outcome:
    status, _, _, _ = select_disc(
        np.array(desired),
        np.array([1.0, 0.0]),
        2.0,
        1.5,
        Paths(*path.moving_arrays),
        Walls(path.walls, path.wall_radius),
        0.0,
        SearchSettings(1e-3, _ring_radii(2.0, 4), _unit_rings(4, 16), 64, 6, 16.0, 0.0),
    )
    return status


@pytest.mark.parametrize(
    ("desired", "gap", "expected"),
    [
        ((0.0, 0.0), 10.0, Outcome.DESIRED),
        ((2.0, 0.0), 2.0, Outcome.ADJUSTED),
    ],
)
def test_compiled_selection_returns_outcomes(desired, gap, expected) -> None:
    status = _select_disc(desired, _wall_ahead(gap))
    assert isinstance(status, Outcome) and status is expected
    sel = select_acceleration(
        desired, [1.0, 0.0], _wall_ahead(gap), AccelLimits(2.0), v_max=1.5, with_clearance=False
    )
    assert sel.status == expected.label


def test_batched_decision_uses_the_selections_codes() -> None:
    """A robot alone: decide's code is the compiled selection's DESIRED (they used to differ:
    2 meant DESIRED in one and 'nothing admissible' in the other)."""
    times = np.linspace(0.0, 3.0, 7)
    pred = np.zeros((1, 7, 2))
    lists = ObstacleLists(
        np.zeros(2, dtype=np.int64),
        np.zeros(0, dtype=np.int64),
        np.zeros((0, 2, 2)),
        np.zeros(0),
        np.zeros(2, dtype=np.int64),
        np.zeros(0, dtype=np.int64),
    )
    robot = DecidingRobots(
        np.zeros((1, 2)), np.array([[1.0, 0.0]]), np.array([0.3]), np.array([2.0]), np.array([1.5])
    )
    kind, accel, _ = decide(
        GroupPaths(times, pred, *path_excursions(pred)),
        lists,
        np.array([0.3]),
        np.array([0]),
        robot,
        np.zeros(1, dtype=bool),
        np.zeros((1, 2)),
        np.array([[0.5, 0.0]]),
    )
    assert kind[0] == Outcome.DESIRED == _select_disc((0.0, 0.0), _wall_ahead(10.0))
    np.testing.assert_array_equal(accel[0], [0.5, 0.0])


def test_labels_are_the_user_facing_statuses() -> None:
    assert [o.label for o in Outcome] == [
        "undecided",
        "desired",
        "adjusted",
        "infeasible",
        "repaired",
    ]
