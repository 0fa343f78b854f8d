"""Tests for planner.audit.branches: hand-built plans over a small fact set.

Every state below is written out by hand from docs/domain.md, not produced
by the audit's own simulator, so the tests check the simulator too.
"""

from __future__ import annotations

import json
import time
from typing import Any

import pytest

from planner.audit.actions import parse_sim_action
from planner.audit.branches import Violation, audit, format_report
from planner.audit.domain import Domain
from planner.audit.facts import parse_facts
from planner.audit.fluents import SimState, parse_sim_state
from planner.audit.stats import tree_stats
from planner.vocabulary import Term, TermError, parse_term

# A top with one connection in the shared region, a robot-reachable leg in
# the shared region (so the human may pick it up), a dangerous foot the
# human cannot reach, and a human-only leg that no manipulator reaches.
# leg2 is reserved in every state of the plan, so it is never a candidate:
# that keeps the plan small while leaving a delegable part for askHelp.
# No initiative fact: the human's initiative budget defaults to 1. A terse
# robot: the conversation it would otherwise need around these hand-built plans
# is tested on planned ones (tests/test_conversation.py).
FACTS = [
    "region(robotOnly)", "region(shared)", "region(humanOnly)",
    "humanReach(shared)", "humanReach(humanOnly)",
    "manipulator(left)", "manipulator(right)",
    "part(top)", "class(top,top)", "connection(top,c1)", "loc(top,shared)",
    "part(leg1)", "movable(leg1)", "class(leg_square,leg1)", "loc(leg1,shared)",
    "part(leg2)", "movable(leg2)", "class(leg_square,leg2)", "loc(leg2,humanOnly)",
    "part(foot1)", "movable(foot1)", "class(foot_square,foot1)", "loc(foot1,robotOnly)",
    "dangerous(foot1)",
    "attachable(leg_square,top)", "attachable(foot_square,leg_square)",
    "reachable(left,top)", "reachable(right,top)",
    "reachable(left,leg1)", "reachable(right,leg1)",
    "reachable(left,foot1)", "reachable(right,foot1)",
    "goal(leg1,top)", "safety(normal)", "verbosity(terse)",
]  # fmt: skip

R2 = "reserved(leg2)"
DONE = "attached(leg1,top,c1)"
IT = "initiatives(1)"


def _node(
    kind: str, action: str | None, state: list[str], children: list[tuple[str | None, str]]
) -> dict[str, Any]:
    node: dict[str, Any] = {
        "kind": kind,
        "action": action,
        "state": sorted([R2, *state]),
        "children": [{"outcome": o, "node": n} for o, n in children],
    }
    if kind == "communication":
        node["say"] = f"(says {action})"
        node["why"] = f"(because of {action})"
    return node


