"""The ``nao`` agents' state as one table per batch (:mod:`nao_arena.agents._nao_columns`):
attributes read and write their row, batches with other members gather the rows
unchanged, a copied agent stands alone, and the compiled bookkeeping (liveness,
young adjustments, applying decisions) is its plain definition."""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference.nao_reference import detour_step, take_decision

from nao_arena.agents import _nao_columns as columns
from nao_arena.agents._nao_decide import (
    ADJUSTED,
    DESIRED,
    INFEASIBLE,
    REPAIRED,
    apply_braking,
    apply_decisions,
)
from nao_arena.agents._nao_per_robot import brakes_when_infeasible
from nao_arena.agents.nao import NAOAgent
from nao_arena.geometry.selection import Selection

STATE = (
    "age",
    "crawl_time",
    "free_time",
    "detour",
    "detour_turns",
    "side",
    "best_distance",
    "since_progress",
    "settling",
    "around_wall",
)


def agents(n: int, seed: int = 0) -> list[NAOAgent]:
    out = [NAOAgent(margin=0.1 + 0.01 * k) for k in range(n)]
    for k, ag in enumerate(out):
        ag.reset(None, np.random.default_rng(seed + k))
    return out


def scramble(ag: NAOAgent, rng: np.random.Generator) -> None:
    """Give the agent some state of its own (through its attributes)."""
    ag.age = float(rng.uniform(0, 2))
    ag.crawl_time = float(rng.uniform(0, 2))
    ag.detour = float(rng.uniform(-3, 0))
    ag.detour_turns = int(rng.integers(0, 4))
    ag.side = float(rng.choice([-1.0, 1.0]))
    ag.settling = bool(rng.random() < 0.5)
    ag.current = rng.normal(size=2)
    ag.last_selection = Selection(rng.normal(size=2), "adjusted", None, math.inf, 7)


def snapshot(ag: NAOAgent) -> tuple:
    sel = ag.last_selection
    return (
        tuple(getattr(ag, name) for name in STATE),
        tuple(ag.current.tolist()),
        None if sel is None else (sel.status, tuple(sel.accel.tolist()), sel.evaluations),
        ag.margin,
        ag.v_pref,
    )


def test_batches_with_other_members_gather_the_rows_unchanged():
    rng = np.random.default_rng(1)
    group = agents(5)
    for ag in group:
        scramble(ag, rng)
    before = [snapshot(ag) for ag in group]
    table = columns.columns_of(group)
    assert all(ag._cols is table for ag in group)
    assert columns.columns_of(group) is table  # the same members: the same table
    assert [snapshot(ag) for ag in group] == before
    part = columns.columns_of(group[1:3])
    assert part is not table and table.members is None
    group[2].detour = -0.5  # written into the new table's row
    before[2] = snapshot(group[2])
    again = columns.columns_of(group)
    assert again is not table and again is not part
    assert [snapshot(ag) for ag in group] == before
    assert [ag._row for ag in group] == list(range(5))


def test_options_write_through_and_a_new_time_grid_regroups_predictions():
    group = agents(3)
    table = columns.columns_of(group)
    assert [g.tolist() for g in table.grid_groups(group)] == [[0, 1, 2]]
    group[1].margin = 0.4
    group[2].v_pref = 0.8
    assert table.opt[1, columns.MARGIN] == 0.4 and group[2].v_pref == 0.8
    group[0].v_pref = None
    assert math.isnan(table.opt[0, columns.V_PREF]) and group[0].v_pref is None
    group[1].times = np.linspace(0.0, 2.0, 21)
    assert [g.tolist() for g in table.grid_groups(group)] == [[0, 2], [1]]
    try:
        group[0].v_pref = math.nan
    except ValueError as exc:
        assert "v_pref" in str(exc)
    else:
        raise AssertionError("a NaN v_pref was accepted")


