"""The `tandem-plan/1` plan: typed nodes, load/save with validation, walks, DOT, tables.

A `Plan` is what every consumer takes (executor, store, dashboard, CLI); its
JSON form is the file format of the architecture notes, and files written
before these types existed load unchanged. A plan still being built (the
dashboard's growing tree) has no statistics: `plan.partial`.

The audit (`planner/audit/branches.py`) deliberately reads the raw JSON instead: it
judges files, including ones this loader would refuse, and names every
violation rather than the first.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, PlainSerializer, PlainValidator, ValidationError

from planner.plan import walks
from planner.vocabulary import (
    ACTION_TYPES,
    CONVERSATION,
    EXPLANATIONS,
    GREETINGS,
    REQUESTS,
    WARNINGS,
    Action,
    AskHelp,
    ConfirmAttach,
    OfferHelp,
    TermError,
    parse_action,
)

FORMAT = "tandem-plan/1"
# The paper's columns (Tables 1-3), then the number of distinct nodes: what every
# plan file has. They count the paper's repertoire, so plans compare with its tables.
PAPER_STAT_KEYS = ("L", "D", "A", "S", "C", "K", "O", "CF", "R", "DN", "BF", "N", "dag_nodes")
# The conversation beyond the paper's five actions, counted apart: greetings and
# goodbyes (GE), warnings (W), explanations (X). Older plan files lack them.
CONVERSATION_STAT_KEYS = ("GE", "W", "X")
STAT_KEYS = (*PAPER_STAT_KEYS[:-1], *CONVERSATION_STAT_KEYS, "dag_nodes")
TIMING_KEYS = ("plan_s", "checks_s")
# "open" only in a partial plan: a state that waits for its solve.
NodeKind = Literal["actuation", "sensing", "communication", "goal", "open"]
KIND_COLOURS: dict[str, str] = {
    "actuation": "#d9d9d9",
    "sensing": "#ffe680",
    "communication": "#9fd3ff",
    "goal": "#a8e6a1",
    "open": "#f4f4f4",
}


class PlanFormatError(ValueError):
    """A plan file that is not a valid `tandem-plan/1` document: one line, with where."""


def _to_action(value: object) -> Action:
    if isinstance(value, ACTION_TYPES):
        return value
    if not isinstance(value, str):
        raise ValueError("an action must be a string")
    try:
        return parse_action(value)
    except TermError as err:
        raise ValueError(str(err)) from err


ActionField = Annotated[Action, PlainValidator(_to_action), PlainSerializer(str, return_type=str)]


@dataclass(frozen=True, slots=True)
class Child:
    """An edge of the plan: the outcome that leads to `node` (None: deterministic).
    A plain dataclass, not a model: a large plan has hundreds of thousands of them
    (U30: 280,000, 540 bytes each as a model, 100 as this); pydantic validates it
    as it validated the model, unknown fields refused."""

    __pydantic_config__ = ConfigDict(extra="forbid")
    outcome: str | None  # None for a deterministic action
    node: str


class Motion(BaseModel):
    """The arm path an actuation node executes: waypoints of the arm's 7 joints."""

    model_config = ConfigDict(extra="forbid")
    arm: str
    joints: list[str]
    path: list[list[float]]


# The node fields about slots (planner.feasibility.slot_map), named once: the audit
# reads them from the raw JSON.
SLOTS = "slots"
ROBOT_SLOT = "robot_slot"

SlotNames = dict[str, dict[str, str]]  # part -> {plan name: real point}, names that differ


class RobotSlot(BaseModel):
    """The robot's own slot choice at an attach: its arm could not reach the real point
    `branch` stood for on `onto`, so it took the free point `real` (`why` says why)."""

    model_config = ConfigDict(extra="forbid")
    onto: str
    branch: str
    real: str
    why: str | None = None


class PlanNode(BaseModel):
    model_config = ConfigDict(extra="allow")  # the format allows fields of later versions
    kind: NodeKind
    action: ActionField | None  # None at a goal
    state: list[str]  # fluents true before the action, canonical text
    children: list[Child]
    expected: str | None = None  # the outcome the planner hoped for
    say: str | None = None  # communication: what the robot says
    why: str | None = None  # communication: the reason
    motion: Motion | None = None  # actuation: the arm path
    # The slot map the motion assumes where it is not the identity (the robot took
    # other free slots on the way from the root), and the choice made at this node.
    slots: SlotNames | None = None
    robot_slot: RobotSlot | None = None

    @property
    def outcomes(self) -> list[str]:
        return [c.outcome for c in self.children if c.outcome is not None]

    def child(self, outcome: str | None) -> str | None:
        """The node after `outcome`, or None if the node has no such outcome."""
        return next((c.node for c in self.children if c.outcome == outcome), None)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.kind,
            "action": None if self.action is None else str(self.action),
            "state": list(self.state),
            "children": [{"outcome": c.outcome, "node": c.node} for c in self.children],
        }
        for key in ("expected", "why", "say"):
            value = getattr(self, key)
            if value is not None:
                out[key] = value
        if self.motion is not None:
            out["motion"] = self.motion.model_dump()
        if self.slots is not None:
            out[SLOTS] = {part: dict(names) for part, names in self.slots.items()}
        if self.robot_slot is not None:
            out[ROBOT_SLOT] = self.robot_slot.model_dump(exclude_none=True)
        out.update(self.model_extra or {})
        return out


