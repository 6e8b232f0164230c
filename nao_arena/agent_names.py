"""The names agents go by: the built-in agents and the plug-ins' entry points.

What both the agent loader (:mod:`nao_arena.agent`) and the map check
(:mod:`nao_arena.maps.loader`, which refuses unknown agent names) need, without
importing either; nothing here imports an agent.
"""

from __future__ import annotations

from importlib.metadata import EntryPoint, entry_points

__all__ = [
    "BUILTIN_AGENTS",
    "BUILTIN_DESCRIPTIONS",
    "ENTRY_POINT_GROUP",
    "available_agents",
    "plugins",
]

ENTRY_POINT_GROUP = "nao_arena.agents"
"""The entry point group of agent plug-ins (name -> ``module:Class``)."""

BUILTIN_AGENTS: dict[str, str] = {
    "nao": "nao_arena.agents.nao:NAOAgent",
    "ao": "nao_arena.agents.nao:AOAgent",
    "vo": "nao_arena.agents.vo:VOAgent",
    "orca": "nao_arena.agents.orca:ORCAAgent",
    "cbf": "nao_arena.agents.cbf:CBFAgent",
    "goal": "nao_arena.agents.goal:GoalAgent",
    "lane": "nao_arena.agents.lane:LaneAgent",
    "social_force": "nao_arena.agents.social_force:SocialForceAgent",
}
"""Built-in agent name -> ``module:Class`` reference."""

BUILTIN_DESCRIPTIONS: dict[str, str] = {
    "nao": "goal seeking outside every neighbour's NAO and every wall's (the default)",
    "ao": "nao with constant-acceleration predictions (the AO)",
    "vo": "velocity obstacles: the nearest admissible velocity, tracked within a_max",
    "orca": "ORCA half-planes and a 2-D linear program, tracked within a_max",
    "cbf": "safety barrier certificates: the goal-seeking acceleration through a QP",
    "goal": "goal seeking with no avoidance (the lower bound)",
    "lane": "the traffic's lane follower: follows the robot's route at its speed",
    "social_force": "people walking by the social force model (Helbing and Molnar 1995)",
}
"""One line on what each built-in agent does (``nao-arena agents``)."""


def plugins() -> dict[str, EntryPoint]:
    """The installed agent plug-ins: name -> entry point of :data:`ENTRY_POINT_GROUP`."""
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_agents() -> dict[str, str]:
    """Name -> reference of every agent available: built-ins, then entry points."""
    found = dict(BUILTIN_AGENTS)
    for name, ep in sorted(plugins().items()):
        found.setdefault(name, ep.value)
    return found