def test_a_copied_or_pickled_agent_stands_alone_with_the_same_state():
    rng = np.random.default_rng(2)
    group = agents(4)
    for ag in group:
        scramble(ag, rng)
    table = columns.columns_of(group)
    for twin in (copy.deepcopy(group[2]), pickle.loads(pickle.dumps(group[2]))):
        assert snapshot(twin) == snapshot(group[2])
        assert twin._cols is not table and twin._cols.members == (twin,)
        twin.detour = 1.0
        twin.current = np.array([9.0, 9.0])
        assert group[2].detour != 1.0 and group[2].current.tolist() != [9.0, 9.0]
    assert columns.columns_of(group) is table  # the originals did not leave their table


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 12))
def test_the_batch_liveness_step_is_each_agents_own_step(seed, n):
    """liveness_batch (the step of act_batch) against detour_step agent by agent, with
    far, crawling and the distance to the goal worked out by numpy; then SETTLING and
    AGE; rows that are not live are left alone."""
    rng = np.random.default_rng(seed)
    batch_agents, own_agents = agents(n, seed % 1000), agents(n, seed % 1000)
    for a, b in zip(batch_agents, own_agents, strict=True):
        state = np.random.default_rng(rng.integers(2**32))
        scramble(a, state)
        scramble(b, np.random.default_rng(state.bit_generator.seed_seq))  # the same
        around = bool(rng.random() < 0.3)
        a.around_wall = b.around_wall = around
    for a, b in zip(batch_agents, own_agents, strict=True):
        assert snapshot(a) == snapshot(b)
    table = columns.columns_of(batch_agents)
    for _ in range(30):
        pos = rng.normal(0, 3, (n, 2))
        vel = rng.normal(0, 0.5, (n, 2)) * rng.choice([0.0, 1.0], (n, 1))
        goals = pos + rng.normal(0, 2, (n, 2)) * rng.choice([0.1, 1.0, 5.0], (n, 1))
        rad = rng.uniform(0.2, 0.6, n)
        v_max = rng.uniform(1.0, 2.0, n)
        held = rng.random(n) < 0.5
        live = rng.random(n) < 0.9
        turn = np.empty(n, dtype=np.bool_)
        columns.liveness_batch(
            live, pos, vel, goals, rad, v_max, held, 0.1, table.real, table.whole, table.opt, turn
        )
        for i in np.flatnonzero(turn).tolist():
            batch_agents[i]._turn_detour()
        to_goal = np.hypot(goals[:, 0] - pos[:, 0], goals[:, 1] - pos[:, 1])
        crawling = np.hypot(vel[:, 0], vel[:, 1]) < 0.25 * v_max
        for i, b in enumerate(own_agents):
            if not live[i]:
                continue
            detour_step(
                b,
                bool(to_goal[i] > 4 * rad[i]),
                bool(crawling[i]),
                0.1,
                float(to_goal[i]),
                bool(held[i]),
            )
            b.settling = bool(to_goal[i] <= b.goal_zone)
            b.age += 0.1
        for a, b in zip(batch_agents, own_agents, strict=True):
            assert snapshot(a) == snapshot(b)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 12))
