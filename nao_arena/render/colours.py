"""The colours of every picture the project draws: the viewer's frames, replays, GIFs and
the left plot of ``nao-arena explain``, so that a robot, a traffic vehicle, a wall, a
contact or a neighbour's predicted path looks the same in all of them.

Colours are RGB tuples of ints 0..255; :func:`to_unit` gives matplotlib's 0..1 floats.
"""

from __future__ import annotations

from typing import cast

__all__ = [
    "AGENT_COLOURS",
    "BACKGROUND",
    "CONTACT_COLOUR",
    "GOOD_COLOUR",
    "LANE_COLOUR",
    "PALETTE",
    "PANEL_BACKGROUND",
    "PERSON_COLOUR",
    "TEXT_COLOUR",
    "TRAFFIC_COLOUR",
    "WALL_COLOUR",
    "WALL_REGION_COLOUR",
    "Colour",
    "agent_colour",
    "body_colour",
    "mix",
    "neighbour_colour",
    "outline_colour",
    "robot_colour",
    "to_unit",
]

Colour = tuple[int, int, int]

AGENT_COLOURS: dict[str, Colour] = {
    "nao": (31, 119, 180),
    "ao": (23, 190, 207),
    "vo": (255, 127, 14),
    "orca": (148, 103, 189),
    "cbf": (188, 189, 34),
    "goal": (127, 127, 127),
    "lane": (44, 160, 44),
    "controlled": (214, 39, 40),
    "traffic": (140, 86, 75),
    "social_force": (227, 119, 194),
    "person": (227, 119, 194),
}
"""Fill colour per agent type ("controlled": a robot driven from outside, e.g. by an RL
policy; "person": a recorded person); plug-in agents get a colour of :data:`PALETTE`
derived from their name."""

PALETTE: list[Colour] = [
    (230, 159, 0),
    (86, 180, 233),
    (0, 158, 115),
    (204, 121, 167),
    (213, 94, 0),
    (0, 114, 178),
    (240, 228, 66),
    (120, 94, 240),
    (100, 143, 255),
    (254, 97, 0),
]
"""Colours of the selected robot's neighbours (their predicted paths and NAO regions) and
of plug-in agents."""

WALL_COLOUR: Colour = (60, 60, 60)
"""Walls (segments, polygons and the bound walls)."""
WALL_REGION_COLOUR: Colour = (190, 190, 190)
"""The accelerations the walls forbid, on the acceleration panel."""
BACKGROUND: Colour = (250, 250, 247)
"""The world panel's background."""
PANEL_BACKGROUND: Colour = (238, 238, 235)
"""The acceleration panel's background."""
LANE_COLOUR: Colour = (222, 222, 218)
"""Traffic lanes."""
TEXT_COLOUR: Colour = (20, 20, 20)
"""Text."""
CONTACT_COLOUR: Colour = (220, 20, 30)
"""The ring that marks a contact (and other warnings)."""
GOOD_COLOUR: Colour = (20, 150, 40)
"""What went well (a goal reached, an admissible choice)."""
TRAFFIC_COLOUR: Colour = AGENT_COLOURS["traffic"]
"""Traffic vehicles' discs."""
PERSON_COLOUR: Colour = AGENT_COLOURS["person"]
"""Recorded people's discs (and the social-force people's)."""


def agent_colour(label: str) -> Colour:
    """A robot's fill colour from its agent's label (:data:`AGENT_COLOURS`, else one of
    :data:`PALETTE` derived from the label)."""
    if label in AGENT_COLOURS:
        return AGENT_COLOURS[label]
    h = sum((i + 1) * ord(c) for i, c in enumerate(label))
    return PALETTE[h % len(PALETTE)]


def robot_colour(label: str, controlled: bool = False) -> Colour:
    """A robot's fill colour: ``AGENT_COLOURS["controlled"]`` when driven from outside,
    else its agent's colour (:func:`agent_colour`)."""
    return AGENT_COLOURS["controlled"] if controlled else agent_colour(label)


def neighbour_colour(j: int) -> Colour:
    """The colour of neighbour j (index among the sensed neighbours, nearest first) of
    the selected robot: its predicted path and, lightened, its NAO on the panel."""
    return PALETTE[j % len(PALETTE)]


def mix(c: Colour, w: float, base: Colour = (255, 255, 255)) -> Colour:
    """c blended with base: w = 1 gives c, w = 0 gives base."""
    # three ints (typeshed's tuple() drops the length)
    return cast(
        "Colour", tuple(int(round(w * a + (1 - w) * b)) for a, b in zip(c, base, strict=True))
    )


def outline_colour(c: Colour) -> Colour:
    """The outline of a body's disc of fill colour c (darkened towards black)."""
    return mix(c, 0.6, (0, 0, 0))


def body_colour(kind: str) -> Colour:
    """The fill colour of a body no agent drives: a recorded person's or a vehicle's."""
    return PERSON_COLOUR if kind == "person" else TRAFFIC_COLOUR


def to_unit(c: Colour) -> tuple[float, float, float]:
    """c as matplotlib's RGB floats 0..1."""
    return (c[0] / 255.0, c[1] / 255.0, c[2] / 255.0)
