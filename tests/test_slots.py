"""Slots that match the world: the human attaches at another free slot than the branch
names, execution follows it, and the robot's later motions go there (real pybullet/OMPL)."""

from __future__ import annotations

import copy
import json
import math
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from app.execution.events import ExecutionEvent, describe
from app.execution.retargeting import retargeter_for
from app.execution.walker import Executor
from app.sources.outcomes import ClickSource, ExpectedSource, FallbackSource, Offer, ScriptedSource
from planner.audit.branches import audit
from planner.feasibility.cache import CheckCache
from planner.feasibility.checks import BenchChecks
from planner.feasibility.grasp_ik import POS_TOL
from planner.feasibility.reach import World
from planner.feasibility.scene import Site, site_of
from planner.feasibility.slot_map import SlotError, SlotMap, connection_points
from planner.plan.model import ROBOT_SLOT, SLOTS, Plan, PlanFormatError, PlanNode, RobotSlot
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario
from planner.vocabulary import Attach, Hands, SenseHumanAttachingWhere
from tests.plan_fixtures import SCENARIOS, plan_of, tandem

# Three slots on the top: when the human attaches the first of their legs, two are free.
SCENARIO = SCENARIOS / "paper" / "paper-02.toml"
# Two slots, and every motion of its plan at the slot its state names.
SMALL = SCENARIOS / "paper" / "paper-01.toml"


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(SCENARIO)


@pytest.fixture(scope="module")
def plan() -> Plan:
    return plan_of(SCENARIO)


def _free_points(plan: Plan, state: list[str], onto: str) -> list[str]:
    taken = {point for o, point in Hands.of(state).attached.values() if o == onto}
    return [c for c in connection_points(plan.facts)[onto] if c not in taken]


def _path_to(plan: Plan, wanted: Callable[[str], bool]) -> tuple[list[str], str]:
    """The outcome labels from the root to the first node that is `wanted` (breadth
    first), and that node."""
    queue = deque([(plan.root, list[str]())])
    seen = {plan.root}
    while queue:
        node_id, labels = queue.popleft()
        if wanted(node_id):
            return labels, node_id
        for child in plan.nodes[node_id].children:
            if child.node not in seen:
                seen.add(child.node)
                more = [child.outcome] if child.outcome is not None else []
                queue.append((child.node, labels + more))
    raise AssertionError("no such node in this plan")


def _script_to_choice(plan: Plan) -> tuple[list[str], str, str, str]:
    """The outcome labels from the root to the first humanAttachingWhere with two free
    slots, then that node's id, its branch slot and another free one."""

    def two_free(node_id: str) -> bool:
        node = plan.nodes[node_id]
        action = node.action
        return (
            isinstance(action, SenseHumanAttachingWhere)
            and len(_free_points(plan, node.state, action.onto)) >= 2
        )

    labels, node_id = _path_to(plan, two_free)
    node = plan.nodes[node_id]
    assert isinstance(node.action, SenseHumanAttachingWhere)
    branch = node.outcomes[0]
    other = next(c for c in _free_points(plan, node.state, node.action.onto) if c != branch)
    return labels, node_id, branch, other


def _run(plan: Plan, scenario: Scenario, script: Path) -> tuple[str, list[ExecutionEvent]]:
    source = FallbackSource(ScriptedSource(script), ExpectedSource())
    retargeter = retargeter_for(scenario, plan)
    assert retargeter is not None  # a plan with motions, on a geometric bench
    executor = Executor(plan, source, retarget=retargeter)
    result = executor.run()
    assert retargeter._checks is None  # closed by the executor, in its thread
    return result, executor.events


