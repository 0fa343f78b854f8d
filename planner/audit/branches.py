"""Audit a `tandem-plan/1` file by re-simulating every branch from its facts.

Independent of clingo and of the ASP encodings on purpose: the semantics come
from docs/domain.md through `planner.audit.domain`, so a bug in an encoding
shows up here as a violation instead of being reproduced.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from planner.audit.actions import COMMUNICATION, GOAL, KINDS, SimAction
from planner.audit.domain import Domain
from planner.audit.facts import Facts, parse_facts
from planner.audit.fluents import (
    HUMAN_FREE,
    HUMAN_HOLDING,
    SimFluent,
    SimState,
    fluent_str,
    parse_sim_state,
)
from planner.audit.motions import motion_problems
from planner.audit.stats import Child, compare_stats, node_children, tree_stats
from planner.audit.talk import conversation_problems
from planner.collector_pause import cycle_collection_paused
from planner.plan.model import FORMAT  # the name only; the checks are our own

ROOT_PATH = "root"


@dataclass(frozen=True)
class Violation:
    """One problem. `node` and `path` are "" for plan-level problems (format, stats)."""

    node: str
    # "root" then the non-null outcome labels taken, e.g. "root > yes > leg2 > no";
    # deterministic steps add nothing, so the node id pins the depth.
    path: str
    message: str


def audit(plan: dict[str, Any]) -> list[Violation]:
    """Every violation of docs/domain.md in `plan`, in depth-first order; [] if sound."""
    out: list[Violation] = []
    plan_level = _plan_level(out)
    if not isinstance(plan, dict):
        return [Violation("", "", "plan is not a JSON object")]
    if plan.get("format") != FORMAT:
        plan_level(f"format: expected {FORMAT!r}, got {plan.get('format')!r}")
    facts, fact_errors = parse_facts(plan.get("facts"))
    for message in fact_errors:
        plan_level(message)
    nodes = plan.get("nodes")
    if not isinstance(nodes, dict) or not nodes:
        plan_level("nodes must be a non-empty object")
        return out
    root = plan.get("root")
    if not isinstance(root, str) or root not in nodes:
        plan_level(f"root {root!r} is not a node")
        return out

    # The audit keeps every node's state to its end: collections would walk them
    # all again and again (U30: 7 of 24 CPU-s).
    with cycle_collection_paused():
        _check_dag(Domain(facts), plan, out)
    return out


def _check_dag(dom: Domain, plan: dict[str, Any], out: list[Violation]) -> None:
    """The walk of every branch, then (on a well-formed DAG) the statistics, the
    motions and the conversation; violations go to `out`. (`plan` has its nodes
    and root: `audit` made sure of that.)"""
    nodes, root = plan["nodes"], plan["root"]
    walker = _Walker(dom, nodes, out)
    walker.run(root)
    for node_id in nodes:
        if node_id not in walker.paths:
            out.append(Violation(node_id, "", "node is not reachable from the root"))
    if not walker.sound:
        return  # statistics and motions only mean something on a well-formed DAG
    compare_stats(plan.get("stats"), tree_stats(plan), _plan_level(out))
    for node_id, message in motion_problems(nodes, root):
        out.append(Violation(node_id, walker.paths.get(node_id, ""), message))
    for node_id, message in conversation_problems(dom, nodes, root, walker.state):
        out.append(Violation(node_id, walker.paths.get(node_id, ""), message))


def _plan_level(out: list[Violation]) -> Callable[[str], None]:
    return lambda message: out.append(Violation("", "", message))


def format_report(violations: Sequence[Violation]) -> str:
    """Human-readable report, one violation a line."""
    if not violations:
        return "plan OK: no violations"
    count = len(violations)
    lines = [f"{count} violation{'s' if count != 1 else ''}:"]
    for v in violations:
        where = v.node or "plan"
        if v.path:
            where += f" [{v.path}]"
        lines.append(f"  {where}: {v.message}")
    return "\n".join(lines)


# ---------------------------------------------------------------- the walk


class _Walker:
    """Depth-first walk of the DAG; each node is checked once, each edge once."""

    def __init__(self, domain: Domain, nodes: dict[str, Any], out: list[Violation]) -> None:
        self.dom = domain
        self.nodes = nodes
        self.out = out
        self.paths: dict[str, str] = {}  # first path reaching each node
        self.successors: dict[str, dict[str | None, SimState] | None] = {}
        self.actions: dict[str, str] = {}
        self._states: dict[str, tuple[SimState, list[str]]] = {}
        self.sound = True  # no cycle, no dangling or malformed edge

    def report(self, node: str, path: str, message: str) -> None:
        self.out.append(Violation(node, path, message))

    def state(self, node_id: str) -> tuple[SimState, list[str]]:
        # Parsed lazily: an edge may be checked before its child is visited.
        if node_id not in self._states:
            raw = self.nodes[node_id]
            items = raw.get("state") if isinstance(raw, dict) else None
            self._states[node_id] = parse_sim_state(items)
        return self._states[node_id]

    def run(self, root: str) -> None:
        on_stack: set[str] = set()
        stack: list[tuple[str, Iterator[Child]]] = []

        def enter(node_id: str, path: str) -> None:
            on_stack.add(node_id)
            stack.append((node_id, iter(self.visit(node_id, path, is_root=not stack))))

        enter(root, ROOT_PATH)
        while stack:
            node_id, kids = stack[-1]
            nxt = next(kids, None)
            if nxt is None:
                on_stack.discard(node_id)
                stack.pop()
                continue
            label, target = nxt
            path = self.paths[node_id] + (f" > {label}" if label is not None else "")
            if target not in self.nodes:
                self.sound = False
                self.report(node_id, self.paths[node_id], f"child {target!r} is not a node")
                continue
            self.check_edge(node_id, label, target, path)
            if target in on_stack:
                self.sound = False
                self.report(
                    node_id,
                    self.paths[node_id],
                    f"cycle: child {target} is an ancestor of this node",
                )
            elif target not in self.paths:
                enter(target, path)

    def visit(self, node_id: str, path: str, *, is_root: bool) -> list[Child]:
        """Check one node; return its children for the walk."""
        self.paths[node_id] = path

        def report(message: str) -> None:
            self.report(node_id, path, message)

        raw = self.nodes[node_id]
        self.successors[node_id] = None
        if not isinstance(raw, dict):
            self.sound = False
            report("node is not an object")
            return []
        kids, kid_errors = node_children(raw)
        if kid_errors:
            self.sound = False
        for message in kid_errors:
            report(message)
        state, state_errors = self.state(node_id)
        for message in state_errors:
            report(message)
        if is_root:
            for message in _root_inconsistencies(self.dom.f, state):
                report(f"root state: {message}")

        text = self.check_kind(raw, kids, None if state_errors else state, report)
        if text is None:
            return kids
        action = self.dom.action(text)
        if isinstance(action, str):
            report(action)
            return kids
        self.actions[node_id] = action.text
        kind = raw.get("kind")
        if kind in KINDS and kind != action.kind:
            report(f"kind is {kind} but {action.text} is of kind {action.kind}")
        if not state_errors:
            self.successors[node_id] = self.check_action(action, state, kids, report)
        return kids

    def check_kind(
        self,
        raw: dict[str, Any],
        kids: list[Child],
        state: SimState | None,
        report: Callable[[str], None],
    ) -> str | None:
        """Checks what a node's kind asks of it (`state`: None if malformed);
        returns its action's text to simulate, or None if there is none."""
        kind, text = raw.get("kind"), raw.get("action")
        if kind not in KINDS:
            report(f"unknown kind {kind!r}")
        if kind == COMMUNICATION:
            for key in ("say", "why"):
                value = raw.get(key)
                if not isinstance(value, str) or not value.strip():
                    report(f"communication node needs a non-empty {key}")
        if kind == GOAL:
            if text is not None:
                report(f"goal node has action {text!r} (must be null)")
            if kids:
                report("goal node has children")
            if state is not None:
                for reason in self.dom.goal_failures(state):
                    report(f"goal not reached: {reason}")
            if text is None or not kids:
                return None
        elif not kids:
            report("leaf not at the goal")
            return None
        if text is None:
            report("action is null but the node is not a goal node")
            return None
        if not isinstance(text, str):
            report(f"action must be a string or null, got {text!r}")
            return None
        return text

    def check_action(
        self, action: SimAction, state: SimState, kids: list[Child], report: Callable[[str], None]
    ) -> dict[str | None, SimState] | None:
        fails, safety = self.dom.preconditions(state, action)
        for name in fails:
            report(f"precondition failed: {name}")
        for message in safety:
            report(message)
        outs = self.dom.outcomes(state, action)
        if outs is None:
            return None
        labels = [label for label, _ in kids]
        if action.deterministic:
            if labels != [None]:
                shown = ", ".join("null" if x is None else x for x in labels)
                report(
                    f"deterministic action needs exactly one child with outcome null, has [{shown}]"
                )
            return outs
        if not outs:
            report(f"{action.text} has no possible outcome")
        if None in labels:
            report("nondeterministic action has a child with outcome null")
        seen: set[str] = set()
        for label in labels:
            if label is None:
                continue
            if label in seen:
                report(f"duplicate outcome: {label}")
            seen.add(label)
            if label not in outs:
                report(f"impossible outcome: {label}")
        for label in outs:
            if label is not None and label not in seen:
                report(f"outcome not covered: {label}")
        return outs

    def check_edge(self, parent: str, label: str | None, child: str, path: str) -> None:
        outs = self.successors.get(parent)
        if outs is None or label not in outs:
            return  # unsimulable or impossible: already reported at the parent
        state, errors = self.state(child)
        if errors:
            return  # reported when the child is visited
        expected = outs[label]
        if state == expected:
            return
        via = self.actions[parent] + (f", outcome {label}" if label is not None else "")
        parts = []
        if missing := expected - state:
            parts.append(f"missing {', '.join(_sorted_fluents(missing))}")
        if extra := state - expected:
            parts.append(f"unexpected {', '.join(_sorted_fluents(extra))}")
        self.report(
            child, path, f"state is not the successor of {parent} ({via}): {'; '.join(parts)}"
        )


