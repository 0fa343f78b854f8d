"""Audit a `tandem-plan/1` file by re-simulating every branch from its facts.

Independent of clingo and of the ASP encodings on purpose: the semantics come
from docs/domain.md through `planner.audit.domain`, so a bug in an encoding
shows up here as a violation instead of being reproduced.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from planner.audit.domain import (
    COMMUNICATION,
    CONVERSATION,
    GOAL,
    HUMAN_FREE,
    HUMAN_HOLDING,
    KINDS,
    Action,
    Domain,
    Facts,
    Fluent,
    State,
    fluent_str,
    parse_action,
    parse_facts,
    parse_state,
)
from planner.audit.motions import motion_problems
from planner.audit.talk import conversation_problems
from planner.plan.model import FORMAT, PAPER_STAT_KEYS, STAT_KEYS  # names only; checks are our own

ROOT_PATH = "root"

Child = tuple[str | None, str]  # (outcome label, node id)


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

    def plan_level(message: str) -> None:
        out.append(Violation("", "", message))

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

    walker = _Walker(Domain(facts), nodes, out)
    walker.run(root)
    for node_id in nodes:
        if node_id not in walker.paths:
            out.append(Violation(node_id, "", "node is not reachable from the root"))
    if walker.sound:
        # Statistics and motions only mean something on a well-formed DAG.
        _compare_stats(plan.get("stats"), tree_stats(plan), plan_level)
        for node_id, message in motion_problems(nodes, root):
            out.append(Violation(node_id, walker.paths.get(node_id, ""), message))
        for node_id, message in conversation_problems(walker.dom, nodes, root, walker.state):
            out.append(Violation(node_id, walker.paths.get(node_id, ""), message))
    return out


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


def _children(raw: Any) -> tuple[list[Child], list[str]]:
    """A node's children as (label, id), and what was malformed."""
    kids = raw.get("children") if isinstance(raw, dict) else None
    if not isinstance(kids, list):
        return [], ["children must be a list"]
    out: list[Child] = []
    errors: list[str] = []
    for kid in kids:
        if (
            isinstance(kid, dict)
            and isinstance(kid.get("node"), str)
            and (kid.get("outcome") is None or isinstance(kid.get("outcome"), str))
        ):
            out.append((kid.get("outcome"), kid["node"]))
        else:
            errors.append(f"malformed child {kid!r}")
    return out, errors


class _Walker:
    """Depth-first walk of the DAG; each node is checked once, each edge once."""

    def __init__(self, domain: Domain, nodes: dict[str, Any], out: list[Violation]) -> None:
        self.dom = domain
        self.nodes = nodes
        self.out = out
        self.paths: dict[str, str] = {}  # first path reaching each node
        self.successors: dict[str, dict[str | None, State] | None] = {}
        self.actions: dict[str, str] = {}
        self._states: dict[str, tuple[State, list[str]]] = {}
        self.sound = True  # no cycle, no dangling or malformed edge

    def report(self, node: str, path: str, message: str) -> None:
        self.out.append(Violation(node, path, message))

    def state(self, node_id: str) -> tuple[State, list[str]]:
        # Parsed lazily: an edge may be checked before its child is visited.
        if node_id not in self._states:
            raw = self.nodes[node_id]
            items = raw.get("state") if isinstance(raw, dict) else None
            self._states[node_id] = parse_state(items)
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
        kids, kid_errors = _children(raw)
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
            if not state_errors:
                for reason in self.dom.goal_failures(state):
                    report(f"goal not reached: {reason}")
            if text is None or not kids:
                return kids
        elif not kids:
            report("leaf not at the goal")
            return kids
        if text is None:
            report("action is null but the node is not a goal node")
            return kids
        if not isinstance(text, str):
            report(f"action must be a string or null, got {text!r}")
            return kids
        action = parse_action(text, self.dom.f)
        if isinstance(action, str):
            report(action)
            return kids
        self.actions[node_id] = action.text
        if kind in KINDS and kind != action.kind:
            report(f"kind is {kind} but {action.text} is of kind {action.kind}")
        if not state_errors:
            self.successors[node_id] = self.check_action(action, state, kids, report)
        return kids

    def check_action(
        self, action: Action, state: State, kids: list[Child], report: Callable[[str], None]
    ) -> dict[str | None, State] | None:
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


# ---------------------------------------------------------------- statistics