def test_the_next_robot_motion_at_a_leg_the_human_put_elsewhere_ends_at_its_real_slot(
    plan: Plan, scenario: Scenario, tmp_path: Path
) -> None:
    labels, where_id, branch, real = _script_to_choice(plan)
    where = plan.nodes[where_id].action
    assert isinstance(where, SenseHumanAttachingWhere)
    leg, onto = where.part, where.onto
    script = tmp_path / "responses.txt"
    script.write_text("\n".join([*labels, real, ""]))
    result, events = _run(plan, scenario, script)
    assert result == "goal"
    at = next(i for i, e in enumerate(events) if e.node == where_id)
    assert events[at].outcome == branch  # the branch is followed...
    seen = events[at].evidence
    assert seen is not None
    # In the plan's names, and in the world's (the same here: no slot was taken before).
    assert seen.slot is not None
    assert (seen.slot.onto, seen.slot.branch, seen.slot.used, seen.slot.real) == (
        onto, branch, real, real
    )
    # ...and the next robot motion working at that leg (a foot onto it) goes to its real slot.
    onto_leg = next(
        e for e in events[at:] if isinstance(e.action, Attach) and e.action.onto == leg
    )  # fmt: skip
    assert onto_leg.motion is not None and onto_leg.evidence is not None
    assert onto_leg.evidence.retargeted is not None
    assert onto_leg.evidence.retargeted.motion == onto_leg.motion
    stored = plan.nodes[onto_leg.node].motion
    assert stored is not None and stored.path != onto_leg.motion.path
    with World(scenario) as world:
        end = world.endpoint(onto_leg.motion.arm, onto_leg.motion.path[-1])
        assert math.dist(end, world.site_target(Site(onto, real))) <= POS_TOL
        # The branch's slot is elsewhere: the stored motion went there, this one does not.
        assert math.dist(end, world.site_target(Site(onto, branch))) > 5 * POS_TOL
        stored_end = world.endpoint(stored.arm, stored.path[-1])
        assert math.dist(stored_end, world.site_target(Site(onto, branch))) <= POS_TOL
        # Every later re-targeted motion ends (attach) or starts (unhold) at a real slot
        # of that part's assembly.
        retargeted = [e for e in events[at:] if e.evidence and e.evidence.retargeted]
        assert len(retargeted) >= 2
        sites = [world.site_target(Site(onto, c)) for c in connection_points(plan.facts)[onto]]
        for e in retargeted:
            assert e.motion is not None and e.action is not None
            q = e.motion.path[-1] if isinstance(e.action, Attach) else e.motion.path[0]
            assert min(math.dist(world.endpoint(e.motion.arm, q), xyz) for xyz in sites) <= POS_TOL


def test_the_slot_map_stays_one_to_one_and_refuses_taken_or_unknown_slots() -> None:
    facts = [f"connection(top,c{i})" for i in (1, 2, 3)] + ["connection(leg1,foot)"]
    slots = SlotMap(facts)
    state = ["attached(leg1,top,c1)"]
    slots.follow("top", "c2", "c3", state)  # the branch says c2, the human used c3
    assert slots.to_json() == {"top": {"c2": "c3", "c3": "c2"}}
    assert slots.state(["attached(leg2,top,c2)", *state]) == [
        "attached(leg2,top,c3)",
        "attached(leg1,top,c1)",
    ]
    assert slots.action(Attach("left", "top", "c3")) == Attach("left", "top", "c2")
    with pytest.raises(SlotError, match="taken"):
        slots.follow("top", "c3", "c1", state)
    with pytest.raises(SlotError, match="no connection point c9"):
        slots.follow("top", "c3", "c9", state)
    # Back where the branch says: the map is the identity again.
    slots.follow("top", "c2", "c2", state)
    assert slots.identity


def test_site_of_follows_the_attachment_chain() -> None:
    attached = {"leg1": ("top", "c2"), "foot1": ("leg1", "foot")}
    assert site_of(attached, "leg1", "foot") == Site("top", "c2")
    assert site_of(attached, "foot1", "x") == Site("top", "c2")
    assert site_of(attached, "leg2", "foot") == Site("leg2", "foot")


def test_tandem_execute_follows_a_scripted_slot_to_the_goal(plan: Plan, tmp_path: Path) -> None:
    labels, where_id, branch, real = _script_to_choice(plan)
    script = tmp_path / "responses.txt"
    script.write_text("\n".join([*labels, f"{real}  # the human uses another free slot", ""]))
    data = tmp_path / "data"
    done = tandem(
        "execute", str(SCENARIO), "--responses", f"scripted:{script}", "--data-dir", str(data)
    )
    assert done.returncode == 0, done.stderr
    assert ": goal after" in done.stdout
    assert f"-> {branch} (scripted)" in done.stderr
    assert f"at {real}" in done.stderr  # the event says where the human really attached
    from app.sessions.store import SessionStore

    with SessionStore(data) as store:
        session = store.list_sessions()[0]
        events = store.events(session.id)
    evidence = [e.evidence for e in events if e.evidence is not None]
    assert any(d.slot is not None and d.slot.real == real for d in evidence)
    assert any(d.retargeted is not None and d.retargeted.motion for d in evidence)


