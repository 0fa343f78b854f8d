"""What the panels say about a node and about a whole plan (Markdown / HTML)."""

from __future__ import annotations

import html

from planner.plan.model import STAT_KEYS, TIMING_KEYS, Plan, PlanNode
from planner.vocabulary import (
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseLengthOf,
    SenseShapeOf,
)

KIND_WORDS = {
    "actuation": "robot action",
    "sensing": "sensing",
    "communication": "communication",
    "goal": "goal reached",
    "open": "still being planned",
}


def sensing_why(node: PlanNode) -> str | None:
    """Why the robot looks here: what it cannot know from the plan alone, and what
    its answer decides (a sensing node's plan entry carries no reason)."""
    action = node.action
    if isinstance(action, SenseHumanHolding):
        return ("the human may have taken a part since the robot last looked; whether "
                "their hands are free decides what the robot may do next.")  # fmt: skip
    if isinstance(action, SenseHumanHoldingWhichPart):
        return ("the human holds a part, and which one it is decides what the robot "
                "holds and attaches next.")  # fmt: skip
    if isinstance(action, SenseHumanUnholding):
        return (f"the human held {action.part}: the robot must know they let it go "
                "before it works on it.")  # fmt: skip
    if isinstance(action, SenseHumanAttachingWhere):
        return (f"the human attaches {action.part} to {action.onto}; the slot they use "
                "decides where the robot attaches the rest.")  # fmt: skip
    if isinstance(action, SenseShapeOf | SenseLengthOf):
        what = "shape" if isinstance(action, SenseShapeOf) else "length"
        return (f"the scenario leaves {action.part}'s {what} open; each possible {what} "
                "has its own way on.")  # fmt: skip
    return None


def details_markdown(node_id: str, node: PlanNode) -> str:
    """The node in a few lines: its action, why, what may come of it, the state."""
    kind = node.kind
    lines = [f"**{node.action or 'goal'}**  ", f"`{node_id}` · {KIND_WORDS.get(kind, kind)}"]
    if node.say:
        lines += ["", f"Robot says: *“{node.say}”*"]
    why = node.why if node.why else sensing_why(node) if kind == "sensing" else None
    if why:
        lines += ["", f"Why: {why}"]
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
    shown = ", ".join(f"`{f}`" for f in state) if state else "(nothing held or attached)"
    lines += ["", f"State before: {shown}"]
    return "\n".join(lines)


# One line per statistic: the paper's definitions (over the unfolded tree), then
# the conversation, which the paper's columns leave out.
STAT_WORDS = {
    "L": "leaves: the branches' ends",
    "D": "the longest branch, in actions (D = A + S + C; talk not counted)",
    "A": "robot actions on the longest branch",
    "S": "sensing actions on the longest branch",
    "C": "communication on the longest branch (talk not counted)",
    "K": "askHelp nodes: the robot asks for help",
    "O": "offerHelp nodes: the robot offers help",
    "CF": "confirmAttach nodes: the robot asks if an attachment is done",
    "R": "request nodes: the robot asks the human to hold, let go or attach",
    "DN": "decision nodes: nodes with several outcomes",
    "BF": "the largest branching factor",
    "N": "nodes of the unfolded tree (talk not counted)",
    "GE": "greetings and goodbyes (talk)",
    "W": "warnings before working near the human (talk)",
    "X": "explanations of a request (talk)",
    "dag_nodes": "distinct nodes drawn (identical states planned once)",
    "plan_s": "seconds planning",
    "checks_s": "seconds of motion-planning checks",
}


def stats_html(plan: Plan) -> str:
    """The paper's columns for this plan, as a small table with what each means."""
    stats = plan.stats or {}
    cells = "".join(
        f"<tr><td><b>{html.escape(k)}</b></td>"
        f"<td style='text-align:right;padding:0 6px'>{stats.get(k, '')}</td>"
        f"<td style='color:#555'>{html.escape(STAT_WORDS.get(k, ''))}</td></tr>"
        for k in (*STAT_KEYS, *TIMING_KEYS)
    )
    return (
        "<table style='font-size:0.75em;border-collapse:collapse;line-height:1.25'>"
        "<tr><th>stat</th><th>value</th><th style='text-align:left'>meaning</th></tr>"
        + cells + "</table>"
    )
