"""The plan audit's statistics: the unfolded tree's counts, recomputed from the
nodes, and compared with the ones a plan states (`tandem-plan/1`'s `stats`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from planner.audit.actions import CONVERSATION, GOAL
from planner.plan.model import PAPER_STAT_KEYS, STAT_KEYS  # names only; counts are our own

Child = tuple[str | None, str]  # (outcome label, node id)


def node_children(raw: Any) -> tuple[list[Child], list[str]]:
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


@dataclass
class _Dag:
    """The nodes below the root: each one's children, the nondeterministic ones,
    and a postorder (children before parents)."""

    kids: dict[str, list[str]] = field(default_factory=dict)
    nondet: set[str] = field(default_factory=set)
    order: list[str] = field(default_factory=list)


def _walk(nodes: dict[str, Any], root: str) -> _Dag:
    """The DAG below `root`, by depth-first search; ValueError on a cycle or on a
    dangling or malformed edge."""
    dag = _Dag()
    done: dict[str, bool] = {}  # False while on the DFS stack, True when finished
    stack: list[tuple[str, Iterator[str]]] = []

    def enter(node_id: str) -> None:
        if node_id not in nodes:
            raise ValueError(f"child {node_id!r} is not a node")
        children, errors = node_children(nodes[node_id])
        if errors:
            raise ValueError(f"node {node_id}: {errors[0]}")
        dag.kids[node_id] = [target for _, target in children]
        if any(label is not None for label, _ in children):
            dag.nondet.add(node_id)
        done[node_id] = False
        stack.append((node_id, iter(dag.kids[node_id])))

    enter(root)
    while stack:
        node_id, it = stack[-1]
        target = next(it, None)
        if target is None:
            done[node_id] = True
            dag.order.append(node_id)
            stack.pop()
        elif target not in done:
            enter(target)
        elif not done[target]:
            raise ValueError(f"cycle through {target}")
    return dag


def _copies(dag: _Dag, root: str) -> dict[str, int]:
    """Paths from the root to each node = its copies in the unfolded tree."""
    copies: dict[str, int] = dict.fromkeys(dag.order, 0)
    copies[root] = 1
    for node_id in reversed(dag.order):
        for target in dag.kids[node_id]:
            copies[target] += copies[node_id]
    return copies


def _longest_branch(
    nodes: dict[str, Any], dag: _Dag, names: dict[str, str], root: str
) -> tuple[int, int, int, int]:
    """(action nodes, actuation, sensing, communication) along the branch with the
    most action nodes (non-goal nodes, the conversation apart); ties: first child."""
    best: dict[str, tuple[int, int, int, int]] = {}
    for node_id in dag.order:
        kind = nodes[node_id].get("kind")
        counted = names[node_id] not in CONVERSATION
        own = (
            int(kind != GOAL and counted),
            int(kind == "actuation"),
            int(kind == "sensing"),
            int(kind == "communication" and counted),
        )
        tail = (0, 0, 0, 0)
        for target in dag.kids[node_id]:
            if best[target][0] > tail[0]:
                tail = best[target]
        best[node_id] = (own[0] + tail[0], own[1] + tail[1], own[2] + tail[2], own[3] + tail[3])
    return best[root]


def _action_name(raw: dict[str, Any]) -> str:
    action = raw.get("action")
    return action.split("(", 1)[0].strip() if isinstance(action, str) else ""


def tree_stats(plan: dict[str, Any]) -> dict[str, int]:
    """Statistics of the unfolded tree (a node shared by k paths counts k times).

    Memoised over the DAG, so exponential unfoldings stay cheap (big ints).
    Raises ValueError if the graph has a cycle or a dangling/malformed edge.
    """
    nodes: dict[str, Any] = plan["nodes"]
    root: str = plan["root"]
    dag = _walk(nodes, root)
    copies = _copies(dag, root)
    names = {node_id: _action_name(nodes[node_id]) for node_id in dag.order}

    def count(pred: Callable[[str], bool]) -> int:
        return sum(copies[n] for n in dag.order if pred(n))

    def named(*wanted: str) -> int:
        return count(lambda n: names[n] in wanted)

    d, a, s, c = _longest_branch(nodes, dag, names, root)
    return {
        "L": count(lambda n: not dag.kids[n]),
        "D": d,
        "A": a,
        "S": s,
        "C": c,
        "K": named("askHelp"),
        "O": named("offerHelp"),
        "CF": named("confirmAttach"),
        "R": named("requestToUnhold", "requestToAttach"),
        "DN": count(lambda n: n in dag.nondet),
        "BF": max(len(dag.kids[n]) for n in dag.order),
        # The paper's columns count the paper's repertoire: the conversation apart.
        "N": count(lambda n: names[n] not in CONVERSATION),
        "GE": named("greet", "farewell"),
        "W": named("warnWorking", "warnDanger"),
        "X": named("explainAsk", "explainOwnTask"),
        "dag_nodes": len(nodes),
    }


def compare_stats(given: Any, actual: dict[str, int], report: Callable[[str], None]) -> None:
    """Reports each statistic `given` (a plan's `stats`) states otherwise than `actual`."""
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
