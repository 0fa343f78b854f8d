"""What the panels say about a node and about a whole plan (Markdown / HTML)."""

from __future__ import annotations

import html

from planner.plan.model import STAT_KEYS, TIMING_KEYS, Plan, PlanNode

KIND_WORDS = {
    "actuation": "robot action",
    "sensing": "sensing",
    "communication": "communication",
    "goal": "goal reached",
    "open": "still being planned",
}


def details_markdown(node_id: str, node: PlanNode) -> str:
    kind = node.kind
    lines = [f"**{node.action or 'goal'}**  ", f"`{node_id}` · {KIND_WORDS.get(kind, kind)}"]
    if node.say:
        lines += ["", f"Robot says: *“{node.say}”*"]
    if node.why:
        lines += ["", f"Why: {node.why}"]
    motion = node.motion
    if motion:
        lines += ["", f"Motion: {motion.arm} arm, {len(motion.path)} waypoints"]
    kids = node.children
    if len(kids) > 1:
        expected = node.expected
        outcomes = ", ".join(
            f"**{k.outcome}**" if k.outcome == expected else str(k.outcome) for k in kids
        )
        lines += ["", f"Outcomes: {outcomes} (bold: expected)"]
    state = node.state
    lines += ["", "State before:", ""]
    lines += [f"- `{f}`" for f in state] if state else ["- (nothing held or attached)"]
    return "\n".join(lines)


def stats_html(plan: Plan) -> str:
    """The paper's columns for this plan, as a small table."""
    stats = plan.stats or {}
    cells = "".join(
        f"<tr><td>{html.escape(k)}</td><td style='text-align:right'>{stats.get(k, '')}</td></tr>"
        for k in (*STAT_KEYS, *TIMING_KEYS)
    )
    return (
        "<table style='font-size:0.8em;border-collapse:collapse'>"
        "<tr><th>statistic</th><th>value</th></tr>" + cells + "</table>"
    )