def make_plan() -> dict[str, Any]:
    """A correct complete plan; g1 is shared by n5 and n9."""
    hh, hp = "humanHolding", "humanHoldingPart(leg1)"
    nodes = {
        "n0": _node("sensing", "sense(humanHolding)", [], [("yes", "n4"), ("no", "n1")]),
        # no: the human's hands are empty, so the robot may take the shared leg
        # (with the right arm although the left one is free and reaches leg1:
        # the planner would not, but that is a preference, not a rule).
        "n1": _node("actuation", "hold(right,leg1)", ["humanFree"], [(None, "n2")]),
        "n2": _node(
            "actuation",
            "attach(right,top,c1)",
            ["holding(right,leg1)", "humanFree"],
            [(None, "n3")],
        ),
        "n3": _node(
            "actuation", "unhold(right)", ["holding(right,leg1)", "humanFree", DONE], [(None, "g0")]
        ),
        "g0": _node("goal", None, [DONE, "humanFree"], []),
        # yes: exactly one candidate, so the robot knows the human holds leg1
        # and the human has used their initiative (budget 1): no candidates left.
        "n4": _node(
            "communication", "confirmAttach(leg1,top)", [hh, hp, IT],
            [("yes", "n5"), ("no", "n6")],
        ),
        "n5": _node(
            "sensing",
            "sense(humanAttachingWhere(leg1,top))",
            [hh, hp, IT, "wantToAttach(leg1,top)"],
            [("c1", "g1")],
        ),
        "n6": _node(
            "communication", "requestToUnhold(leg1)", [hh, hp, IT, "reserved(leg1)"],
            [(None, "n7")],
        ),
        "n7": _node(
            "actuation", "hold(right,leg1)", ["humanFree", IT, "reserved(leg1)"], [(None, "n8")]
        ),
        # Attaching leg1 settles it: reserved(leg1) is forgotten, so both
        # answers to confirmAttach end in the same goal node g1.
        "n8": _node(
            "actuation",
            "attach(right,top,c1)",
            ["holding(right,leg1)", "humanFree", IT, "reserved(leg1)"],
            [(None, "n9")],
        ),
        "n9": _node(
            "actuation",
            "unhold(right)",
            ["holding(right,leg1)", "humanFree", IT, DONE],
            [(None, "g1")],
        ),
        "g1": _node("goal", None, [DONE, "humanFree", IT], []),
    }  # fmt: skip
    stats = {
        "L": 3, "D": 6, "A": 3, "S": 1, "C": 2, "K": 0, "O": 0, "CF": 1, "R": 1,
        "DN": 3, "BF": 2, "N": 13, "dag_nodes": 12, "plan_s": 0.1, "checks_s": 0.0,
    }  # fmt: skip
    return {
        "format": "tandem-plan/1",
        "scenario": {"name": "audit-test", "sha256": "0" * 64},
        "facts": FACTS,
        "root": "n0",
        "nodes": nodes,
        "stats": stats,
    }


def messages(violations: list[Violation]) -> list[str]:
    return [v.message for v in violations]


def not_stats(violations: list[Violation]) -> list[Violation]:
    return [v for v in violations if not v.message.startswith("stats:")]


# ---------------------------------------------------------------- sound plans


def test_correct_plan_has_no_violations() -> None:
    plan = make_plan()
    assert audit(plan) == []
    assert format_report(audit(plan)) == "plan OK: no violations"
    # The file format is JSON: a round trip changes nothing.
    assert audit(json.loads(json.dumps(plan))) == []


def test_shared_node_is_checked_against_every_parent_and_counted_per_path() -> None:
    plan = make_plan()
    parents = [n for n, v in plan["nodes"].items() if any(c["node"] == "g1" for c in v["children"])]
    assert parents == ["n5", "n9"]
    stats = tree_stats(plan)
    assert stats["N"] == 13 and stats["dag_nodes"] == 12 and stats["L"] == 3
    # A wrong state in the shared node is reported once per parent edge.
    plan["nodes"]["g1"]["state"].append("humanHolding")
    assert not_stats(audit(plan)) == [
        Violation(
            "g1",
            "root > yes > yes > c1",
            "state is not the successor of n5 (sense(humanAttachingWhere(leg1,top)), outcome c1): "
            "unexpected humanHolding",
        ),
        Violation(
            "g1",
            "root > yes > no",
            "state is not the successor of n9 (unhold(right)): unexpected humanHolding",
        ),
    ]


# ---------------------------------------------------------------- one test per violation


def test_missing_outcome() -> None:
    plan = make_plan()
    plan["nodes"]["n0"]["children"] = [{"outcome": "yes", "node": "n4"}]
    out = audit(plan)
    assert Violation("n0", "root", "outcome not covered: no") in out
    assert Violation("n1", "", "node is not reachable from the root") in out


def test_impossible_outcome() -> None:
    plan = make_plan()
    plan["nodes"]["n5"]["children"].append({"outcome": "c2", "node": "g1"})
    assert Violation("n5", "root > yes > yes", "impossible outcome: c2") in audit(plan)


def test_broken_precondition_busy_manipulator() -> None:
    plan = make_plan()
    # n2: the right hand already holds leg1.
    plan["nodes"]["n2"]["action"] = "hold(right,foot1)"
    out = audit(plan)
    assert Violation("n2", "root > no", "precondition failed: free(right)") in out
    assert not any("precondition failed: reachable" in m for m in messages(out))