class ScenarioRef(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str
    sha256: str


class Plan(BaseModel):
    """A conditional plan: a DAG of nodes by id, rooted at `root`."""

    model_config = ConfigDict(extra="allow")
    format: Literal["tandem-plan/1"] = "tandem-plan/1"
    scenario: ScenarioRef
    facts: list[str]
    root: str
    nodes: dict[str, PlanNode]
    stats: dict[str, int | float] | None = None  # STAT_KEYS and TIMING_KEYS; None: partial

    @property
    def partial(self) -> bool:
        """True for a plan still being built: no statistics yet, leaves may be open."""
        return self.stats is None

    @property
    def statistics(self) -> dict[str, int | float]:
        """The statistics of a complete plan (`PlanFormatError` for a partial one)."""
        if self.stats is None:
            raise PlanFormatError("a partial plan has no statistics yet")
        return self.stats

    # -- load and save
    @classmethod
    def from_json(cls, doc: object, source: str = "plan") -> Plan:
        """The plan of a `tandem-plan/1` document; `PlanFormatError` names the first fault."""
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise PlanFormatError(f"{source}: not a {FORMAT} document")
        try:
            plan = cls.model_validate(doc)
        except ValidationError as err:
            first = err.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            raise PlanFormatError(f"{source}: {where}: {first['msg']}") from None
        plan._check_links(source)
        return plan

    def _check_links(self, source: str) -> None:
        if self.root not in self.nodes:
            raise PlanFormatError(f"{source}: root: no node {self.root!r}")
        for node_id, node in self.nodes.items():
            for child in node.children:
                if child.node not in self.nodes:
                    raise PlanFormatError(f"{source}: nodes.{node_id}: no child node {child.node}")
            if (node.action is None) != (node.kind in ("goal", "open")):
                raise PlanFormatError(f"{source}: nodes.{node_id}: only goals have no action")
        if self.stats is not None:
            missing = [k for k in PAPER_STAT_KEYS if k not in self.stats]
            if missing:
                raise PlanFormatError(f"{source}: stats: missing {', '.join(missing)}")

    @classmethod
    def read(cls, path: str | Path) -> Plan:
        try:
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            raise PlanFormatError(f"{path}: cannot read plan: {err}") from err
        return cls.from_json(doc, str(path))

    def to_json(self) -> dict[str, Any]:
        doc: dict[str, Any] = {
            "format": FORMAT,
            "scenario": self.scenario.model_dump(),
            "facts": list(self.facts),
            "root": self.root,
            "nodes": {node_id: node.to_json() for node_id, node in self.nodes.items()},
        }
        if self.stats is not None:
            doc["stats"] = dict(self.stats)
        doc.update(self.model_extra or {})
        return doc

    def write(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=1) + "\n")

    # -- walks
    def children_of(self, node_id: str) -> list[str]:
        return [c.node for c in self.nodes[node_id].children]

    def breadth_first(self) -> list[str]:
        return walks.breadth_first(self.root, self.children_of)

    def postorder(self) -> list[str]:
        return walks.postorder(self.root, self.children_of)

    def root_paths(self, order: list[str] | None = None) -> dict[str, int]:
        """How many paths lead from the root to each node: how often the unfolded
        tree holds it. `order`: the plan's postorder, if at hand."""
        order = self.postorder() if order is None else order
        paths = dict.fromkeys(order, 0)
        paths[self.root] = 1
        for node_id in reversed(order):
            for child in self.nodes[node_id].children:
                paths[child.node] += paths[node_id]
        return paths

    def expected_path(self) -> list[tuple[str, str | None]]:
        """(node id, outcome taken) from the root along the expected outcomes to a leaf;
        the leaf's outcome is None. Stops at a node seen before (a partial plan)."""
        out: list[tuple[str, str | None]] = []
        seen: set[str] = set()
        node_id = self.root
        while node_id not in seen:
            seen.add(node_id)
            kids = self.nodes[node_id].children
            if not kids:
                out.append((node_id, None))
                break
            expected = self.nodes[node_id].expected
            child = next((c for c in kids if c.outcome == expected), kids[0])
            out.append((node_id, child.outcome))
            node_id = child.node
        return out

    def first_branch(self) -> list[tuple[str, str | None]]:
        """The branch the planner expects (its hoped-for outcomes): (action, outcome)."""
        return [
            (str(self.nodes[node_id].action), outcome)
            for node_id, outcome in self.expected_path()
            if self.nodes[node_id].kind != "goal"
        ]

    def outcome_labels(self) -> set[str]:
        return {label for node in self.nodes.values() for label in node.outcomes}

    def dot(self) -> str:
        lines = [
            "digraph plan {",
            '  node [shape=box, style="rounded,filled", fontname=Helvetica];',
        ]
        for node_id, node in self.nodes.items():
            label = str(node.action) if node.action is not None else "goal"
            colour = KIND_COLOURS[node.kind]
            lines.append(f'  {node_id} [label="{label}", fillcolor="{colour}"];')
            for child in node.children:
                edge = f' [label="{child.outcome}"]' if child.outcome is not None else ""
                lines.append(f"  {node_id} -> {child.node}{edge};")
        lines.append("}")
        return "\n".join(lines) + "\n"


