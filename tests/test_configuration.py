"""A final configuration planned per branch, from shapes and lengths sensed while
planning (docs/scenario.md, "Unknown shapes and a planned configuration").

Small declared benches, so the real planner and the real audit run in
fractions of a second; the paper's real-world task is tests/test_real_world.py.
"""

from __future__ import annotations

import copy
import json
import os
import time
from pathlib import Path
from typing import Any

import pytest

from app.execution.walker import Executor
from app.sources.outcomes import ClickSource
from planner import diagnosis
from planner.audit.branches import audit
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.scenario.loading import ScenarioError, parse_scenario
from planner.search.encoding import PLANNED
from planner.vocabulary import (
    Attached,
    SenseHumanHolding,
    SenseLengthOf,
    SenseShapeOf,
    parse_fluent,
)
from tests.plan_fixtures import tandem

_BENCH = """\
name = "planned"

[[regions]]
id = "robotOnly"
human_reach = false

[[regions]]
id = "shared"
human_reach = true

[[regions]]
id = "humanOnly"
human_reach = true

[feasibility.reachable]
left = ["robotOnly", "shared"]
right = ["robotOnly", "shared"]

[[parts]]
id = "top"
kind = "top"
region = "shared"
connections = ["c1", "c2"]
"""


def _part(pid: str, kind: str, region: str, **fields: str | list[str]) -> str:
    lines = [f'id = "{pid}"', f'kind = "{kind}"', f'region = "{region}"']
    for key, value in fields.items():
        words = [value] if isinstance(value, str) else value
        quoted = ", ".join(f'"{v}"' for v in words)
        shown = quoted if isinstance(value, str) else f"[{quoted}]"
        lines.append(f"{key} = {shown}")
    return "\n[[parts]]\n" + "\n".join(lines) + "\n"


# Two slots; leg1 has a square hole, leg2 a circle one. foot2 is circle or
# square: if circle it goes on leg2, if square leg2 needs foot3 from the far side.
SHAPES = (
    _BENCH
    + _part("leg1", "leg", "robotOnly", length="tall", shape="square")
    + _part("leg2", "leg", "shared", length="tall", shape="circle")
    + _part("leg3", "leg", "robotOnly", length="short", shape="square")
    + _part("foot1", "foot", "shared", shape="square")
    + _part("foot2", "foot", "robotOnly", shape=["circle", "square"])
    + _part("foot3", "foot", "humanOnly", shape="circle")
    + '\n[goal]\ntable = "stable"\nconfiguration = "planned"\n'
)

# leg2 is tall or short: if short, leg3 from the far side takes its place.
LENGTHS = (
    _BENCH
    + _part("leg1", "leg", "robotOnly", length="tall", shape="square")
    + _part("leg2", "leg", "shared", length=["tall", "short"], shape="square")
    + _part("leg3", "leg", "humanOnly", length="tall", shape="square")
    + _part("foot1", "foot", "shared", shape="square")
    + _part("foot2", "foot", "robotOnly", shape="square")
    + '\n[goal]\ntable = "stable"\nconfiguration = "planned"\n'
)


def _plan(text: str) -> Plan:
    return plan_scenario(parse_scenario(text, "planned.toml"), workers=1).plan


def _goal_pairs(plan: Plan, start: str, label: str) -> set[tuple[str, str]]:
    """The attachments at the goal reached from `start` through outcome `label`,
    then the outcomes the planner hoped for, with the human's hands staying free."""
    node_id = plan.nodes[start].child(label)
    assert node_id is not None
    while plan.nodes[node_id].kind != "goal":
        node = plan.nodes[node_id]
        # The human takes no initiative, so the robot's own choices show.
        wanted = "no" if isinstance(node.action, SenseHumanHolding) else node.expected
        hoped = node.child(wanted) if wanted is not None else None
        node_id = hoped or node.children[0].node
    pairs = set()
    for text in plan.nodes[node_id].state:
        fluent = parse_fluent(text)
        if isinstance(fluent, Attached):
            pairs.add((fluent.part, fluent.onto))
    return pairs


def _sensing(plan: Plan, kind: type[SenseShapeOf | SenseLengthOf]) -> list[str]:
    return [n for n, node in plan.nodes.items() if isinstance(node.action, kind)]