def test_broken_precondition_hands_unknown() -> None:
    plan = make_plan()
    # Start with hold of the shared leg before sensing the human's hands.
    plan["root"] = "n1"
    plan["nodes"]["n1"]["state"] = [R2]
    out = audit(plan)
    assert Violation("n1", "root", "precondition failed: humanKnowsNot(leg1)") in out


def test_safety_ask_help_of_dangerous_part() -> None:
    plan = make_plan()
    n1 = plan["nodes"]["n1"]
    n1.update(kind="communication", action="askHelp(foot1,leg1)", say="Could you?", why="Because.")
    out = audit(plan)
    assert (
        Violation(
            "n1", "root > no", "safety: askHelp(foot1,leg1) involves the dangerous part foot1"
        )
        in out
    )
    # The safety rule is reported as such, not as a failed precondition.
    assert "precondition failed: not dangerous(foot1)" not in messages(out)


def test_safety_strict_unsafe_region() -> None:
    plan = make_plan()
    # Under strict safety, the loose dangerous foot makes the human-only region unsafe.
    plan["facts"] = [f for f in FACTS if f not in ("loc(foot1,robotOnly)", "safety(normal)")]
    plan["facts"] += ["loc(foot1,humanOnly)", "safety(strict)"]
    plan["nodes"]["n1"].update(
        kind="communication", action="askHelp(leg2,top)", say="Could you?", why="Because."
    )
    assert Violation(
        "n1",
        "root > no",
        "safety: askHelp(leg2,top) under strict safety: leg2 lies in unsafeRegion(humanOnly)",
    ) in audit(plan)


def test_leaf_not_at_goal() -> None:
    plan = make_plan()
    plan["nodes"]["n9"]["children"] = []
    assert not_stats(audit(plan)) == [Violation("n9", "root > yes > no", "leaf not at the goal")]


def test_goal_node_must_satisfy_goal() -> None:
    plan = make_plan()
    plan["nodes"]["g0"]["state"].append("wantToAttach(leg1,top)")
    out = audit(plan)
    assert (
        Violation("g0", "root > no", "goal not reached: pending task wantToAttach(leg1,top)") in out
    )


def test_wrong_successor_state() -> None:
    plan = make_plan()
    # requestToUnhold frees the human's hands: the state must say humanFree.
    plan["nodes"]["n7"]["state"].remove("humanFree")
    out = audit(plan)
    assert out[0] == Violation(
        "n7",
        "root > yes > no",
        "state is not the successor of n6 (requestToUnhold(leg1)): missing humanFree",
    )


def test_wrong_stats() -> None:
    plan = make_plan()
    plan["stats"]["N"] = 12
    assert audit(plan) == [Violation("", "", "stats: N is 12 but the tree has 13")]


def test_stats_missing_or_not_integer() -> None:
    plan = make_plan()
    del plan["stats"]["BF"]
    plan["stats"]["L"] = 3.0
    assert audit(plan) == [
        Violation("", "", "stats: L is 3.0, not an integer (the tree has 3)"),
        Violation("", "", "stats: BF is missing (the tree has 2)"),
    ]


def test_cycle() -> None:
    plan = make_plan()
    plan["nodes"]["n3"]["children"] = [{"outcome": None, "node": "n1"}]
    out = audit(plan)
    assert Violation("n3", "root > no", "cycle: child n1 is an ancestor of this node") in out
    # No statistics on a cyclic graph: the unfolded tree is infinite.
    assert not any(m.startswith("stats:") for m in messages(out))
    with pytest.raises(ValueError, match="cycle"):
        tree_stats(plan)


def test_missing_say() -> None:
    plan = make_plan()
    plan["nodes"]["n4"]["say"] = ""
    del plan["nodes"]["n6"]["why"]
    assert audit(plan) == [
        Violation("n4", "root > yes", "communication node needs a non-empty say"),
        Violation("n6", "root > yes > no", "communication node needs a non-empty why"),
    ]


# ---------------------------------------------------------------- domain rules


def domain(add: tuple[str, ...] = (), drop: tuple[str, ...] = ()) -> Domain:
    facts, errors = parse_facts([f for f in FACTS if f not in drop] + list(add))
    assert errors == []
    return Domain(facts)


