"""The `tandem-plan/1` file: nodes, statistics, Graphviz DOT and text tables."""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from planner import phrases
from planner.hcp import DagNode
from planner.solver import State

FORMAT = "tandem-plan/1"
STAT_KEYS = ("L", "D", "A", "S", "C", "K", "O", "CF", "R", "DN", "BF", "N", "dag_nodes")
KIND_COLOURS = {
    "actuation": "#d9d9d9",
    "sensing": "#ffe680",
    "communication": "#9fd3ff",
    "goal": "#a8e6a1",
}
REQUESTS = ("requestToUnhold", "requestToAttach")


@dataclass
class Plan:
    """A plan as stored: the JSON document, with helpers to read it."""

    doc: dict[str, Any]

    @property
    def nodes(self) -> dict[str, dict[str, Any]]:
        return self.doc["nodes"]  # type: ignore[no-any-return]

    @property
    def root(self) -> str:
        return self.doc["root"]  # type: ignore[no-any-return]

    @property
    def stats(self) -> dict[str, Any]:
        return self.doc["stats"]  # type: ignore[no-any-return]

    def write(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.doc, indent=1) + "\n")

    @classmethod
    def read(cls, path: str | Path) -> Plan:
        return cls(json.loads(Path(path).read_text()))

    def first_branch(self) -> list[tuple[str, str | None]]:
        """The branch the planner expects (its hoped-for outcomes): (action, outcome)."""
        return [
            (self.nodes[node_id]["action"], outcome)
            for node_id, outcome in expected_path(self.doc)
            if self.nodes[node_id]["kind"] != "goal"
        ]

    def dot(self) -> str:
        lines = [
            "digraph plan {",
            '  node [shape=box, style="rounded,filled", fontname=Helvetica];',
        ]
        for node_id, node in self.nodes.items():
            label = node["action"] or "goal"
            colour = KIND_COLOURS[node["kind"]]
            lines.append(f'  {node_id} [label="{label}", fillcolor="{colour}"];')
            for child in node["children"]:
                edge = f' [label="{child["outcome"]}"]' if child["outcome"] is not None else ""
                lines.append(f"  {node_id} -> {child['node']}{edge};")
        lines.append("}")
        return "\n".join(lines) + "\n"


def build_plan(
    nodes: dict[State, DagNode],
    root: State,
    *,
    scenario_name: str,
    scenario_sha256: str,
    facts: list[str],
    plan_s: float,
    checks_s: float,
) -> Plan:
    ids = number_states(nodes, root)
    fact_set = frozenset(facts)
    verbosity = next((f[len("verbosity(") : -1] for f in facts if f.startswith("verbosity(")), "")
    out: dict[str, dict[str, Any]] = {}
    for state, node_id in ids.items():
        node = nodes[state]
        entry: dict[str, Any] = {
            "kind": "goal" if node.goal else node.kind,
            "action": None if node.goal else node.action,
            "state": sorted(state),
            "children": [{"outcome": label, "node": ids[succ]} for label, succ in node.children],
        }
        if node.expected is not None:
            entry["expected"] = node.expected
        if node.kind == "communication" and node.action is not None:
            entry["why"] = phrases.why(node.action, state, fact_set)
            entry["say"] = phrases.say(node.action, verbosity, entry["why"])
        out[node_id] = entry
    doc: dict[str, Any] = {
        "format": FORMAT,
        "scenario": {"name": scenario_name, "sha256": scenario_sha256},
        "facts": sorted(facts),
        "root": ids[root],
        "nodes": out,
    }
    doc["stats"] = {**tree_stats(doc), "plan_s": round(plan_s, 3), "checks_s": round(checks_s, 3)}
    return Plan(doc)


def expected_path(doc: dict[str, Any]) -> list[tuple[str, str | None]]:
    """(node id, outcome taken) from the root along the expected outcomes to a leaf;
    the leaf's outcome is None. Stops at a node seen before (a partial plan)."""
    nodes = doc["nodes"]
    out: list[tuple[str, str | None]] = []
    seen: set[str] = set()
    node_id: str = doc["root"]
    while node_id not in seen:
        seen.add(node_id)
        kids = nodes[node_id]["children"]
        if not kids:
            out.append((node_id, None))
            break
        expected = nodes[node_id].get("expected")
        child = next((c for c in kids if c["outcome"] == expected), kids[0])
        out.append((node_id, child["outcome"]))
        node_id = child["node"]
    return out


def number_states(nodes: Mapping[State, DagNode], root: State) -> dict[State, str]:
    """Node ids in breadth-first order, so that files are stable and readable. States
    not in `nodes` (still open, while planning goes on) get ids but no children."""
    ids: dict[State, str] = {}
    queue = deque([root])
    while queue:
        state = queue.popleft()
        if state in ids:
            continue
        ids[state] = f"n{len(ids)}"
        if state in nodes:
            queue.extend(succ for _, succ in nodes[state].children)
    return ids


def tree_stats(doc: dict[str, Any]) -> dict[str, int]:
    """Statistics of the unfolded tree (shared nodes count once per path), by DP."""
    nodes: dict[str, dict[str, Any]] = doc["nodes"]
    memo: dict[str, dict[str, int]] = {}
    order = _postorder(nodes, doc["root"])
    for node_id in order:
        node = nodes[node_id]
        kids = [memo[c["node"]] for c in node["children"]]
        action = node["action"] or ""
        name = action.split("(")[0]
        nondet = any(c["outcome"] is not None for c in node["children"])
        s = {
            "N": 1 + sum(k["N"] for k in kids),
            "L": 1 if not kids else sum(k["L"] for k in kids),
            "K": (name == "askHelp") + sum(k["K"] for k in kids),
            "O": (name == "offerHelp") + sum(k["O"] for k in kids),
            "CF": (name == "confirmAttach") + sum(k["CF"] for k in kids),
            "R": (name in REQUESTS) + sum(k["R"] for k in kids),
            "DN": int(nondet) + sum(k["DN"] for k in kids),
            "BF": max([len(kids), *(k["BF"] for k in kids)]),
        }
        # The longest branch: first longest child in children order.
        best = max(kids, key=lambda k: k["D"], default=None) if kids else None
        if best is None:
            s.update(D=0, A=0, S=0, C=0)
        else:
            first = next(k for k in kids if k["D"] == best["D"])
            kind = node["kind"]
            s.update(
                D=first["D"] + 1,
                A=first["A"] + (kind == "actuation"),
                S=first["S"] + (kind == "sensing"),
                C=first["C"] + (kind == "communication"),
            )
        memo[node_id] = s
    stats = dict(memo[doc["root"]])
    stats["dag_nodes"] = len(nodes)
    return {k: stats[k] for k in STAT_KEYS}


def _postorder(nodes: dict[str, dict[str, Any]], root: str) -> list[str]:
    order: list[str] = []
    seen: set[str] = set()
    stack: list[tuple[str, bool]] = [(root, False)]
    while stack:
        node_id, expanded = stack.pop()
        if expanded:
            order.append(node_id)
            continue
        if node_id in seen:
            continue
        seen.add(node_id)
        stack.append((node_id, True))
        stack.extend((c["node"], False) for c in reversed(nodes[node_id]["children"]))
    return order


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
    "dag",
    "plan s",
    "checks s",
)


def stats_row(name: str, stats: dict[str, Any]) -> tuple[str, ...]:
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
