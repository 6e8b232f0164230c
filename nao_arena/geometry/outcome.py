"""How an acceleration was chosen: one code for every selection, repair and decision.

The compiled kernels return and store these codes (numba treats the members as
integer constants); user-facing strings (selection statuses, infos, logs) are the
members' :attr:`Outcome.label`.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = ["Outcome"]


class Outcome(IntEnum):
    """Outcome of choosing an acceleration."""

    UNDECIDED = -1
    """Non-finite input or obstacle paths: the caller decides (and reports)."""
    DESIRED = 0
    """The desired acceleration is admissible and is taken."""
    ADJUSTED = 1
    """The admissible acceleration nearest the desired one."""
    INFEASIBLE = 2
    """Nothing admissible found: the caller's fallback."""
    REPAIRED = 3
    """A nearby admissible acceleration found by repairing the current one locally."""

    @property
    def label(self) -> str:
        """The lower-case name used in statuses, infos and logs ("desired", ...)."""
        return self.name.lower()