def st(*fluents: str) -> SimState:
    state, errors = parse_sim_state(list(fluents))
    assert errors == []
    return state


def check(dom: Domain, state: SimState, action: str) -> list[str]:
    act = parse_sim_action(action, dom.f)
    assert not isinstance(act, str)
    fails, safety = dom.preconditions(state, act)
    return fails + safety


def outcomes(dom: Domain, state: SimState, action: str) -> dict[str | None, SimState] | None:
    act = parse_sim_action(action, dom.f)
    assert not isinstance(act, str)
    return dom.outcomes(state, act)


def test_sensing_the_initiative_records_it() -> None:
    plan = make_plan()
    plan["nodes"]["n4"]["state"].remove(IT)
    assert Violation(
        "n4",
        "root > yes",
        "state is not the successor of n0 (sense(humanHolding), outcome yes): "
        "missing initiatives(1)",
    ) in audit(plan)
    # Two candidates: the part is learnt, and the initiative counted, one step
    # later; only the count is remembered, not which part it was.
    dom = domain(add=("initiative(2)",))
    s = st("humanHolding", IT)
    assert dom.candidates(s) == ["leg1", "leg2"]
    assert outcomes(dom, s, "sense(humanHoldingWhichPart)") == {
        "leg1": st("humanHolding", "humanHoldingPart(leg1)", "initiatives(2)"),
        "leg2": st("humanHolding", "humanHoldingPart(leg2)", "initiatives(2)"),
    }
    # Several candidates: yes alone neither names the part nor counts.
    assert outcomes(dom, st(IT), "sense(humanHolding)") == {
        "yes": st("humanHolding", IT),
        "no": st("humanFree", IT),
    }


def test_initiative_budget_limits_candidates() -> None:
    assert domain().candidates(st()) == ["leg1", "leg2"]
    assert domain().candidates(st(IT)) == []  # default budget 1
    two = domain(add=("initiative(2)",))
    assert two.candidates(st(IT)) == ["leg1", "leg2"]
    assert two.candidates(st("initiatives(2)")) == []
    # A count beyond the budget cannot be a real state.
    plan = make_plan()
    plan["nodes"]["n0"]["state"].append("initiatives(2)")
    assert Violation(
        "n0", "root", "root state: initiatives(2): more than the 1 initiative(s) allowed"
    ) in audit(plan)
    # Budget 0: nothing the human could have picked up, so the only answer is no.
    plan = make_plan()
    plan["facts"] = [*FACTS, "initiative(0)"]
    out = audit(plan)
    assert Violation("n0", "root", "impossible outcome: yes") in out
    # ...and the lapse no longer forgets that the human's hands are empty.
    zero = domain(add=("initiative(0)",))
    assert outcomes(zero, st("humanFree"), "hold(left,leg1)") == {
        None: st("humanFree", "holding(left,leg1)")
    }


def test_only_the_first_open_point_is_free() -> None:
    # ASP term order: c1 < c10 < c2 (constants compare as strings).
    dom = domain(add=("connection(top,c2)", "connection(top,c10)"))
    assert dom.free_point(st(), "leg1", "top") == "c1"
    assert dom.free_point(st("attached(leg2,top,c1)"), "leg1", "top") == "c10"
    assert dom.free_point(st("attached(leg2,top,c1)"), "foot1", "top") is None  # not attachable
    assert dom.free_point(st("attached(leg1,top,c1)"), "top", "top") is None  # P != Q
    held = st("holding(left,leg1)", "humanFree")
    assert check(dom, held, "attach(left,top,c1)") == []
    assert check(dom, held, "attach(left,top,c2)") == ["freePoint(leg1,top,c2)"]
    # The human's attachment has exactly one outcome: the first open point.
    s = st("attached(leg2,top,c1)", "requestedAttach(leg1,top)", "humanHolding",
           "humanHoldingPart(leg1)")  # fmt: skip
    got = outcomes(dom, s, "sense(humanAttachingWhere(leg1,top))")
    assert got is not None and list(got) == ["c10"]
    # In the plan: the extra points change nothing, naming another point is wrong.
    plan = make_plan()
    plan["facts"] = [*FACTS, "connection(top,c2)", "connection(top,c10)"]
    assert audit(plan) == []
    plan["nodes"]["n5"]["children"] = [{"outcome": "c2", "node": "g1"}]
    out = audit(plan)
    assert Violation("n5", "root > yes > yes", "impossible outcome: c2") in out
    assert Violation("n5", "root > yes > yes", "outcome not covered: c1") in out


