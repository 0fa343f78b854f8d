"""When the conversation is due, for the plan audit (docs/domain.md, "Conversation").

Re-implemented from the document like the rest of `planner.audit.domain`, never
from planner/asp/conversation.lp: for every node of the paper's repertoire (and
every goal) the talk it needs just before it, and a check that each branch
says exactly that there, in that order, and nothing else.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from planner.audit.actions import CONVERSATION
from planner.audit.domain import Domain
from planner.audit.fluents import SimState, parse_sim_state

# The order of what is said before one node.
_TURN = {
    "greet": 0,
    "warnDanger": 1,
    "warnWorking": 2,
    "explainAsk": 3,
    "explainOwnTask": 3,
    "farewell": 4,
}


def due(dom: Domain, s: SimState, action: str | None, *, first: bool) -> list[str]:
    """What the robot says just before `action` in `s` (None: a goal), in order;
    `first`: the node starts the plan."""
    f = dom.f
    if f.verbosity not in ("normal", "chatty"):
        return []
    out: list[tuple[int, str]] = []
    if first and not f.resumed:
        out.append((0, "greet"))
    if action is None:
        out.append((4, "farewell"))
        return [text for _, text in sorted(out)]
    parsed = dom.action(action)
    if isinstance(parsed, str) or parsed.name in CONVERSATION:
        return [text for _, text in sorted(out)]
    name, args = parsed.name, parsed.args
    # An arm moves into a region the human reaches while they hold a part.
    region = None
    if name == "hold":
        region = f.loc.get(args[1])
    elif name == "attach":
        root = dom.root(s, args[1])
        region = f.loc.get(root) if dom.loose(s, root) else None
    if region in f.human_reach and ("humanHolding",) in s:
        out.append((2, f"warnWorking({region})"))
    # The human is sent where a dangerous part lies loose.
    if name in ("askHelp", "requestToAttach"):
        where = f.loc.get(args[0])
        out += [
            (1, f"warnDanger({x})")
            for x in f.dangerous
            if f.loc.get(x) == where and dom.loose(s, x)
        ]
    if f.verbosity == "chatty":
        if name == "askHelp":
            out.append((3, f"explainAsk({args[0]})"))
        if name == "hold" and args[1] in f.dangerous and dom.in_reach(args[1]):
            out.append((3, f"explainOwnTask({args[1]})"))
    return [text for _, text in sorted(out)]


def conversation_problems(
    dom: Domain,
    nodes: dict[str, Any],
    root: str,
    state_of: Callable[[str], tuple[SimState, list[str]]] | None = None,
) -> Iterator[tuple[str, str]]:
    """(node, message) for each place where a branch says too little, too much, or
    out of order: every run of talk must be what its next node needs. `state_of`
    gives a node's parsed state (the audit's walk has them already)."""
    parsed = state_of or (lambda node_id: parse_sim_state(nodes[node_id].get("state")))
    # Every run of talk starts at the root or after a node of the task.
    starts: list[tuple[str, bool]] = [(root, True)]
    for node_id in nodes:
        if _talk(nodes, node_id) is None:
            starts += [(kid, False) for kid in _children(nodes, node_id)]
    for start, first in dict.fromkeys(starts):
        said, node_id = _run_of_talk(nodes, start)
        if _talk(nodes, node_id) is not None:
            continue
        state, errors = parsed(node_id)
        if errors:
            continue
        needed = due(dom, state, _action(nodes, node_id), first=first)
        if said != needed:
            what = _action(nodes, node_id) or "the goal"
            yield (
                node_id,
                f"conversation before {what}: said [{', '.join(said)}], due [{', '.join(needed)}]",
            )


def _run_of_talk(nodes: dict[str, Any], start: str) -> tuple[list[str], str]:
    """What is said from `start` on, and the node after it (a talk node if the run
    is malformed: a talk node without exactly one child, or a loop)."""
    said: list[str] = []
    node_id = start
    while (text := _talk(nodes, node_id)) is not None and len(said) <= len(nodes):
        said.append(text)
        kids = _children(nodes, node_id)
        if len(kids) != 1:
            break  # malformed: reported by the walk
        node_id = kids[0]
    return said, node_id


def _action(nodes: dict[str, Any], node_id: str) -> str | None:
    text = nodes[node_id].get("action")
    return text if isinstance(text, str) else None


def _talk(nodes: dict[str, Any], node_id: str) -> str | None:
    """The node's action if it is part of the conversation."""
    text = _action(nodes, node_id)
    if text is None:
        return None
    return text if text.split("(", 1)[0] in CONVERSATION else None


def _children(nodes: dict[str, Any], node_id: str) -> list[str]:
    kids = nodes[node_id].get("children")
    return [k["node"] for k in kids if k.get("node") in nodes] if isinstance(kids, list) else []
