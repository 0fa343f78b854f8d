"""The conversation around a task plan: greeting, goodbye, warnings, explanations.

These communication actions are deterministic and change nothing in the world,
so they never change which task plan is best: they are planned once the task
plan is built, by one clingo solve of `planner/asp/conversation.lp` over all of
the plan's nodes, and put in as communication nodes just before the node that
needs them (in the same state: talk moves no part) as the plan is built
(`plan.build_plan`). The search, and the paper's columns of the statistics,
stay what they were.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import clingo

from planner.resources import encoding_dir
from planner.vocabulary import (
    Action,
    AskHelp,
    Attach,
    Communication,
    Hold,
    RequestToAttach,
    parse_action,
)

PROGRAM = "conversation.lp"
# The fluents read of a node, by its action: whether the human holds a part, and
# what is held; the nodes whose action is marked also get the part of their
# assembly the rules read (`_assembly_read`).
_HANDS = ("humanHolding", "holding(")
_READ: dict[str, tuple[tuple[str, ...], bool]] = {
    Hold.name: (("humanHolding",), False),
    Attach.name: (_HANDS, True),
    AskHelp.name: (_HANDS, True),
    RequestToAttach.name: (_HANDS, True),
}
_ATTACHED = "attached("


Said = dict[str, list[Communication]]  # by node id: what is said before it, in order
# What the conversation reads of a node: its id, kind, action and state.
NodeView = tuple[str, str | None, Action | None, Iterable[str]]


def talk_about(facts: Sequence[str], root: str, nodes: Iterable[NodeView]) -> Said:
    """What is said before each node, in order, by the plan's `facts` (nothing if the
    robot is terse). It needs the nodes alone, not the plan: planning asks for it
    before the plan is built, and builds the plan with it (`plan.build_plan`)."""
    if "verbosity(terse)" in facts:
        return {}  # a terse robot says none of it
    return _solve(facts, root, nodes)


def _solve(plan_facts: Sequence[str], root: str, nodes: Iterable[NodeView]) -> Said:
    """What is said before each node, in order."""
    facts, situations = _node_facts(plan_facts, root, nodes)
    ctl = clingo.Control(["--warn=none"])
    with (encoding_dir() / PROGRAM).open() as f:
        ctl.add("base", [], f.read())
    ctl.add("base", [], "\n".join(f"{fact}." for fact in facts))
    ctl.ground([("base", [])])
    found: list[tuple[str, int, str]] = []

    def on_model(model: clingo.Model) -> None:
        # sayAt(N,A,K) read from its text: one call into clingo per symbol, not
        # one per argument (U14: 6,500 symbols, 0.5 s by argument).
        found[:] = []
        for symbol in model.symbols(shown=True):
            node, _, rest = str(symbol)[len("sayAt(") : -1].partition(",")
            action, _, turn = rest.rpartition(",")
            found.append((node, int(turn), action))

    ctl.solve(on_model=on_model)
    # A situation's talk is said before each of its nodes.
    by_node: dict[str, list[tuple[int, str]]] = {}
    for key, turn, text in found:
        for node_id in situations.get(key, (key,)):
            by_node.setdefault(node_id, []).append((turn, text))
    out: dict[str, list[Communication]] = {}
    for node_id, said in sorted(by_node.items()):
        for _, text in sorted(said):
            action = parse_action(text)
            assert isinstance(action, Communication)
            out.setdefault(node_id, []).append(action)
    return out


def _node_facts(
    plan_facts: Sequence[str], root: str, nodes: Iterable[NodeView]
) -> tuple[list[str], dict[str, list[str]]]:
    """The facts conversation.lp reads, and the nodes of each situation.

    Root and goal nodes are named by their ids. What a node does, what is in the
    hands and what is assembled before it is said once per situation (`s<K>`):
    nodes that share all three get the same talk, and U18's 41,000 nodes are far
    fewer situations (parsing every node's facts took clingo 1.7 s)."""
    facts = [*plan_facts, f"root({root})"]
    dangerous = {t[len("dangerous(") : -1] for t in plan_facts if t.startswith("dangerous(")}
    assemblies: dict[frozenset[str], int] = {}
    situations: dict[tuple[str, tuple[str, ...], int | None], str] = {}
    nodes_of: dict[str, list[str]] = {}
    for node_id, kind, action, state in nodes:
        if kind == "goal":
            facts.append(f"goalNode({node_id})")
        # Only the nodes and fluents the rules read, and each assembly once: parsing
        # the attached fluents of every node cost more than the rest.
        read = _READ.get(action.name) if action is not None else None
        if read is None or action is None:
            continue
        hands, with_assembly = read
        number = None
        if with_assembly:
            attached = _assembly_read(action, state, dangerous)
            number = assemblies.setdefault(attached, len(assemblies))
        held = tuple(sorted(f for f in state if f.startswith(hands)))
        key = (str(action), held, number)
        situation = situations.get(key)
        if situation is None:
            situation = situations[key] = f"s{len(situations)}"
            facts.append(f"does({situation},{action})")
            facts.extend(f"in({situation},{fluent})" for fluent in held)
            if number is not None:
                facts.append(f"assembly({situation},{number})")
        nodes_of.setdefault(situation, []).append(node_id)
    return facts + _assembly_facts(assemblies), nodes_of


def _assembly_read(action: Action, state: Iterable[str], dangerous: set[str]) -> frozenset[str]:
    """The attachments of a node's assembly that conversation.lp reads: where an arm
    attaches, those from the part it attaches onto up to the assembly's root
    (`chainOf`, `rootAt`); where the human is sent, those of the dangerous parts
    (`looseAt`). The rest of the assembly says nothing more, and left out it
    lets nodes share their situation (U30: 644,000 `assembled` atoms derived
    from 38,567 whole assemblies otherwise, 0.3 GB and seconds of grounding)."""
    onto: dict[str, list[str]] = {}
    for fluent in state:
        if fluent.startswith(_ATTACHED):
            onto.setdefault(fluent[len(_ATTACHED) :].partition(",")[0], []).append(fluent)
    if not isinstance(action, Attach):
        return frozenset(f for part in dangerous for f in onto.get(part, ()))
    read: set[str] = set()
    todo = [action.onto]
    while todo:
        for fluent in onto.get(todo.pop(), ()):
            if fluent not in read:
                read.add(fluent)
                todo.append(fluent[len(_ATTACHED) : -1].split(",")[1])
    return frozenset(read)


def _assembly_facts(assemblies: dict[frozenset[str], int]) -> list[str]:
    """What is attached in each assembly: an assembly one attachment past another
    one is `extends(S,S0,F)`, any other lists its fluents, `assembled(S,F)`. Plans
    grow assemblies an attachment at a time, so most are extensions, and clingo
    parses a tenth of the facts (U18: 86,000 `assembled` facts otherwise)."""
    facts: list[str] = []
    known: dict[frozenset[str], int] = {}
    for attached, number in sorted(assemblies.items(), key=lambda a: (len(a[0]), a[1])):
        smaller = ((attached - {fluent}, fluent) for fluent in sorted(attached))
        parent = next(((known[less], fluent) for less, fluent in smaller if less in known), None)
        if parent is None:
            facts.extend(f"assembled({number},{fluent})" for fluent in sorted(attached))
        else:
            facts.append(f"extends({number},{parent[0]},{parent[1]})")
        known[attached] = number
    return facts