def test_unhold_only_a_part_of_an_assembly() -> None:
    plan = make_plan()
    plan["nodes"]["n2"]["action"] = "unhold(right)"
    assert Violation(
        "n2", "root > no", "precondition failed: attached(leg1,_,_) or attached(_,leg1,_)"
    ) in audit(plan)
    dom = domain()
    # Something attached to the held part is enough.
    assert check(dom, st("holding(left,top)", "attached(leg2,top,c1)"), "unhold(left)") == []
    assert check(dom, st("holding(left,leg1)", DONE), "unhold(left)") == []


def test_attaching_settles_the_part() -> None:
    plan = make_plan()
    plan["nodes"]["n9"]["state"].append("reserved(leg1)")
    assert Violation(
        "n9",
        "root > yes > no",
        "state is not the successor of n8 (attach(right,top,c1)): unexpected reserved(leg1)",
    ) in audit(plan)
    # The human's attachment forgets reserved, keepsHolding and every declined(P,_).
    dom = domain(add=("goal(leg2,top)", "goal(leg2,leg1)", "connection(leg1,c1)",
                      "attachable(leg_square,leg_square)"))  # fmt: skip
    s = st("requestedAttach(leg2,top)", "declined(leg2,top)", "declined(leg2,leg1)",
           "declined(leg1,top)", "reserved(leg2)", "keepsHolding(leg2)", "humanHolding",
           "humanHoldingPart(leg2)", IT)  # fmt: skip
    assert outcomes(dom, s, "sense(humanAttachingWhere(leg2,top))") == {
        "c1": st("attached(leg2,top,c1)", "declined(leg1,top)", IT, "humanFree")
    }


def test_purposeful_actuation() -> None:
    plan = make_plan()
    plan["nodes"]["n1"]["action"] = "hold(right,foot1)"  # no goal(foot1,_)
    assert Violation("n1", "root > no", "precondition failed: stillNeeded(foot1)") in audit(plan)
    assert check(domain(), st("humanFree"), "hold(left,foot1)") == ["stillNeeded(foot1)"]
    assert check(domain(add=("goal(foot1,leg1)",)), st("humanFree"), "hold(left,foot1)") == []
    # Attach a part only where the final configuration wants it.
    other = domain(add=("goal(leg2,top)",), drop=("goal(leg1,top)",))
    s = st("holding(right,leg1)", "humanFree")
    assert check(other, s, "attach(right,top,c1)") == ["goal(leg1,top)"]


def test_symmetry_breaking_is_not_checked() -> None:
    # The planner asks about delegable parts in id order and prefers the left
    # arm; other orders are just as correct.
    dom = domain(add=("part(leg0)", "movable(leg0)", "class(leg_square,leg0)",
                      "loc(leg0,humanOnly)", "goal(leg0,top)", "goal(leg2,top)"))  # fmt: skip
    assert check(dom, st("humanFree"), "askHelp(leg2,top)") == []
    assert check(dom, st("humanFree", "declined(leg2,top)"), "requestToAttach(leg2,top)") == []
    assert check(dom, st("humanFree"), "hold(right,leg1)") == []


# ---------------------------------------------------------------- other checks


def test_kind_must_match_action() -> None:
    plan = make_plan()
    plan["nodes"]["n1"]["kind"] = "sensing"
    assert audit(plan) == [
        Violation("n1", "root > no", "kind is sensing but hold(right,leg1) is of kind actuation")
    ]


def test_deterministic_action_needs_one_null_child() -> None:
    plan = make_plan()
    plan["nodes"]["n1"]["children"][0]["outcome"] = "yes"
    out = audit(plan)
    assert (
        Violation(
            "n1",
            "root > no",
            "deterministic action needs exactly one child with outcome null, has [yes]",
        )
        in out
    )