def test_young_adjustments_and_applied_decisions_are_their_plain_definitions(seed, n):
    rng = np.random.default_rng(seed)
    group = agents(n, seed % 1000)
    for ag in group:
        scramble(ag, rng)
        ag.last_selection = (
            None
            if rng.random() < 0.2
            else Selection(
                rng.normal(size=2),
                str(rng.choice(["desired", "adjusted", "infeasible"])),
                None,
                math.inf,
                3,
            )
        )
    table = columns.columns_of(group)
    m = rng.permutation(n)[: int(rng.integers(1, n + 1))].astype(np.int64)
    holds = table.holds(m)
    for j, i in enumerate(m.tolist()):
        ag = group[i]
        sel = ag.last_selection
        assert holds[j] == (
            sel is not None
            and sel.status == "adjusted"
            and not ag.settling
            and ag.age < ag.reselect_after - 1e-9
        )
    status = rng.choice([0, 1, 2], len(m)).astype(np.int64)
    kind = rng.choice([REPAIRED, DESIRED, ADJUSTED, INFEASIBLE, -1], len(m)).astype(np.int64)
    accel = rng.normal(size=(len(m), 2))
    tested = rng.integers(0, 50, len(m)).astype(np.int64)
    before = [snapshot(ag) for ag in group]
    sel_before = [ag.last_selection for ag in group]
    out = rng.normal(size=(n, 2))
    out_before = out.copy()
    settled = np.zeros(len(m), dtype=np.bool_)
    apply_decisions(m, status, kind, accel, tested, table.real, table.whole, out, settled)
    for j, i in enumerate(m.tolist()):
        ag, kd = group[i], int(kind[j])
        acted = status[j] == 0 and kd in (REPAIRED, DESIRED, ADJUSTED)
        assert settled[j] == acted
        if not acted:
            assert snapshot(ag) == before[i] and ag.last_selection is sel_before[i]
            assert out[i].tolist() == out_before[i].tolist()
            continue
        assert out[i].tolist() == accel[j].tolist() == ag.current.tolist()
        if kd == REPAIRED:  # the adjustment keeps its age and selection
            assert ag.age == before[i][0][0] and ag.last_selection is sel_before[i]
        else:
            sel = ag.last_selection
            assert ag.age == 0.0 and sel is not sel_before[i]
            assert sel.status == ("desired" if kd == DESIRED else "adjusted")
            assert sel.accel.tolist() == accel[j].tolist() and sel.evaluations == tested[j]
            assert ag.last_selection is sel  # built once


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8))
def test_compiled_braking_fallback_is_the_agents_own_bit_for_bit(seed, n):
    """apply_braking does for many robots what take_decision does robot by robot for an
    INFEASIBLE outcome (the agent's fallback, AccelLimits.project, the commit): the
    same accelerations bit for bit, the same selections, and nothing for the members it
    must leave alone (status not 0, another outcome, a fallback that is not braking: the
    option read from the table, with traffic near or not)."""
    rng = np.random.default_rng(seed)
    group, twins = agents(n, seed % 1000), agents(n, seed % 1000)
    for ag, tw in zip(group, twins, strict=True):  # what a commit changes: alike
        scramble(ag, rng)
        tw.age, tw.current, tw.last_selection = ag.age, ag.current, ag.last_selection
    table = columns.columns_of(group)
    m = rng.permutation(n)[: int(rng.integers(1, n + 1))].astype(np.int64)
    status = rng.choice([0, 0, 1, 2], len(m)).astype(np.int64)
    kind = rng.choice([INFEASIBLE, INFEASIBLE, ADJUSTED, -1], len(m)).astype(np.int64)
    tested = rng.integers(0, 50, len(m)).astype(np.int64)
    traffic = rng.random(n) < 0.3  # per robot (row of the table)
    for i in m.tolist():
        group[i].infeasible = twins[i].infeasible = str(
            rng.choice(["brake", "auto", "latest_contact", "stop_in_time"])
        )
    # speeds from standing still to far beyond the limits; a_max down to subnormal
    vel = rng.normal(size=(n, 2)) * rng.choice([0.0, 1e-300, 1.0, 1e300], size=(n, 1))
    a_max = rng.choice([2.0, 0.5, 1e-310], n)
    dt = 0.1
    out = rng.normal(size=(n, 2))
    expected = out.copy()
    settled = np.zeros(len(m), dtype=np.bool_)
    apply_braking(
        m, status, kind, tested, traffic, vel, a_max, dt, table.real, table.whole, out, settled
    )
    decided = (kind, np.zeros((len(m), 2)), tested)
    for j, i in enumerate(m.tolist()):
        acted = (
            status[j] == 0
            and kind[j] == INFEASIBLE
            and brakes_when_infeasible(twins[i], bool(traffic[i]))
        )
        assert settled[j] == acted
        done = (
            take_decision(twins[i], decided, j, vel[i], float(a_max[i]), dt, bool(traffic[i]))
            if acted
            else None
        )
        if done is not None:
            expected[i] = done
        ag, tw = group[i], twins[i]
        assert out[i].tobytes() == expected[i].tobytes()
        assert ag.current.tobytes() == tw.current.tobytes() and ag.age == tw.age
        sel, tsel = ag.last_selection, tw.last_selection
        assert (sel.status, sel.accel.tobytes(), sel.evaluations) == (
            tsel.status,
            tsel.accel.tobytes(),
            tsel.evaluations,
        )


def test_the_infeasible_option_is_a_checked_column():
    group = agents(3)
    table = columns.columns_of(group)
    for ag, label in zip(group, ("brake", "latest_contact", "auto"), strict=True):
        ag.infeasible = label
    assert [ag.infeasible for ag in group] == ["brake", "latest_contact", "auto"]
    assert table.whole[:, columns.FALLBACK].tolist() == [
        columns.FALLBACKS.index(v) for v in ("brake", "latest_contact", "auto")
    ]
    with pytest.raises(ValueError, match="infeasible"):
        group[0].infeasible = "swerve"
    assert group[0].infeasible == "brake"
    assert copy.deepcopy(group[1]).infeasible == "latest_contact"
    assert NAOAgent(infeasible="brake").infeasible == "brake"
