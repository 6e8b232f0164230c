"""The NAO agent's ``infeasible="stop_in_time"`` fallback: where nothing is admissible, brake
when braking brings the robot to rest before any predicted contact (a contact then finds it
standing), else postpone contact longest. The stop test is checked by forward simulation
of the braking robot and of a turning walker, not by the geometry itself."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from forward_sim import Encounter, Polyline, Robot, turning_walker
from hypothesis import given, settings
from strategies import floats, vec
from test_nao_agent import agent, head_on, observation

from nao_arena.agents._nao_per_robot import stops_before_contact
from nao_arena.arena import Arena
from nao_arena.geometry import sampled_path
from nao_arena.maps import map_from_dict

HORIZON = 3.0
TIMES = np.linspace(0.0, HORIZON, 31)
A_MAX = 2.0
RADIUS = 0.75  # combined radius (m): two 0.3 m discs and a 0.15 m margin


@settings(max_examples=500, deadline=None)
@given(
    v=vec(1.5),
    velocity=vec(1.8),
    turn=floats(-0.8, 0.8),
    side=floats(-math.pi, math.pi),
    gap=floats(-0.3, 0.3),
    when=floats(0.0, 2.0),
)
def test_the_stop_test_agrees_with_forward_simulation(v, velocity, turn, side, gap, when):
    """Whether braking at a_max from v comes to rest (at |v| / a_max) before the walker
    first comes within the combined radius: the forward simulation's first contact of
    the braking robot (its motion up to the stop is that of the constant deceleration).
    At ``when`` x the stop time (s) the walker is ``gap`` (m) outside the combined radius
    of where the robot comes to rest, on the side ``side`` (rad): close calls on either
    side of the stop."""
    speed = float(np.hypot(*v))
    stop = speed / A_MAX
    rest = v * stop / 2  # where braking brings the robot to rest
    there = rest + (RADIUS + gap) * np.array([math.cos(side), math.sin(side)])
    centers = turning_walker(TIMES, there - velocity * when * stop, velocity, turn)
    decel = -v / speed * A_MAX if speed > 0 else np.zeros(2)
    sim = Encounter(Robot.make(v, decel), Polyline.make(TIMES, centers), RADIUS).simulate()
    closest = float(np.min(sim.distance[sim.grid <= stop])) - RADIUS  # until the stop
    if abs(sim.time_of_first_contact - stop) < 1e-6 or abs(closest) < 1e-9:
        return  # touching as it stops, or grazing: either answer is right
    expected = speed == 0.0 or sim.time_of_first_contact >= stop
    assert stops_before_contact(v, A_MAX, sampled_path(TIMES, centers, RADIUS)) == expected


def test_at_rest_or_alone_a_robot_stops_at_once():
    far = sampled_path(TIMES, np.full((TIMES.size, 2), 50.0), RADIUS)
    assert stops_before_contact(np.zeros(2), A_MAX, far)
    assert stops_before_contact(np.array([1.5, 0.0]), A_MAX, far)
    # walking straight at a robot at rest: it is at rest when touched
    towards = sampled_path(TIMES, np.array([[1.5 - 1.0 * t, 0.0] for t in TIMES]), RADIUS)
    assert stops_before_contact(np.zeros(2), A_MAX, towards)


def _closing_person() -> object:
    """A robot at 0.3 m/s, a person 1.2 m ahead walking at it at 1.5 m/s: nothing is
    admissible (the robot cannot get 0.75 m sideways before the person passes, nor outrun
    them), but braking stops it in 0.15 s, 0.02 m on, long before the person arrives."""
    return observation(vel=(0.3, 0.0), nb_pos=(1.2, 0.0), nb_vel=(-1.5, 0.0), kind="person")


def test_stop_in_time_brakes_where_braking_comes_to_rest_before_contact():
    stopping = agent(infeasible="stop_in_time")
    a = stopping.act(_closing_person())
    assert stopping.last_selection.status == "infeasible"
    np.testing.assert_allclose(a, [-A_MAX, 0.0])  # -v/|v| min(a_max, |v| / dt)
    dodging = agent(infeasible="latest_contact")
    b = dodging.act(_closing_person())
    assert dodging.last_selection.status == "infeasible"
    assert not np.allclose(b, a)  # postponing contact keeps the robot moving


def test_stop_in_time_postpones_contact_where_braking_comes_too_late():
    """A neighbour 0.1 m away closing at 3 m/s: braking from 1.5 m/s takes 0.75 s, too
    long; the robot postpones contact as ``latest_contact`` does, bit for bit."""
    stopping = agent(infeasible="stop_in_time")
    dodging = agent(infeasible="latest_contact")
    for kind in ("robot", "person", "traffic"):
        np.testing.assert_array_equal(
            stopping.act(head_on(kind)), dodging.act(head_on(kind)), err_msg=kind
        )


def test_an_unknown_fallback_is_one_clear_error():
    with pytest.raises(ValueError, match="infeasible: expected one of 'auto', 'brake', "):
        agent(infeasible="stop")


def _pop_in(folder: Path, ahead: float, mode: str) -> dict:
    """A nao robot (v_max 1.5 m/s) drives +x from (-4, 0) m; at 2 s a recorded person
    appears ``ahead`` m in front of it, walking -x at 1.5 m/s: too close to get out of
    the way."""
    x0 = -4.0 + 1.5 * (2.0 - 1.5 / 4.0)  # the robot at 2 s, full speed from 0.75 s
    rows = [(f, 9, x0 + ahead - 1.5 * (f - 20) / 10, 0.0) for f in range(20, 61)]
    path = folder / f"pop_in_{ahead}.txt"
    path.write_text("\n".join(f"{f} {i} {x} {y}" for f, i, x, y in rows) + "\n")
    robot = {
        "name": "r",
        "start": [-4.0, 0.0],
        "goal": [7.0, 0.0],
        "agent": "nao",
        "v_max": 1.5,
        "predictor": "constant_velocity",
        "agent_options": {"infeasible": mode},
    }
    return {
        "name": "pop_in",
        "bounds": {"min": [-8, -8], "max": [8, 8]},
        "robots": [robot],
        "traffic": [{"type": "recorded", "file": str(path), "format": "xy", "fps": 10.0}],
        "episode": {"time_limit": 6.0},
    }


def _person_contacts(data: dict) -> tuple[int, list[tuple[float, float]]]:
    """(robot-caused contacts, (time s, robot speed m/s) of each contact with the person)."""
    summary = Arena(map_from_dict(data)).run(0)
    (robot,) = summary.robots
    touches = [(c.time, c.speed_a) for c in summary.contacts if c.kind_b == "person"]
    return robot.caused_person_contacts, touches


def test_a_person_appearing_ahead_finds_the_robot_standing_if_it_can_stop(tmp_path):
    """2.4 m ahead: braking stops the robot before the person arrives, who then walks
    into it standing (not the robot's doing); postponing contact keeps it moving into
    the touch. 1.6 m ahead: braking comes too late, and both do the same, bit for bit."""
    caused, touches = _person_contacts(_pop_in(tmp_path, 2.4, "stop_in_time"))
    assert caused == 0 and touches and touches[0][1] < 0.05
    caused, touches = _person_contacts(_pop_in(tmp_path, 2.4, "latest_contact"))
    assert caused == 1 and touches[0][1] > 0.05
    late = [_person_contacts(_pop_in(tmp_path, 1.6, m)) for m in ("stop_in_time", "latest_contact")]
    assert late[0] == late[1] and late[0][0] == 1