@pytest.fixture(scope="module")
def shapes_plan() -> Plan:
    return _plan(SHAPES)


def test_the_sensed_shape_changes_which_foot_goes_on_which_leg(shapes_plan: Plan) -> None:
    plan = shapes_plan
    sensed = _sensing(plan, SenseShapeOf)
    assert sensed, "the plan never looks at foot2"
    for node_id in sensed:
        # One outcome per option of the scenario, nothing else.
        assert sorted(plan.nodes[node_id].outcomes) == ["circle", "square"]
    node_id = sensed[0]
    circle = _goal_pairs(plan, node_id, "circle")
    square = _goal_pairs(plan, node_id, "square")
    assert ("foot2", "leg2") in circle and ("foot3", "leg2") not in circle
    assert ("foot3", "leg2") in square and ("foot2", "leg2") not in square
    for pairs in (circle, square):
        assert {p for p, q in pairs if q == "top"} == {"leg1", "leg2"}


def test_the_planned_plan_passes_the_audit_and_counts_its_sensing(shapes_plan: Plan) -> None:
    doc = shapes_plan.to_json()
    assert PLANNED in doc["facts"]
    assert not any(f.startswith("goal(") for f in doc["facts"])
    assert audit(doc) == []
    assert shapes_plan.statistics["S"] >= 1


def _first(doc: dict[str, Any], action: str) -> str:
    return next(n for n, node in doc["nodes"].items() if node["action"] == action)


@pytest.mark.parametrize(("foot", "seen"), [("foot1", None), ("foot2", "shapeIs(foot2,square)")])
def test_the_audit_flags_a_foot_on_a_leg_of_another_shape(
    shapes_plan: Plan, foot: str, seen: str | None
) -> None:
    doc = copy.deepcopy(shapes_plan.to_json())
    # Where the robot attaches a square foot (known, or seen to be) to leg1,
    # send it to the circle leg2 instead.
    node_id = next(
        n
        for n, node in doc["nodes"].items()
        if (node["action"] or "").startswith("attach(")
        and node["action"].endswith(",leg1,foot)")
        and any(s.startswith("holding(") and s.endswith(f",{foot})") for s in node["state"])
        and (seen is None or seen in node["state"])
    )
    doc["nodes"][node_id]["action"] = doc["nodes"][node_id]["action"].replace("leg1", "leg2")
    messages = [v.message for v in audit(doc) if v.node == node_id]
    assert f"precondition failed: {foot} (square) fits the hole of leg2 (circle)" in messages


def test_the_audit_flags_an_attachment_before_the_shape_is_seen(shapes_plan: Plan) -> None:
    doc = copy.deepcopy(shapes_plan.to_json())
    # Forget, in the state after sensing, what the camera saw of foot2.
    node_id = next(
        n
        for n, node in doc["nodes"].items()
        if "shapeIs(foot2,circle)" in node["state"]
        and (node["action"] or "").startswith("attach(")
        and any(s.startswith("holding(") and s.endswith(",foot2)") for s in node["state"])
    )
    doc["nodes"][node_id]["state"].remove("shapeIs(foot2,circle)")
    messages = [v.message for v in audit(doc) if v.node == node_id]
    assert "precondition failed: shapes of foot2 and leg2 known" in messages


def test_the_audit_flags_a_goal_that_is_not_a_stable_table(shapes_plan: Plan) -> None:
    doc = copy.deepcopy(shapes_plan.to_json())
    goal = next(n for n, node in doc["nodes"].items() if node["kind"] == "goal")
    state = doc["nodes"][goal]["state"]
    foot_on_leg1 = next(s for s in state if s.startswith("attached(") and ",leg1," in s)
    state.remove(foot_on_leg1)
    messages = [v.message for v in audit(doc) if v.node == goal]
    assert "goal not reached: leg1 has no foot" in messages


def test_an_unknown_length_is_sensed_and_changes_which_legs_go_on_the_top() -> None:
    plan = _plan(LENGTHS)
    assert audit(plan.to_json()) == []
    sensed = _sensing(plan, SenseLengthOf)
    assert sensed
    node_id = sensed[0]
    assert sorted(plan.nodes[node_id].outcomes) == ["short", "tall"]
    tall = {p for p, q in _goal_pairs(plan, node_id, "tall") if q == "top"}
    short = {p for p, q in _goal_pairs(plan, node_id, "short") if q == "top"}
    assert "leg2" in tall
    assert short == {"leg1", "leg3"}