def _wrong_slot() -> tuple[dict[str, Any], dict[str, Any], str, str]:
    """paper-01's plan, and a copy whose robot attach onto the top at c1 has a real
    path to c2 instead; the node and the arm."""
    doc = plan_of(SMALL).to_json()
    node_id, node = next(
        (i, n) for i, n in doc["nodes"].items() if str(n["action"]).endswith(",top,c1)")
    )
    arm = node["motion"]["arm"]
    held = Hands.of(node["state"]).holding[arm]
    with CheckCache() as cache, BenchChecks(load_scenario(SMALL), cache=cache) as checks:
        path = checks.move(arm, held, Site("top", "c2"))
    broken = copy.deepcopy(doc)
    broken["nodes"][node_id]["motion"]["path"] = path
    return doc, broken, node_id, arm


def test_audit_flags_a_motion_to_the_wrong_slot() -> None:
    from planner.audit.slots import slot_problems

    doc, broken, node_id, arm = _wrong_slot()
    scenario = load_scenario(SMALL)
    assert slot_problems(doc, scenario) == []
    problems = slot_problems(broken, scenario)
    assert [n for n, _ in problems] == [node_id]
    assert f"{arm} motion ends" in problems[0][1]
    assert "from the site of top's c1 (top@c1)" in problems[0][1]


def test_tandem_check_with_the_scenario_checks_motion_targets(tmp_path: Path) -> None:
    doc, broken, node_id, _ = _wrong_slot()
    good, bad = tmp_path / "plan.json", tmp_path / "bad.json"
    good.write_text(json.dumps(doc))
    bad.write_text(json.dumps(broken))
    ok = tandem("check", str(good), "--scenario", str(SMALL))
    assert ok.returncode == 0 and "plan OK" in ok.stdout, ok.stdout + ok.stderr
    flagged = tandem("check", str(bad), "--scenario", str(SMALL))
    assert flagged.returncode == 1
    assert f"{node_id}" in flagged.stdout and "from the site of top's c1" in flagged.stdout
    other = tandem("check", str(good), "--scenario", str(SCENARIO))
    assert other.returncode != 0 and "not the scenario of this plan" in other.stderr


def test_clicks_offer_every_free_slot_and_a_click_elsewhere_is_followed(
    plan: Plan, scenario: Scenario
) -> None:
    labels, where_id, branch, real = _script_to_choice(plan)
    answers = iter([*labels, real])
    offered: dict[str, tuple[str, ...]] = {}
    clicks = ClickSource(timeout=5.0)

    def answer(offer: Offer | None) -> None:
        if offer is not None:
            offered[offer.node_id] = offer.options
            clicks.click(next(answers, offer.options[0]), offer.node_id)

    clicks.on_offer = answer
    executor = Executor(plan, clicks, retarget=retargeter_for(scenario, plan))
    clicks.slots = executor
    assert executor.run() == "goal"
    node = plan.nodes[where_id]
    assert isinstance(node.action, SenseHumanAttachingWhere)
    # The branch has one outcome; the buttons are every free slot of the top.
    assert node.outcomes == [branch]
    assert set(offered[where_id]) == set(_free_points(plan, node.state, node.action.onto))
    event = next(e for e in executor.events if e.node == where_id)
    assert event.outcome == branch and event.text == describe(node.action, real)
    assert any(e.evidence and e.evidence.retargeted for e in executor.events)


def test_the_robot_attaches_at_a_free_slot_it_reaches_when_the_named_one_is_out_of_reach(
    tmp_path: Path,
) -> None:
    from planner.audit.slots import slot_problems

    path = SCENARIOS / "default.toml"  # the left arm reaches only the top's c2
    scenario, plan = load_scenario(path), plan_of(path)
    labels, node_id = _path_to(plan, lambda n: plan.nodes[n].robot_slot is not None)
    node = plan.nodes[node_id]
    action, chosen = node.action, node.robot_slot
    assert isinstance(action, Attach) and node.motion is not None and chosen is not None
    assert chosen.onto == "top" and chosen.branch == action.slot and chosen.real != action.slot
    assert node.slots == {"top": {action.slot: chosen.real, chosen.real: action.slot}}
    with World(scenario) as world:
        end = world.endpoint(action.arm, node.motion.path[-1])
        assert math.dist(end, world.site_target(Site("top", chosen.real))) <= POS_TOL
    # The plan's motions are where its slot maps say, and its branches continuous.
    assert slot_problems(plan.to_json(), scenario) == []
    assert audit(plan.to_json()) == []
    # Executing that branch takes the same slot: the stored motions need no re-targeting.
    script = tmp_path / "responses.txt"
    script.write_text("\n".join([*labels, ""]))
    result, events = _run(plan, scenario, script)
    assert result == "goal"
    event = next(e for e in events if e.node == node_id)
    assert event.motion == node.motion and event.evidence is None
    assert not any(e.evidence and e.evidence.retargeted for e in events)


