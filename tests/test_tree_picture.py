"""The plan tree as a picture and the log as sentences (pure: no page)."""

from __future__ import annotations

import re

from app.dashboard.log_lines import action_words, sentence
from app.dashboard.tree_layout import SpanningTree, layout
from app.dashboard.tree_svg import (
    CURRENT,
    PATH,
    QUESTION_FILL,
    Step,
    TreeMarks,
    draw,
    geometry,
    label,
    strip_svg,
)
from app.execution.events import ExecutionEvent
from planner.plan.model import Plan
from planner.vocabulary import Hold, SenseHumanHolding
from tests.plan_fixtures import SCENARIOS, default_plan, plan_of


def _boxes_overlap(plan: Plan, collapsed: set[str]) -> list[tuple[str, str]]:
    tree = SpanningTree.of(plan)
    geo = geometry(plan, layout(tree, collapsed))
    rows: dict[float, list[float]] = {}
    for x, y in geo.boxes.values():
        rows.setdefault(y, []).append(x)
    clashes = []
    for xs in rows.values():
        xs.sort()
        clashes += [(f"{a}", f"{b}") for a, b in zip(xs, xs[1:], strict=False)
                    if b - a < geo.column_px]  # fmt: skip
    return clashes


def test_no_two_boxes_share_space_open_or_folded() -> None:
    plan = default_plan()
    tree = SpanningTree.of(plan)
    assert _boxes_overlap(plan, set()) == []
    assert _boxes_overlap(plan, tree.default_collapsed(plan)) == []


def test_the_large_plan_opens_on_its_expected_branch_without_overlaps() -> None:
    plan = plan_of(SCENARIOS / "paper" / "U10.toml")
    tree = SpanningTree.of(plan)
    folded = tree.default_collapsed(plan)
    shown = layout(tree, folded)
    assert len(plan.nodes) > 5000 and len(shown.positions) < 400
    assert all(node in shown.positions for node, _ in plan.expected_path())
    assert _boxes_overlap(plan, folded) == []


def test_the_picture_names_actions_outcomes_and_the_run() -> None:
    plan = default_plan()
    tree = SpanningTree.of(plan)
    shown = layout(tree, set())
    walked = [node for node, _ in plan.expected_path()][:4]
    marks = TreeMarks(selected=walked[0], current=walked[-1],
                      path=tuple(Step(n, "click") for n in walked[:-1]))  # fmt: skip
    svg = draw(plan, shown, marks, (0, 0, 500, 500))
    labels = re.findall(r'<text class="label"[^>]*>([^<]*)<', svg)
    assert len(labels) == len(shown.positions)
    assert all(text == label(plan.nodes[n]) for n, text in
               zip(shown.positions, labels, strict=True))  # fmt: skip
    branching = [e for e in shown.edges if e.outcome is not None and not e.shared]
    assert branching and svg.count('class="outcome"') == len(branching)
    assert f'stroke="{CURRENT}"' in svg and f'stroke="{PATH}"' in svg
    assert "· click" in svg  # who answered, on the answered nodes
    if any(n.kind == "communication" and len(n.children) > 1 for n in plan.nodes.values()):
        assert QUESTION_FILL in svg


def test_the_timeline_strip_frames_the_running_step() -> None:
    assert strip_svg([], []) == ""
    strip = strip_svg(["n0", "n1", "n2"], ["communication", "actuation", "sensing"])
    assert strip.count("<rect") == 3 and strip.count(CURRENT) == 1 and "step 3" in strip
    long = strip_svg([f"n{i}" for i in range(100)], ["actuation"] * 100)
    assert long.count("<rect") == 40 and "the last 40 shown" in long


def test_log_lines_are_sentences_with_who_answered() -> None:
    assert action_words(Hold("left", "leg1")) == "The robot holds leg1 with its left arm."
    held = ExecutionEvent(3, 0.0, "n3", SenseHumanHolding(), "sensing", outcome="holding",
                          source="camera", confidence=0.93)  # fmt: skip
    line = sentence(held)
    assert line.startswith("`n3` The robot looks whether the human holds a part.")
    assert "**holding** (by the camera, 93% sure)" in line
    said = ExecutionEvent(1, 0.0, "n1", None, "communication", text="Hello!")
    assert sentence(said) == "`n1` The robot says: “Hello!”"


def test_the_dialogues_turns_are_sentences_too() -> None:
    stop = ExecutionEvent(5, 0.0, "n4", None, "paused", source="voice", text="stop")
    assert sentence(stop) == "`n4` *The human said stop: the robot stopped.* (heard “stop”)"
    again = ExecutionEvent(6, 0.0, "n4", None, "asked-again")
    assert sentence(again) == "`n4` *No answer heard: the robot asks again.*"


def test_a_timed_session_on_lanes_with_who_answered_and_a_cursor() -> None:
    from app.dashboard.timeline_svg import bars, lanes_svg

    timed = [
        ExecutionEvent(0, 1.0, "n0", None, "communication", text="Hello", start=100.0, end=101.0),
        ExecutionEvent(1, 3.0, "n1", Hold("left", "leg1"), "actuation", start=101.0, end=103.0),
        ExecutionEvent(2, 4.0, "n2", None, "human", start=101.5, end=104.0),
        ExecutionEvent(3, 5.0, "n3", SenseHumanHolding(), "sensing", outcome="yes",
                       source="camera", start=104.0, end=105.0),  # fmt: skip
    ]
    placed, is_timed = bars(timed)
    assert is_timed and [(b.lane, b.start, b.end) for b in placed] == [
        ("talk", 0.0, 1.0), ("robot", 1.0, 3.0), ("human", 1.5, 4.0), ("sensing", 4.0, 5.0)
    ]
    svg = lanes_svg(timed, shown=3)
    # Four bars, the camera's answer with the camera's own mark (a letter once stood
    # for both click and camera).
    assert svg.count('class="bar"') == 4 and "answered by camera" in svg
    assert svg.count('data-source="camera"') == 1 and ">C</text>" not in svg
    assert "0 s … 5.0 s" in svg and f'stroke="{CURRENT}"' in svg
    untimed = [ExecutionEvent(i, 0.0, f"n{i}", None, "communication") for i in range(3)]
    assert "untimed" in lanes_svg(untimed) and bars(untimed)[1] is False