def test_explicit_attachments_still_plan_as_a_fixed_stable_table() -> None:
    # A fixed table uses every foot: the spare circle foot3 goes.
    spare = _part("foot3", "foot", "humanOnly", shape="circle")
    known = (
        SHAPES.replace('shape = ["circle", "square"]', 'shape = "circle"')
        .replace('configuration = "planned"\n', "")
        .replace(spare, "")
    )
    fixed = parse_scenario(known, "fixed.toml")
    pairs = fixed.goal_pairs()
    listed = ", ".join(f'["{p}", "{q}"]' for p, q in pairs)
    explicit = known.replace('table = "stable"', f"attachments = [{listed}]")
    by_table = plan_scenario(fixed, workers=1).plan.to_json()
    by_list = plan_scenario(parse_scenario(explicit, "fixed.toml"), workers=1).plan.to_json()
    assert PLANNED not in by_table["facts"]
    assert by_table["nodes"] == by_list["nodes"]
    assert by_table["facts"] == by_list["facts"]


def test_diagnosis_refuses_no_planned_table() -> None:
    scenario = parse_scenario(SHAPES, "planned.toml")
    assert diagnosis.causes(scenario, scenario.reachable_pairs()) == []


def _error(text: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, "bad.toml")
    return str(info.value)


@pytest.mark.parametrize(
    ("before", "after", "message"),
    [
        (
            'shape = ["circle", "square"]',
            'shape = ["circle"]',
            "bad.toml: parts[5].shape: an unknown shape lists at least two options "
            "(a known one is a plain word)",
        ),
        (
            'shape = ["circle", "square"]',
            'shape = ["circle", "circle"]',
            "bad.toml: parts[5].shape[1]: duplicate option 'circle' (already at parts[5].shape[0])",
        ),
        (
            'configuration = "planned"\n',
            "",
            "bad.toml: parts[5].shape: an unknown shape (circle or square) needs the planner to "
            'choose the table: write configuration = "planned" under [goal]',
        ),
        (
            'configuration = "planned"\n',
            'configuration = "always"\n',
            "bad.toml: goal.configuration: expected 'fixed' or 'planned', got string 'always'",
        ),
        (
            'region = "humanOnly"\nshape = "circle"',
            'region = "humanOnly"\nshape = "triangle"',
            "bad.toml: goal.configuration: no stable table when foot2 is square",
        ),
    ],
)
def test_bad_options_are_one_line_errors(before: str, after: str, message: str) -> None:
    assert before in SHAPES
    assert _error(SHAPES.replace(before, after, 1)) == message


def test_a_planned_configuration_needs_a_table_goal() -> None:
    text = SHAPES.replace('table = "stable"', 'attachments = [["leg1", "top"]]').replace(
        'shape = ["circle", "square"]', 'shape = "circle"'
    )
    assert _error(text) == (
        'bad.toml: goal.configuration: only with table = "stable": explicit attachments fix '
        "the configuration"
    )


def _script(plan: Plan, shape: str) -> list[str]:
    """The labels of one branch: the human's hands stay free, foot2 is `shape`,
    and the hoped-for outcome elsewhere."""
    labels = []
    node_id = plan.root
    while plan.nodes[node_id].kind != "goal":
        node = plan.nodes[node_id]
        wanted = node.expected
        if isinstance(node.action, SenseHumanHolding):
            wanted = "no"
        elif isinstance(node.action, SenseShapeOf):
            wanted = shape
        if node.outcomes:
            labels.append(wanted or node.outcomes[0])
        node_id = node.child(wanted if node.outcomes else None) or node.children[0].node
    return labels


