"""`[feasibility] points = "each"`: the motion planner checks every arm's reach of
every point of the top, and the plan puts parts only where the acting arm reaches
(real clingo, pybullet and OMPL on paper-02, whose left arm cannot reach the top's c3).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from app.execution.events import REPAIR
from app.execution.repair import Repairer
from app.execution.retargeting import retargeter_for
from app.execution.walker import Executor
from app.sources.outcomes import ExpectedSource, FallbackSource, ScriptedSource
from planner.audit.branches import audit
from planner.audit.slots import slot_problems
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.scenario.loading import ScenarioError, parse_scenario
from planner.scenario.model import Scenario
from planner.vocabulary import SenseHumanAttachingWhere
from tests.plan_fixtures import SCENARIOS
from tests.test_slots import _script_to_choice

GEOMETRY = 'source = "geometry"'


def paper_02(points: str) -> Scenario:
    text = (SCENARIOS / "paper" / "paper-02.toml").read_text()
    assert GEOMETRY in text
    return parse_scenario(text.replace(GEOMETRY, f'{GEOMETRY}\npoints = "{points}"'), "p.toml")


@pytest.fixture(scope="module")
def each() -> tuple[Scenario, dict[str, Any]]:
    scenario = paper_02("each")
    return scenario, plan_scenario(scenario, workers=1).plan.to_json()


def test_every_motion_ends_at_the_point_its_state_names(
    each: tuple[Scenario, dict[str, Any]],
) -> None:
    scenario, doc = each
    assert audit(doc) == []
    assert slot_problems(doc, scenario) == []
    assert "pointReach(right,top,c3)" in doc["facts"]
    assert "pointReach(left,top,c3)" not in doc["facts"]
    # Reaching the top's nearest point is not reaching all of them: the same bench
    # planned by nearest points sends an arm where it cannot work.
    nearest = paper_02("nearest")
    assert slot_problems(plan_scenario(nearest, workers=1).plan.to_json(), nearest) != []


def test_only_an_arm_that_reaches_a_point_attaches_there(
    each: tuple[Scenario, dict[str, Any]],
) -> None:
    _, doc = each
    onto_top = [
        (node_id, node["action"])
        for node_id, node in doc["nodes"].items()
        if str(node.get("action", "")).startswith("attach(") and ",top," in node["action"]
    ]
    assert onto_top and all(not a.startswith("attach(left,top,c3)") for _, a in onto_top)
    # The audit, which re-simulates without clingo, names the rule when a plan breaks it.
    node_id, action = next((n, a) for n, a in onto_top if a.startswith("attach(right,top,c3)"))
    broken = copy.deepcopy(doc)
    broken["nodes"][node_id]["action"] = action.replace("right", "left")
    said = [v.message for v in audit(broken) if v.node == node_id]
    assert any("armPoint(left," in m and ",top,c3)" in m for m in said), said


def test_points_each_needs_geometry() -> None:
    text = (SCENARIOS / "declared.toml").read_text()
    text = text.replace('source = "declared"', 'source = "declared"\npoints = "each"')
    with pytest.raises(ScenarioError, match="points"):
        parse_scenario(text, "d.toml")


def test_a_human_at_another_point_makes_the_robot_plan_again_from_it(
    each: tuple[Scenario, dict[str, Any]], tmp_path: Path
) -> None:
    scenario, doc = each
    plan = Plan.from_json(doc)
    labels, where_id, branch, other = _script_to_choice(plan)
    script = tmp_path / "responses.txt"
    script.write_text("\n".join([*labels, other, ""]))
    repairer = Repairer(scenario, lambda _plan: "kept")  # no store: the hash is not used
    executor = Executor(
        plan,
        FallbackSource(ScriptedSource(script), ExpectedSource()),
        repairing=repairer.repair,
        retarget=retargeter_for(scenario, plan),
    )
    assert executor.run() == "goal"
    # Not mapped onto the branch's point: planned again from the point really used.
    repairs = [e for e in executor.events if e.kind == REPAIR]
    assert [e.node for e in repairs] == [where_id]
    assert repairs[0].evidence is not None
    where = plan.nodes[where_id].action
    assert isinstance(where, SenseHumanAttachingWhere)
    seen = f"attached({where.part},{where.onto},{other})"
    assert repairs[0].evidence.replanned is not None
    assert seen in repairs[0].evidence.replanned.observed and branch != other
    # The new plan puts every later motion where its state says.
    assert audit(executor.plan.to_json()) == []
    assert slot_problems(executor.plan.to_json(), scenario) == []
