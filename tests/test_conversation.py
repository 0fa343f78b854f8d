"""The conversation around a task plan: greeting, goodbye, warnings, explanations.

Each is planned where its rule needs it (real clingo, the real planner), and
the audit, which re-implements the rules on its own, names the rule when the
same plan goes without it; verbosity picks the repertoire; the paper's columns
of the statistics count the task alone.
"""

from __future__ import annotations

import pytest

from planner.audit.branches import audit
from planner.plan.model import PAPER_STAT_KEYS, Child, Plan, PlanNode, tree_stats
from planner.planning import plan_scenario
from planner.vocabulary import CONVERSATION, Communication
from tests.domain_fixtures import scenario

CHATTY = ('verbosity = "normal"', 'verbosity = "chatty"')
TERSE = ('verbosity = "normal"', 'verbosity = "terse"')
# A dangerous spare part the table does not use, beside the leg only the human reaches.
NAIL = (
    "[goal]",
    '[[parts]]\nid = "nail"\nkind = "other"\nclass = "nail"\nregion = "humanOnly"\n'
    "dangerous = true\n\n[goal]",
)
NO_INITIATIVE = ("[robot]", "[human]\ninitiative = 0\n\n[robot]")

_plans: dict[tuple[tuple[str, str], ...], Plan] = {}


def planned(*edits: tuple[str, str]) -> Plan:
    if edits not in _plans:
        _plans[edits] = plan_scenario(scenario(*edits), workers=1).plan
    return _plans[edits]


def without(plan: Plan, names: set[str]) -> Plan:
    """The same plan with the talk named `names` left out (parents skip over it)."""

    def skip(node_id: str) -> str:
        node = plan.nodes[node_id]
        while node.action is not None and node.action.name in names:
            node_id = node.children[0].node
            node = plan.nodes[node_id]
        return node_id

    kept = {
        node_id: node.model_copy(
            update={
                "children": [Child(outcome=c.outcome, node=skip(c.node)) for c in node.children]
            }
        )
        for node_id, node in plan.nodes.items()
        if node.action is None or node.action.name not in names
    }
    out = plan.model_copy(update={"root": skip(plan.root), "nodes": kept})
    out.stats = {**plan.statistics, **tree_stats(out)}
    return out


def talk(plan: Plan, name: str) -> list[tuple[PlanNode, PlanNode]]:
    """(the talk, the node after it) for every node of action `name`."""
    return [
        (node, plan.nodes[node.children[0].node])
        for node in plan.nodes.values()
        if node.action is not None and node.action.name == name
    ]