@pytest.mark.parametrize(("shape", "onto_leg2"), [("circle", "foot2"), ("square", "foot3")])
def test_tandem_execute_answers_the_shape_from_a_script(
    tmp_path: Path, shapes_plan: Plan, shape: str, onto_leg2: str
) -> None:
    env = {**os.environ, "TANDEM_DATA_DIR": str(tmp_path / "data")}
    plan_file = tmp_path / "plan.json"
    plan_file.write_text(json.dumps(shapes_plan.to_json()))
    script = tmp_path / "answers.txt"
    script.write_text("\n".join(_script(shapes_plan, shape)) + "\n")
    done = tandem("execute", str(plan_file), "--responses", f"scripted:{script}", env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1].split()[2] == "goal"
    export = tmp_path / "session.json"
    sid = done.stdout.splitlines()[0].split()[1]
    assert tandem("sessions", "export", sid, "-o", str(export), env=env).returncode == 0
    events = json.loads(export.read_text())["events"]
    sensed = [e for e in events if e["action"] == "sense(shapeOf(foot2))"]
    assert [e["outcome"] for e in sensed] == [shape]
    last = shapes_plan.nodes[events[-1]["node"]].state
    assert f"attached({onto_leg2},leg2,foot)" in last


def test_tandem_check_passes_a_planned_plan_and_fails_a_broken_one(
    tmp_path: Path, shapes_plan: Plan
) -> None:
    doc = shapes_plan.to_json()
    good = tmp_path / "good.json"
    good.write_text(json.dumps(doc))
    assert tandem("check", str(good)).returncode == 0
    broken = copy.deepcopy(doc)
    node_id = _first(broken, "sense(shapeOf(foot2))")
    # One outcome per option: dropping one leaves the plan incomplete.
    broken["nodes"][node_id]["children"] = broken["nodes"][node_id]["children"][:1]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(broken))
    done = tandem("check", str(bad))
    assert done.returncode != 0
    assert "outcome not covered: square" in done.stdout + done.stderr


def test_a_click_says_what_the_part_is(shapes_plan: Plan) -> None:
    # The dashboard's buttons: a click answers the look, in words of the part.
    clicks = ClickSource(timeout=None)
    executor = Executor(shapes_plan, clicks)
    executor.start()
    seen: list[tuple[str, ...]] = []
    while not executor.done:
        offer = clicks.pending()
        if offer is None:
            time.sleep(0.001)
            continue
        node = shapes_plan.nodes[offer.node_id]
        choice = node.expected or offer.options[0]
        if isinstance(offer.action, SenseShapeOf):
            seen.append(offer.words)
            choice = "square"
        if clicks.click(choice, offer.node_id):
            while clicks.pending() == offer and not executor.done:
                time.sleep(0.001)
    assert executor.wait() == "goal"
    assert seen == [("foot2 is circle", "foot2 is square")]
    last = shapes_plan.nodes[executor.events[-1].node].state
    assert "shapeIs(foot2,square)" in last


def test_unknown_shapes_with_explicit_attachments_say_what_to_write() -> None:
    text = SHAPES.replace('table = "stable"\nconfiguration = "planned"\n', "").replace(
        "[goal]\n", '[goal]\nattachments = [["leg1", "top"]]\n'
    )
    assert _error(text) == (
        "bad.toml: parts[5].shape: an unknown shape (circle or square) needs the planner to "
        'choose the table: write table = "stable" and configuration = "planned" under [goal]'
    )


def test_parts_that_make_no_stable_table_are_refused() -> None:
    # Three slots, but two tall legs and one short, whatever sensing says.
    text = SHAPES.replace('connections = ["c1", "c2"]', 'connections = ["c1", "c2", "c3"]')
    assert _error(text) == "bad.toml: goal.configuration: no stable table from these parts"


def test_the_audit_flags_a_grasp_that_would_carry_the_other_arm(shapes_plan: Plan) -> None:
    doc = copy.deepcopy(shapes_plan.to_json())
    other = {"left": "right", "right": "left"}
    node_id, arm, leg = next(
        (n, arm, leg)
        for n, node in doc["nodes"].items()
        if (node["action"] or "").startswith("hold(")
        for arm, leg in [node["action"][len("hold(") : -1].split(",")]
        if leg.startswith("leg")
        and not any(s.startswith(f"holding({other[arm]},") for s in node["state"])
    )
    carried = [f"attached(foot1,{leg},foot)", f"holding({other[arm]},foot1)"]
    doc["nodes"][node_id]["state"] += carried
    messages = [v.message for v in audit(doc) if v.node == node_id]
    assert f"precondition failed: not holding(_,foot1) while foot1 is attached to {leg}" in messages
