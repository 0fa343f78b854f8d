"""The plan of the search's DAG: nodes numbered breadth-first, the talk put in.

The search (`hcp`) finds a DAG of states; this module turns it into the typed
`Plan` every consumer reads, with what the robot says in it. It lives beside the
search, not in `planner.plan`, so the plan's model knows nothing of how plans are found.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from planner.plan import walks
from planner.plan.model import Child, Plan, PlanNode, ScenarioRef, tree_stats
from planner.talk import phrases
from planner.vocabulary import Action, Communication, parse_term

if TYPE_CHECKING:
    from planner.search.dag import DagNode
    from planner.vocabulary import State


def build_plan(
    nodes: Mapping[State, DagNode],
    root: State,
    *,
    scenario_name: str,
    scenario_sha256: str,
    facts: list[str],
    timings: tuple[float, float] | None = None,
    ids: Mapping[State, str] | None = None,
    said: Mapping[str, Sequence[Communication]] | None = None,
) -> Plan:
    """The plan of the builder's DAG, nodes numbered breadth-first (`ids`, if
    numbered already by `number_states`). `timings` (plan s, checks s) make it
    complete with statistics; None: a partial plan, where states still open become
    leaves without an action. `said`: what the robot says before nodes of a
    complete plan, by their `ids` (`conversation.talk_about`), put in as
    communication nodes just before them."""
    ids = number_states(nodes, root) if ids is None else ids
    writer = _NodeWriter(nodes, ids, said or {}, facts, complete=timings is not None)
    numbered = writer.numbering(root)
    plan = Plan(
        scenario=ScenarioRef(name=scenario_name, sha256=scenario_sha256),
        facts=sorted(facts),
        root=numbered[(root, 0)],
        nodes={node_id: writer.node(key, numbered) for key, node_id in numbered.items()},
    )
    if timings is not None:
        plan.stats = {**tree_stats(plan), "plan_s": round(timings[0], 3)}
        plan.stats["checks_s"] = round(timings[1], 3)
    return plan


# (state, i): the i-th sentence said before the state's node, or (i = the number of
# sentences) the node itself; edges go into (state, 0).
_Key = tuple["State", int]


class _NodeWriter:
    """The plan nodes of a DAG's states, and of the sentences said before them."""

    def __init__(
        self,
        nodes: Mapping[State, DagNode],
        ids: Mapping[State, str],
        talk: Mapping[str, Sequence[Communication]],
        facts: list[str],
        *,
        complete: bool,
    ) -> None:
        self.nodes = nodes
        self.ids = ids
        self.talk = talk
        self.facts = frozenset(facts)
        self.verbosity = _fact_value(facts, "verbosity") or ""
        self.language = (_fact_value(facts, "language") or "en-us").strip('"')
        # A partial plan is redrawn twice a second while planning goes on: its
        # sentences wait for the complete plan.
        self.complete = complete

    def chain(self, state: State) -> int:
        """How many sentences are said before the state's node."""
        return len(self.talk.get(self.ids[state], ()))

    def numbering(self, root: State) -> dict[_Key, str]:
        """Node ids of the states and sentences. The talk shifts the numbering, so
        the nodes are numbered again."""
        if not self.talk:
            return {(state, 0): node_id for state, node_id in self.ids.items()}
        nodes = self.nodes
        order = walks.with_chains(root, lambda s: [c for _, c in nodes[s].children], self.chain)
        return {key: f"n{i}" for i, key in enumerate(order)}

    def node(self, key: _Key, numbered: Mapping[_Key, str]) -> PlanNode:
        state, i = key
        node = self.nodes.get(state)
        if node is None or (node.action is None and not node.goal):
            # Still open while planning goes on: a leaf for now.
            return PlanNode(kind="open", action=None, state=sorted(state), children=[])
        if i < self.chain(state):
            return self._sentence(state, i, numbered)
        return self._planned(state, node, numbered)

    def _sentence(self, state: State, i: int, numbered: Mapping[_Key, str]) -> PlanNode:
        sentence = self.talk[self.ids[state]][i]
        reason = phrases.why(sentence, state, self.facts)
        return PlanNode(
            kind="communication",
            action=sentence,
            state=sorted(state),
            children=[Child(outcome=None, node=numbered[(state, i + 1)])],
            say=phrases.say(sentence, self.verbosity, reason, self.language),
            why=reason,
        )

    def _planned(self, state: State, node: DagNode, numbered: Mapping[_Key, str]) -> PlanNode:
        kind, action = kind_and_action(node)
        say = why = None
        if isinstance(action, Communication) and self.complete:
            why = phrases.why(action, state, self.facts)
            say = phrases.say(action, self.verbosity, why, self.language)
        return PlanNode(
            kind=kind,
            action=action,
            state=sorted(state),
            # While planning goes on, a child added after the numbering waits for
            # the next snapshot.
            children=[
                Child(outcome=label, node=numbered[(succ, 0)])
                for label, succ in node.children
                if (succ, 0) in numbered
            ],
            expected=node.expected,
            say=say,
            why=why,
        )


def kind_and_action(node: DagNode) -> tuple[str, Action | None]:
    """What a planned DAG node is in the plan: its kind, and its action (none at a goal)."""
    if node.goal:
        return "goal", None
    return node.kind or "goal", node.action


def _fact_value(facts: list[str], name: str) -> str | None:
    for text in facts:
        term = parse_term(text)
        if term.name == name and len(term.args) == 1:
            return str(term.args[0])
    return None


def number_states(nodes: Mapping[State, DagNode], root: State) -> dict[State, str]:
    """Node ids in breadth-first order, so that files are stable and readable. States
    not in `nodes` (still open, while planning goes on) get ids but no children."""

    def successors(state: State) -> list[State]:
        node = nodes.get(state)
        return [succ for _, succ in node.children] if node is not None else []

    return {state: f"n{i}" for i, state in enumerate(walks.breadth_first(root, successors))}