def test_a_nodes_slot_map_and_robot_slot_are_typed_and_saved_only_when_set() -> None:
    doc: dict[str, Any] = {
        "kind": "actuation",
        "action": "attach(left,top,c1)",
        "state": ["holding(left,leg1)"],
        "children": [{"outcome": None, "node": "n1"}],
        SLOTS: {"top": {"c1": "c2", "c2": "c1"}},
        ROBOT_SLOT: {"onto": "top", "branch": "c1", "real": "c2", "why": "left cannot reach c1"},
    }
    node = PlanNode.model_validate(doc)  # as files written before the fields were typed
    assert node.slots == {"top": {"c1": "c2", "c2": "c1"}}
    assert node.robot_slot == RobotSlot(
        onto="top", branch="c1", real="c2", why="left cannot reach c1"
    )
    assert node.model_extra == {}
    assert node.to_json() == doc
    assert list(node.to_json()) == list(doc)  # in the same order: files are unchanged
    plain = {k: v for k, v in doc.items() if k not in (SLOTS, ROBOT_SLOT)}
    assert PlanNode.model_validate(plain).to_json() == plain
    assert {SLOTS, ROBOT_SLOT} <= set(PlanNode.model_fields)  # the audit's names are the model's
    broken = plan_of(SMALL).to_json()
    next(iter(broken["nodes"].values()))[ROBOT_SLOT] = {"onto": "top"}
    with pytest.raises(PlanFormatError, match="robot_slot"):
        Plan.from_json(broken)


def test_audit_flags_a_slot_map_that_is_not_one_to_one() -> None:
    from planner.audit.slots import slot_problems

    path = SCENARIOS / "default.toml"
    doc = plan_of(path).to_json()
    node_id = next(i for i, n in doc["nodes"].items() if ROBOT_SLOT in n)
    doc["nodes"][node_id][SLOTS] = {"top": {"c1": "c2"}}  # c2 stands for c2 as well
    problems = dict(slot_problems(doc, load_scenario(path)))
    assert problems[node_id] == "the slot map of top is not one to one over its points"


def test_after_a_repair_the_world_keeps_its_slots_and_the_new_plan_is_re_targeted(
    tmp_path: Path,
) -> None:
    from app.execution.events import REPAIR
    from app.execution.repair import Repairer

    # The default plan's left arm put leg1 at the top's real c2 (it cannot reach c1);
    # the human then attaches leg2 at the plan's c2, which is the real c1.
    path = SCENARIOS / "default.toml"
    scenario, plan = load_scenario(path), plan_of(path)
    script = tmp_path / "responses.txt"
    script.write_text("!attach leg2 top c2\n")
    source = FallbackSource(ScriptedSource(script), ExpectedSource())
    repairer = Repairer(scenario, lambda p: "new")
    executor = Executor(
        plan, source, repairing=repairer.repair, retarget=retargeter_for(scenario, plan)
    )
    assert executor.run() == "goal"
    at = next(i for i, e in enumerate(executor.events) if e.kind == REPAIR)
    feet = [
        e for e in executor.events[at:]
        if isinstance(e.action, Attach) and e.motion is not None
    ]  # fmt: skip
    assert {str(e.action) for e in feet} == {"attach(left,leg1,foot)", "attach(right,leg2,foot)"}
    real = {"leg1": "c2", "leg2": "c1"}
    with World(scenario) as world:
        for e in feet:
            assert e.motion is not None and isinstance(e.action, Attach)
            leg = e.action.onto
            end = world.endpoint(e.motion.arm, e.motion.path[-1])
            assert math.dist(end, world.site_target(Site("top", real[leg]))) <= POS_TOL


def test_without_a_motion_planner_the_executor_takes_the_plans_slot_choices() -> None:
    plan = plan_of(SCENARIOS / "default.toml")
    executor = Executor(plan, ExpectedSource())
    assert executor.run() == "goal"
    # The plan's own choice (leg1 at the real c2) is followed: no motion needs re-targeting.
    assert executor.slots.world.to_json() == {"top": {"c1": "c2", "c2": "c1"}}
    assert all(e.evidence is None for e in executor.events if e.kind == "actuation")