def tree_stats(plan: Plan) -> dict[str, int | float]:
    """Statistics of the unfolded tree (shared nodes count once per path).

    A count over the unfolded tree is each node's own count times the number of
    paths from the root to it, and those numbers come from one pass in reverse
    postorder; the longest branch (D and its A, S and C) is a pass in postorder.
    The paper's columns leave the conversation out (its nodes add nothing to N, D
    or C); GE, W and X count it."""
    order = plan.postorder()
    paths = plan.root_paths(order)
    counts = dict.fromkeys(("N", "GE", "W", "X", "L", "K", "O", "CF", "R", "DN"), 0)
    widest = 0
    # Per node: (D, A, S, C) of the longest branch below it, the first longest
    # child in children order.
    longest: dict[str, tuple[int, int, int, int]] = {}
    for node_id in order:
        node = plan.nodes[node_id]
        name = node.action.name if node.action is not None else ""
        talk = name in CONVERSATION
        n = paths[node_id]
        own = {
            "N": not talk,
            "GE": name in GREETINGS,
            "W": name in WARNINGS,
            "X": name in EXPLANATIONS,
            "L": not node.children,
            "K": name == AskHelp.name,
            "O": name == OfferHelp.name,
            "CF": name == ConfirmAttach.name,
            "R": name in REQUESTS,
            "DN": any(c.outcome is not None for c in node.children),
        }
        for key, counted in own.items():
            if counted:
                counts[key] += n
        widest = max(widest, len(node.children))
        below: tuple[int, int, int, int] | None = None
        for child in node.children:
            if below is None or longest[child.node][0] > below[0]:
                below = longest[child.node]
        d, a, s, c = below or (0, 0, 0, 0)
        if below is not None:
            d += not talk
            a += node.kind == "actuation"
            s += node.kind == "sensing"
            c += node.kind == "communication" and not talk
        longest[node_id] = (d, a, s, c)
    d, a, s, c = longest[plan.root]
    stats: dict[str, int | float] = {**counts, "BF": widest, "D": d, "A": a, "S": s, "C": c}
    stats["dag_nodes"] = len(plan.nodes)
    return {k: stats[k] for k in STAT_KEYS}


TABLE_HEADER = (
    "instance",
    "L",
    "D=A+S+C",
    "K",
    "O",
    "C",
    "R",
    "DN",
    "BF",
    "N",
    "GE",
    "W",
    "X",
    "dag",
    "plan s",
    "checks s",
)


def stats_row(name: str, stats: Mapping[str, Any]) -> tuple[str, ...]:
    return (
        name,
        str(stats["L"]),
        f"{stats['D']}={stats['A']}+{stats['S']}+{stats['C']}",
        str(stats["K"]),
        str(stats["O"]),
        str(stats["CF"]),
        str(stats["R"]),
        str(stats["DN"]),
        str(stats["BF"]),
        str(stats["N"]),
        # Plans from before the conversation have no counts for it: they said none.
        *(str(stats.get(k, 0)) for k in CONVERSATION_STAT_KEYS),
        str(stats["dag_nodes"]),
        f"{stats['plan_s']:.2f}",
        f"{stats['checks_s']:.2f}",
    )


def format_table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(r: tuple[str, ...]) -> str:
        return "  ".join(
            c.rjust(w) if i else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )

    sep = "-" * len(line(header))
    return "\n".join([line(header), sep, *(line(r) for r in rows)])