def test_root_state_must_be_consistent() -> None:
    plan = make_plan()
    plan["nodes"]["n0"]["state"].append("holding(right,leg9)")
    out = audit(plan)
    assert Violation("n0", "root", "root state: holding(right,leg9): unknown part leg9") in out


def test_unknown_action_and_dangling_child() -> None:
    plan = make_plan()
    plan["nodes"]["n1"]["action"] = "fly(right,leg1)"
    plan["nodes"]["n8"]["children"] = [{"outcome": None, "node": "n99"}]
    out = audit(plan)
    assert Violation("n1", "root > no", "unknown action fly(right,leg1)") in out
    assert Violation("n8", "root > yes > no", "child 'n99' is not a node") in out
    assert Violation("n9", "", "node is not reachable from the root") in out


def test_format_report_lists_each_violation() -> None:
    report = format_report(
        [
            Violation("n3", "root > no", "leaf not at the goal"),
            Violation("", "", "stats: N is 1 but the tree has 2"),
        ]
    )
    assert report == (
        "2 violations:\n"
        "  n3 [root > no]: leaf not at the goal\n"
        "  plan: stats: N is 1 but the tree has 2"
    )


# ---------------------------------------------------------------- terms and statistics


def test_parse_nested_terms() -> None:
    assert parse_term("sense(humanAttachingWhere(leg2,top))") == Term(
        "sense", (Term("humanAttachingWhere", (Term("leg2"), Term("top"))),)
    )
    assert str(parse_term(" attach( left , top,c1 ) ")) == "attach(left,top,c1)"
    assert str(parse_term("class(leg_square,leg1)")) == "class(leg_square,leg1)"
    for bad in ("hold(left,", "hold(left leg1)", "", "a)b", "Hold(x)"):
        with pytest.raises(TermError):
            parse_term(bad)


def _synthetic(
    nodes: dict[str, list[tuple[str | None, str]]], kinds: dict[str, str]
) -> dict[str, Any]:
    return {
        "root": "r",
        "nodes": {
            n: {
                "kind": kinds[n],
                "action": None if kinds[n] == "goal" else "x",
                "children": [{"outcome": o, "node": c} for o, c in kids],
            }
            for n, kids in nodes.items()
        },
    }


def test_longest_branch_ties_take_the_first_in_children_order() -> None:
    kinds = {"r": "sensing", "a": "communication", "b": "actuation", "g": "goal", "h": "goal"}
    first_a = _synthetic(
        {"r": [("x", "a"), ("y", "b")], "a": [(None, "g")], "b": [(None, "h")], "g": [], "h": []},
        kinds,
    )
    assert {k: tree_stats(first_a)[k] for k in "DASC"} == {"D": 2, "A": 0, "S": 1, "C": 1}
    first_b = _synthetic(
        {"r": [("y", "b"), ("x", "a")], "a": [(None, "g")], "b": [(None, "h")], "g": [], "h": []},
        kinds,
    )
    assert {k: tree_stats(first_b)[k] for k in "DASC"} == {"D": 2, "A": 1, "S": 1, "C": 0}


def test_stats_of_a_huge_unfolding_are_computed_by_dp() -> None:
    # 300 levels, each node's two outcomes lead to the same next node: 2**300 leaves.
    depth = 300
    nodes: dict[str, list[tuple[str | None, str]]] = {
        f"v{i}": [("yes", f"v{i + 1}"), ("no", f"v{i + 1}")] for i in range(depth)
    }
    nodes[f"v{depth}"] = []
    kinds = {n: "sensing" for n in nodes} | {f"v{depth}": "goal"}
    plan = _synthetic(nodes, kinds)
    plan["root"] = "v0"
    t0 = time.perf_counter()
    stats = tree_stats(plan)
    assert time.perf_counter() - t0 < 1.0
    assert stats["L"] == 2**depth
    assert stats["N"] == 2 ** (depth + 1) - 1
    assert stats["DN"] == 2**depth - 1
    assert (stats["D"], stats["S"], stats["BF"], stats["dag_nodes"]) == (depth, depth, 2, depth + 1)
