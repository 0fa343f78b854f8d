"""Small real scenarios and solvers for the rule tests (real clingo, no mocks)."""

from __future__ import annotations

from planner.resources import scenario_path
from planner.scenario.loading import Scenario, parse_scenario
from planner.search.encoding import FeasibilityContext
from planner.search.solver import BranchSolver, SequentialPlan
from planner.vocabulary import parse_action

DEFAULT = scenario_path("declared.toml")


def scenario(*edits: tuple[str, str]) -> Scenario:
    """The default scenario with textual edits (old, new) applied."""
    text = DEFAULT.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return parse_scenario(text, "edited.toml")


def solver(sc: Scenario, skip: tuple[str, ...] = (), horizon: int = 10) -> BranchSolver:
    reach = sc.reachable_pairs()
    facts = [f for f in sc.facts(reach) if not f.startswith("reachable(")]
    return BranchSolver(facts, horizon, FeasibilityContext(lambda m, p: (m, p) in reach), skip=skip)


def actions(found: SequentialPlan | None) -> list[str]:
    assert found is not None, "expected a plan"
    return [str(s.action) for s in found.steps]


def successor(bs: BranchSolver, state: set[str], action: str) -> dict[str | None, set[str]]:
    return {o.label: set(o.state) for o in bs.outcomes(frozenset(state), parse_action(action))}