# name: (scenario edits, how the task after the talk starts, the rule's words in the audit)
CASES: dict[str, tuple[tuple[tuple[str, str], ...], tuple[str, ...], str]] = {
    "greet": ((), ("hold(left,leg1)",), "due [greet]"),
    "farewell": ((), ("goal",), "due [farewell]"),
    "warnWorking": ((), ("hold(", "attach("), "warnWorking(shared)"),
    "warnDanger": (
        (NAIL, NO_INITIATIVE),
        ("askHelp(leg2,", "requestToAttach(leg2,"),
        "warnDanger(nail)",
    ),
    "explainAsk": ((CHATTY,), ("askHelp(leg2,",), "explainAsk(leg2)"),
    "explainOwnTask": (
        (CHATTY,),
        ("hold(left,foot1)", "hold(right,foot1)"),
        "explainOwnTask(foot1)",
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_each_conversation_action_is_said_where_its_rule_needs_it(name: str) -> None:
    edits, before, words = CASES[name]
    plan = planned(*edits)
    assert audit(plan.to_json()) == []
    said = talk(plan, name)
    assert said, f"no {name} in the plan"
    for node, after in said:
        assert isinstance(node.action, Communication) and node.say and node.why
        assert node.state == after.state  # talk moves no part
        # What follows (after any more talk) is the task the talk is about.
        while after.action is not None and after.action.name in CONVERSATION:
            after = plan.nodes[after.children[0].node]
        shown = str(after.action) if after.action is not None else "goal"
        assert shown.startswith(before), shown
    if name == "greet":
        assert plan.nodes[plan.root].action is not None
        assert plan.nodes[plan.root].action.name == "greet" and len(said) == 1
    # The cheapest task plan breaks the rule without the talk: the audit says which.
    problems = [v.message for v in audit(without(plan, {name}).to_json())]
    assert problems and all("conversation before" in p for p in problems)
    assert any(words in p for p in problems), problems


def test_verbosity_picks_the_repertoire() -> None:
    def names(plan: Plan) -> set[str]:
        return {n.action.name for n in plan.nodes.values() if n.action is not None}

    terse, normal, chatty = planned(TERSE), planned(), planned(CHATTY)
    assert not names(terse) & set(CONVERSATION)
    assert names(normal) & set(CONVERSATION) == {"greet", "farewell", "warnWorking"}
    assert {"greet", "farewell", "warnWorking", "explainAsk", "explainOwnTask"} <= names(chatty)
    for plan in (terse, normal, chatty):
        assert audit(plan.to_json()) == []
    # Said once per goal leaf and once at the start; explanations only when chatty.
    assert normal.statistics["GE"] == normal.statistics["L"] + 1
    assert terse.statistics["GE"] == terse.statistics["W"] == terse.statistics["X"] == 0
    assert normal.statistics["X"] == 0 < chatty.statistics["X"]
    assert normal.statistics["W"] > 0


def test_the_paper_columns_count_the_task_alone() -> None:
    plan = planned()
    task = without(plan, set(CONVERSATION))
    assert len(task.nodes) < len(plan.nodes) == plan.statistics["dag_nodes"]
    for key in PAPER_STAT_KEYS[:-1]:
        assert plan.statistics[key] == task.statistics[key], key
    # A warning said where none is due is a violation too.
    wrong = plan.to_json()
    node_id, node = next((i, n) for i, n in wrong["nodes"].items() if n["action"] == "greet")
    node["action"] = "warnWorking(shared)"
    problems = [v.message for v in audit(wrong)]
    assert any("said [warnWorking(shared)], due [greet]" in p for p in problems), problems


def test_a_plan_from_a_later_state_does_not_greet_again() -> None:
    # A repair plans from where the execution stood: the robot greeted already.
    resumed = plan_scenario(
        scenario(), workers=1, start=frozenset({"attached(leg1,top,c1)", "humanFree"})
    ).plan
    assert "resumed" in resumed.facts
    assert talk(resumed, "farewell") and not talk(resumed, "greet")
    assert audit(resumed.to_json()) == []
    # The audit holds it to that: a greeting put back at its root is talk too many.
    first = planned()
    (greeting, _), = talk(first, "greet")
    again = resumed.model_copy(
        update={
            "root": "hello",
            "nodes": {
                **resumed.nodes,
                "hello": greeting.model_copy(
                    update={"children": [Child(outcome=None, node=resumed.root)]}
                ),
            },
        }
    )
    again.stats = {**resumed.statistics, **tree_stats(again)}
    # (The greeting copied from the first plan also carries that plan's start state.)
    problems = [v.message for v in audit(again.to_json())]
    assert any(m.endswith("said [greet], due []") for m in problems), problems


def test_the_talk_found_from_the_search_is_the_talk_of_the_built_plan() -> None:
    """Planning finds the conversation from the search's DAG before the plan is
    built (`conversation.talk_about`); it is what the built plan's nodes give."""
    from planner.search.hcp import ConditionalPlanner
    from planner.search.plan_building import build_plan
    from planner.talk.conversation import talk_about

    planners: list[ConditionalPlanner] = []
    sc = scenario(CHATTY, NAIL, NO_INITIATIVE)
    new = plan_scenario(sc, workers=1, planner_hook=planners.append).plan
    search = planners[0]

    def built(said: dict[str, list[Communication]] | None = None) -> Plan:
        return build_plan(
            search.nodes,
            search.root,
            scenario_name=sc.name,
            scenario_sha256=sc.sha256,
            facts=new.facts,
            timings=(0.0, 0.0),
            said=said,
        )

    task = built()  # the task alone
    views = ((i, n.kind, n.action, n.state) for i, n in task.nodes.items())
    old = built(talk_about(task.facts, task.root, views))  # found from the plan's nodes
    assert new.root == old.root and new.nodes.keys() == old.nodes.keys()
    fields = ("kind", "action", "state", "children", "say", "why")
    for node_id, node in new.nodes.items():
        assert node.model_dump(include=set(fields)) == old.nodes[node_id].model_dump(
            include=set(fields)
        )
    said = [n.action.name for n in new.nodes.values() if n.action and n.action.name in CONVERSATION]
    assert {"greet", "farewell", "warnDanger", "explainAsk"} <= set(said)


def test_a_plan_built_with_its_talk_counts_it_as_the_audit_does() -> None:
    """`build_plan` puts the talk in as it builds; the statistics count it as the
    audit's own count does, also before a goal at the root."""
    from planner.audit.stats import tree_stats as audited_stats
    from planner.search.hcp import DagNode
    from planner.search.plan_building import build_plan
    from planner.vocabulary import Farewell, Greet, State

    chatty = planned(CHATTY, NAIL, NO_INITIATIVE)
    done: State = frozenset({"humanFree"})  # a bench already assembled: a goal at the root
    at_goal = build_plan(
        {done: DagNode(done, goal=True)},
        done,
        scenario_name="done",
        scenario_sha256="0" * 64,
        facts=["verbosity(normal)"],
        timings=(0.0, 0.0),
        said={"n0": [Greet(), Farewell()]},
    )
    assert [n.kind for n in at_goal.nodes.values()] == ["communication", "communication", "goal"]
    for plan in (chatty, at_goal):
        counted = {k: v for k, v in plan.statistics.items() if k not in ("plan_s", "checks_s")}
        assert counted == tree_stats(plan)
        assert counted == audited_stats(plan.to_json())
    assert at_goal.statistics["GE"] == 2 and at_goal.statistics["BF"] == 1
