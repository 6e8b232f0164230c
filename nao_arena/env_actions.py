"""The environment's actions checked: real numbers of shape (2,), finite, one per live
agent (see "Actions" in :mod:`nao_arena.environment`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["actions_array"]

_REAL_KINDS = frozenset("iuf")
"""numpy dtype kinds accepted in actions: signed and unsigned integers, floats."""


def _check_real(name: str, action: Any) -> None:
    """ValueError unless ``action`` is made of real numbers (not bool, complex, str, object)."""
    if type(action) is np.ndarray and action.dtype.kind in _REAL_KINDS:
        return  # the common case
    if isinstance(action, (list, tuple)) and any(isinstance(x, (bool, np.bool_)) for x in action):
        kind = "b"
    else:
        try:
            kind = np.asarray(action).dtype.kind
        except (TypeError, ValueError):
            return  # not an array at all: the shape check explains it
    if kind not in _REAL_KINDS:
        what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes"}.get(
            kind, "objects"
        )
        raise ValueError(
            f"action of {name!r}: expected real numbers (a float array of shape "
            f"(2,)), got {what}: {action!r}"
        )


def actions_array(
    actions: Mapping[str, Any],
    live: list[str],
    rows: Mapping[str, int],
    possible_agents: Sequence[str],
) -> NDArray[np.float64]:
    """Validated actions (m, 2) of the live agents, in ``live`` order, clipped to [-1, 1].

    Each action must be real numbers (ints or floats; not booleans, complex numbers,
    strings or objects) of shape (2,), finite; else ValueError naming the agent. ``rows``:
    the known agents (names -> rows), ``possible_agents`` their names as the error lists
    them."""
    if not isinstance(actions, Mapping):
        raise ValueError(
            f"actions: expected a dict of agent name -> action of shape (2,), "
            f"got {type(actions).__name__}"
        )
    if not rows.keys() >= actions.keys():
        name = next(a for a in actions if a not in rows)
        raise ValueError(
            f"action for unknown agent {name!r}; expected one of {', '.join(possible_agents)}"
        )
    if len(actions) < len(live) or not actions.keys() >= set(live):
        missing = [a for a in live if a not in actions]
        raise ValueError(f"missing actions for live agents: {', '.join(missing)}")
    for a in live:
        _check_real(a, actions[a])
    try:
        arr = np.array([actions[a] for a in live], dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (len(live), 2):
        for a in live:
            try:
                one = np.asarray(actions[a], dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError(
                    f"action of {a!r}: expected a numeric array of shape (2,), got {actions[a]!r}"
                ) from None
            if one.shape != (2,):
                raise ValueError(f"action of {a!r}: expected shape (2,), got {one.shape}")
        raise ValueError("expected actions of shape (2,)")
    if not np.all(np.isfinite(arr)):
        bad = [a for a, row in zip(live, arr, strict=True) if not np.all(np.isfinite(row))]
        raise ValueError(
            f"action of {bad[0]!r}: expected finite values, got "
            f"{np.asarray(actions[bad[0]]).tolist()}"
        )
    return np.clip(arr, -1.0, 1.0)