# ---------------------------------------------------------------- root state


def _root_inconsistencies(f: Facts, s: SimState) -> list[str]:
    """Why `s` cannot be a real state (used on the root, which is given)."""
    out: list[str] = []
    for y in sorted(s):
        shown = fluent_str(y)
        if y[0] == "holding" and y[1] not in f.manipulators:
            out.append(f"{shown}: unknown manipulator {y[1]}")
        if y[0] == "initiatives" and int(y[1]) > f.initiative:
            out.append(f"{shown}: more than the {f.initiative} initiative(s) allowed")
        # Every argument names a part, except the manipulator, the point, the count.
        parts = {"holding": y[2:], "attached": y[1:3], "initiatives": ()}.get(y[0], y[1:])
        out += [f"{shown}: unknown part {x}" for x in parts if x not in f.parts]
        if y[0] == "holding" and y[2] in f.parts and y[2] not in f.movable:
            out.append(f"{shown}: {y[2]} is not movable")
        if y[0] == "attached" and y[3] not in f.connections.get(y[2], set()):
            out.append(f"{shown}: {y[3]} is not a connection point of {y[2]}")
    out += _duplicates(s, "holding", (1,), "holds several parts")
    out += _duplicates(s, "holding", (2,), "is held by several manipulators")
    out += _duplicates(s, "attached", (1,), "is attached several times")
    out += _duplicates(s, "attached", (2, 3), "is used by several attachments")
    counts = sorted(fluent_str(y) for y in s if y[0] == "initiatives")
    if len(counts) > 1:
        out.append(f"several initiative counts: {', '.join(counts)}")
    if HUMAN_FREE in s and HUMAN_HOLDING in s:
        out.append("humanFree and humanHolding together")
    held = [y[1] for y in s if y[0] == "humanHoldingPart"]
    if held and HUMAN_HOLDING not in s:
        out.append("humanHoldingPart without humanHolding")
    if len(held) > 1:
        out.append(f"the human holds several parts: {', '.join(sorted(held))}")
    return out


def _duplicates(s: SimState, name: str, key: tuple[int, ...], what: str) -> list[str]:
    seen: dict[tuple[str, ...], int] = {}
    for y in s:
        if y[0] == name:
            k = tuple(y[i] for i in key)
            seen[k] = seen.get(k, 0) + 1
    return [f"{','.join(k)} {what}" for k, n in sorted(seen.items()) if n > 1]


def _sorted_fluents(fluents: Iterable[SimFluent]) -> list[str]:
    return sorted(fluent_str(y) for y in fluents)