def tree_stats(plan: dict[str, Any]) -> dict[str, int]:
    """Statistics of the unfolded tree (a node shared by k paths counts k times).

    Memoised over the DAG, so exponential unfoldings stay cheap (big ints).
    Raises ValueError if the graph has a cycle or a dangling/malformed edge.
    """
    nodes: dict[str, Any] = plan["nodes"]
    root: str = plan["root"]
    kids: dict[str, list[str]] = {}
    nondet: set[str] = set()
    order: list[str] = []  # postorder: children before parents
    done: dict[str, bool] = {}  # False while on the DFS stack, True when finished
    stack: list[tuple[str, Iterator[str]]] = []

    def enter(node_id: str) -> None:
        if node_id not in nodes:
            raise ValueError(f"child {node_id!r} is not a node")
        children, errors = _children(nodes[node_id])
        if errors:
            raise ValueError(f"node {node_id}: {errors[0]}")
        kids[node_id] = [target for _, target in children]
        if any(label is not None for label, _ in children):
            nondet.add(node_id)
        done[node_id] = False
        stack.append((node_id, iter(kids[node_id])))

    enter(root)
    while stack:
        node_id, it = stack[-1]
        target = next(it, None)
        if target is None:
            done[node_id] = True
            order.append(node_id)
            stack.pop()
        elif target not in done:
            enter(target)
        elif not done[target]:
            raise ValueError(f"cycle through {target}")

    # Paths from the root to each node = its copies in the unfolded tree.
    copies: dict[str, int] = dict.fromkeys(order, 0)
    copies[root] = 1
    for node_id in reversed(order):
        for target in kids[node_id]:
            copies[target] += copies[node_id]

    def name(node_id: str) -> str:
        action = nodes[node_id].get("action")
        return action.split("(", 1)[0].strip() if isinstance(action, str) else ""

    def count(pred: Callable[[str], bool]) -> int:
        return sum(copies[n] for n in order if pred(n))

    # The paper's columns count the paper's repertoire: the conversation apart.
    def talk(node_id: str) -> bool:
        return name(node_id) in CONVERSATION

    # Longest branch (action nodes = non-goal nodes); ties: first child in order.
    best: dict[str, tuple[int, int, int, int]] = {}
    for node_id in order:
        kind = nodes[node_id].get("kind")
        counted = not talk(node_id)
        own = (
            int(kind != GOAL and counted),
            int(kind == "actuation"),
            int(kind == "sensing"),
            int(kind == "communication" and counted),
        )
        tail = (0, 0, 0, 0)
        for target in kids[node_id]:
            if best[target][0] > tail[0]:
                tail = best[target]
        best[node_id] = (own[0] + tail[0], own[1] + tail[1], own[2] + tail[2], own[3] + tail[3])
    d, a, s, c = best[root]
    return {
        "L": count(lambda n: not kids[n]),
        "D": d,
        "A": a,
        "S": s,
        "C": c,
        "K": count(lambda n: name(n) == "askHelp"),
        "O": count(lambda n: name(n) == "offerHelp"),
        "CF": count(lambda n: name(n) == "confirmAttach"),
        "R": count(lambda n: name(n) in ("requestToUnhold", "requestToAttach")),
        "DN": count(lambda n: n in nondet),
        "BF": max(len(kids[n]) for n in order),
        "N": count(lambda n: not talk(n)),
        "GE": count(lambda n: name(n) in ("greet", "farewell")),
        "W": count(lambda n: name(n) in ("warnWorking", "warnDanger")),
        "X": count(lambda n: name(n) in ("explainAsk", "explainOwnTask")),
        "dag_nodes": len(nodes),
    }


def _compare_stats(given: Any, actual: dict[str, int], report: Callable[[str], None]) -> None:
    if not isinstance(given, dict):
        report("stats: missing (expected an object)")
        return
    for key in STAT_KEYS:
        if key not in given:
            # Files from before the conversation lack its counts, and need none.
            if key in PAPER_STAT_KEYS or actual[key]:
                report(f"stats: {key} is missing (the tree has {actual[key]})")
            continue
        value = given[key]
        if not isinstance(value, int) or isinstance(value, bool):
            report(f"stats: {key} is {value!r}, not an integer (the tree has {actual[key]})")
        elif value != actual[key]:
            report(f"stats: {key} is {value} but the tree has {actual[key]}")


# ---------------------------------------------------------------- root state


def _root_inconsistencies(f: Facts, s: State) -> list[str]:
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


def _duplicates(s: State, name: str, key: tuple[int, ...], what: str) -> list[str]:
    seen: dict[tuple[str, ...], int] = {}
    for y in s:
        if y[0] == name:
            k = tuple(y[i] for i in key)
            seen[k] = seen.get(k, 0) + 1
    return [f"{','.join(k)} {what}" for k, n in sorted(seen.items()) if n > 1]


def _sorted_fluents(fluents: Iterable[Fluent]) -> list[str]:
    return sorted(fluent_str(y) for y in fluents)
