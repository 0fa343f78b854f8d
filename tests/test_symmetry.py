"""Interchangeable parts: found from the facts, states renamed to a canonical one,
and each canonical state solved once, with the same tree of plans."""

from __future__ import annotations

import pytest

from planner.audit.branches import audit
from planner.planning import feasible_pairs, plan_scenario
from planner.scenario import paper
from planner.scenario.loading import Scenario, parse_scenario
from planner.search.symmetry import Symmetry, substitute


def _declared(family: str, n: int) -> Scenario:
    return parse_scenario(paper.scenario_toml(family, n, "declared"), f"{family}{n}")


def _symmetry(scenario: Scenario, drop: str = "") -> Symmetry:
    reachable, _ = feasible_pairs(scenario, None)
    facts = [f for f in scenario.facts(reachable) if not f.startswith("reachable(")]
    return Symmetry.of([f for f in facts if f != drop], reachable)


def test_members_are_interchangeable_only_where_every_fact_says_so() -> None:
    # paper-05: the left arm reaches the odd shared legs and feet, the right arm the
    # even ones; leg1 (robot only) and leg2 (human only) have no twin.
    odd, even = (("leg3", "foot3"), ("leg5", "foot5")), (("leg4", "foot4"), ("leg6", "foot6"))
    u6 = _declared("U", 6)
    assert sorted(_symmetry(u6).classes) == sorted([odd, even])
    # One fact that tells leg5 from leg3 (where it lies) leaves leg3 without a twin.
    assert _symmetry(u6, drop="loc(leg5,shared)").classes == (even,)
    # Legs only the human reaches, with no feet: one class of single parts.
    p4 = _symmetry(_declared("P", 4))
    assert p4.classes == ((("leg2",), ("leg3",), ("leg4",), ("leg5",)),)


def test_members_that_share_a_part_are_not_renamed() -> None:
    # foot goes onto both legs: the legs alike, but renaming one would rename the
    # other's foot too.
    facts = ["goal(a,top)", "goal(b,top)", "goal(f,a)", "goal(f,b)", "part(a)", "part(b)"]
    assert Symmetry.of(facts, [("left", "a"), ("left", "b")]).classes == ()
    alone = ["goal(a,top)", "goal(b,top)", "goal(f,a)", "goal(g,b)"]
    assert Symmetry.of(alone, []).classes == ((("a", "f"), ("b", "g")),)


def test_a_state_and_its_renaming_have_one_canonical_state() -> None:
    sym = _symmetry(_declared("U", 6))
    # Pair 3 assembled, pair 5 loose: assembled in id order, its own canonical state.
    in_order = frozenset(
        {"attached(leg3,top,c1)", "attached(foot3,leg3,foot)", "humanFree", "initiatives(1)"}
    )
    assert sym.canonical(in_order) == (in_order, None)
    # The same with pair 5 assembled instead: renamed to the state above.
    swap = {"leg3": "leg5", "leg5": "leg3", "foot3": "foot5", "foot5": "foot3"}
    other = frozenset(substitute(f, swap) for f in in_order)
    canon, renaming = sym.canonical(other)
    assert canon == in_order and renaming is not None
    assert renaming.actual_state(canon) == other
    assert renaming.actual("hold(left,foot3)") == "hold(left,foot5)"
    assert renaming.canonical("askHelp(leg5,top)") == "askHelp(leg3,top)"
    # Names inside quoted strings and of functions are left alone.
    assert substitute('say("leg3",leg3(leg3))', swap) == 'say("leg3",leg3(leg5))'


@pytest.mark.parametrize(("family", "n"), [("U", 6), ("P", 6)])
def test_interchangeable_states_are_solved_once_with_the_same_tree(family: str, n: int) -> None:
    scenario = _declared(family, n)
    every = plan_scenario(scenario, workers=2, symmetry=False)
    once = plan_scenario(scenario, workers=2)
    assert once.solves < every.solves
    # The paper's statistics count the unfolded tree: the same tree of plans, with
    # parts renamed where a state took its plan from an interchangeable one.
    paper_columns = [k for k in every.plan.stats if k not in ("dag_nodes", "plan_s")]
    assert paper_columns
    assert {k: once.plan.stats[k] for k in paper_columns} == {
        k: every.plan.stats[k] for k in paper_columns
    }
    assert audit(once.plan.to_json()) == []
    # Where states are solved never changes the plan: one worker process's plan
    # and two workers' are the same document.
    alone = plan_scenario(scenario, workers=2, inline_s=1e9)
    assert alone.plan.to_json()["nodes"] == once.plan.to_json()["nodes"]
