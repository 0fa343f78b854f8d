"""Executing real plans: outcome sources, the executor's walk and its controls."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

from app.execution.events import ExecutionEvent, Outcome, describe, is_step
from app.execution.walker import Executor
from app.sessions.store import SessionStore
from app.sources.outcomes import (
    ClickSource,
    ExpectedSource,
    FallbackSource,
    RandomSource,
    ScriptedSource,
    ScriptError,
)
from planner.plan.model import Plan
from tests.plan_fixtures import PAPER_NAMES, default_plan, paper_plan
from tests.plan_paths import is_plan_path

SEEDS = range(100)


@pytest.fixture(scope="module")
def paper_plans() -> dict[str, Plan]:
    return {name: paper_plan(name) for name in PAPER_NAMES}


@pytest.fixture(scope="module")
def plan() -> Plan:
    return default_plan()


def walk(doc: Plan, source: Any, **kw: Any) -> Executor:
    executor = Executor(doc, source, **kw)
    executor.run()
    return executor


def path_of(executor: Executor) -> list[tuple[str, str | None]]:
    return [(e.node, e.outcome) for e in executor.events if is_step(e)]


class Counter:
    """A listener that lets a test wait for the n-th event without sleeping blindly."""

    def __init__(self) -> None:
        self.cond = threading.Condition()
        self.events: list[ExecutionEvent] = []

    def __call__(self, event: ExecutionEvent) -> None:
        with self.cond:
            self.events.append(event)
            self.cond.notify_all()

    def wait_for(self, n: int) -> None:
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.events) >= n, 60)


# -- 1,500 random executions --------------------------------------------------


@pytest.mark.parametrize("name", PAPER_NAMES)
def test_random_outcomes_always_reach_a_goal_leaf(
    name: str, paper_plans: dict[str, Plan], tmp_path: Path
) -> None:
    doc = paper_plans[name]
    leaves: set[str] = set()
    with SessionStore(tmp_path) as store:
        for seed in SEEDS:
            session = store.start(doc, note=f"seed {seed}")
            executor = Executor(doc, RandomSource(seed), [store.recorder(session)])
            result = executor.run()
            store.finish(session, result)
            assert result == "goal", (name, seed)
            stored = store.path(session)
            assert stored == path_of(executor)
            assert is_plan_path(doc, stored), (name, seed)
            leaves.add(stored[-1][0])
        sessions = store.list_sessions(scenario=name)
    assert len(sessions) == len(SEEDS)
    assert {s.result for s in sessions} == {"goal"}
    if doc.statistics["L"] > 1:
        assert len(leaves) > 1, "random outcomes should reach more than one leaf"


def test_the_same_seed_takes_the_same_branch(plan: Plan) -> None:
    paths = {seed: path_of(walk(plan, RandomSource(seed))) for seed in range(20)}
    assert all(path_of(walk(plan, RandomSource(s))) == p for s, p in paths.items())
    assert len({tuple(p) for p in paths.values()}) > 1


def test_expected_outcomes_follow_the_first_branch(plan: Plan) -> None:
    executor = walk(plan, ExpectedSource())
    assert executor.result == "goal"
    steps = [
        (str(e.action), e.outcome) for e in executor.events if e.kind != "goal" and is_step(e)
    ]
    assert steps == plan.first_branch()
    assert {e.source for e in executor.events if e.outcome is not None} == {"expected"}


def test_events_carry_motions_and_sentences(plan: Plan) -> None:
    executor = walk(plan, RandomSource(4))
    assert [e.seq for e in executor.events] == list(range(len(executor.events)))
    for event in executor.events:
        node = plan.nodes[event.node]
        if event.kind == "human":  # the simulated human's action a request started
            assert event.source == "simulated" and node.kind == "communication"
            continue
        assert event.kind == node.kind and event.action == node.action
        if event.kind == "actuation":
            assert event.motion is not None and event.motion == node.motion
            assert event.motion.arm in ("left", "right") and event.motion.path
        if event.kind == "communication":
            assert event.text == node.say
        if event.outcome is not None:
            assert event.source == "random" and event.confidence is not None
    assert executor.events[-1].kind == "goal"


# -- describing outcomes ------------------------------------------------------


def test_every_outcome_of_the_default_plan_has_words(plan: Plan) -> None:
    seen: dict[str, str] = {}
    for node in plan.nodes.values():
        for child in node.children:
            if child.outcome is not None:
                words = describe(node.action, child.outcome)
                assert words.startswith("Human"), (node.action, child.outcome, words)
                seen[f"{node.action}={child.outcome}"] = words
    assert seen["sense(humanHoldingWhichPart)=leg2"] == "Human holds leg2"
    assert seen["askHelp(leg2,top)=yes"] == "Human says yes"
    assert seen["askHelp(leg2,top)=no"] == "Human says no"
    assert seen["sense(humanUnholding(leg2))=yes"] == "Human puts leg2 down"
    assert seen["sense(humanUnholding(leg2))=no"] == "Human keeps holding leg2"
    assert seen["sense(humanAttachingWhere(leg2,top))=c2"] == "Human attaches leg2 to top at c2"
    assert seen["sense(humanHolding)=no"] == "Human's hands are free"


# -- scripted and fallback ----------------------------------------------------


def test_a_script_answers_in_order_and_skips_comments(plan: Plan, tmp_path: Path) -> None:
    expected = [o for _, o in plan.first_branch() if o is not None]
    script = tmp_path / "answers.txt"
    script.write_text("# the hoped-for branch\n\n" + "\n".join(f"{o}  # ok" for o in expected))
    source = ScriptedSource(script)
    executor = walk(plan, source)
    assert executor.result == "goal"
    assert [e.outcome for e in executor.events if e.outcome is not None] == expected
    assert source.remaining == 0


def test_a_wrong_label_names_its_line(plan: Plan, tmp_path: Path) -> None:
    script = tmp_path / "answers.txt"
    script.write_text("# first question\nmaybe\n")
    with pytest.raises(ScriptError, match=r"answers\.txt:2: 'maybe' is not an outcome"):
        walk(plan, ScriptedSource(script))
    with pytest.raises(ScriptError, match=r"answers\.txt:2: 'maybe'"):
        ScriptedSource(script).check_labels({"yes", "no"})


def test_fallback_takes_over_from_a_failing_or_silent_source(
    plan: Plan, tmp_path: Path
) -> None:
    script = tmp_path / "answers.txt"
    script.write_text("maybe\n")  # wrong at the first question, then nothing
    reasons: list[str] = []
    source = FallbackSource(
        ScriptedSource(script), ExpectedSource(), lambda node, why: reasons.append(why)
    )
    executor = walk(plan, source)
    assert executor.result == "goal"
    asked = [e for e in executor.events if e.outcome is not None]
    assert {e.source for e in asked} == {"expected"}
    assert "maybe" in reasons[0] and reasons[1:] == ["no answer"] * (len(asked) - 1)


def test_an_unreadable_script_is_a_script_error(tmp_path: Path) -> None:
    with pytest.raises(ScriptError, match="cannot read responses"):
        ScriptedSource(tmp_path / "missing.txt")


# -- clicks and controls ------------------------------------------------------


def test_clicks_from_another_thread_drive_the_execution(plan: Plan) -> None:
    clicks = ClickSource(timeout=None)
    executor = Executor(plan, clicks)
    executor.start()
    answered = 0
    while not executor.done:
        offer = clicks.pending()
        if offer is None:
            time.sleep(0.001)
            continue
        assert not clicks.click("not-an-option")
        node = plan.nodes[offer.node_id]
        assert offer.options == tuple(c.outcome for c in node.children)
        assert offer.words == tuple(describe(node.action, o) for o in offer.options)
        choice = node.expected or offer.options[0]
        if clicks.click(choice, offer.node_id):
            answered += 1
            while clicks.pending() == offer and not executor.done:
                time.sleep(0.001)
    assert executor.wait() == "goal"
    asked = [e for e in executor.events if e.outcome is not None]
    assert len(asked) == answered > 0
    assert {(e.source, e.confidence) for e in asked} == {("click", 1.0)}


def test_a_click_timeout_falls_back_to_the_next_source(plan: Plan) -> None:
    source = FallbackSource(ClickSource(timeout=0.0), ExpectedSource())
    executor = walk(plan, source)
    assert executor.result == "goal"
    assert {e.source for e in executor.events if e.outcome is not None} == {"expected"}


def test_abort_wakes_a_source_waiting_for_a_click(plan: Plan) -> None:
    clicks = ClickSource(timeout=None)
    executor = Executor(plan, clicks)
    executor.start()
    while clicks.pending() is None:
        time.sleep(0.001)
    executor.abort()
    assert executor.wait(60) == "aborted"
    assert executor.error is None


def test_single_steps_then_abort(plan: Plan) -> None:
    counter = Counter()
    executor = Executor(plan, ExpectedSource(), [counter])
    executor.pause()
    executor.start()
    for n in (1, 2, 3):
        executor.step()
        counter.wait_for(n)
    executor.abort()
    assert executor.wait(60) == "aborted"
    assert len(executor.events) == 3


def test_pause_step_resume_reaches_the_goal(plan: Plan) -> None:
    counter = Counter()
    executor = Executor(plan, RandomSource(7), [counter])
    executor.pause()
    executor.start()
    executor.step()
    counter.wait_for(1)
    assert executor.paused
    executor.resume()
    assert executor.wait(60) == "goal"
    assert path_of(executor) == path_of(walk(plan, RandomSource(7)))


def test_abort_during_a_step_delay(plan: Plan) -> None:
    counter = Counter()
    executor = Executor(plan, ExpectedSource(), [counter], step_delay=3600)
    executor.start()
    counter.wait_for(1)
    executor.abort()
    assert executor.wait(60) == "aborted"
    assert len(executor.events) == 1


def test_a_leaf_that_is_no_goal_is_a_dead_end() -> None:
    doc = Plan.from_json(
        {
            "format": "tandem-plan/1",
            "scenario": {"name": "test", "sha256": ""},
            "facts": [],
            "root": "n0",
            "nodes": {
                "n0": {
                    "kind": "sensing",
                    "action": "sense(humanHolding)",
                    "state": [],
                    "children": [
                        {"outcome": "yes", "node": "n1"},
                        {"outcome": "no", "node": "n2"},
                    ],
                },
                "n1": {"kind": "goal", "action": None, "state": [], "children": []},
                "n2": {
                    "kind": "actuation",
                    "action": "hold(left,leg1)",
                    "state": [],
                    "children": [],
                },
            },
        }
    )

    class Always:
        def choose(self, node_id: str, node: Any, options: Any) -> Outcome:
            return Outcome("no", "test")

    executor = walk(doc, Always())
    assert executor.result == "dead-end"
    assert not is_plan_path(doc, path_of(executor))
    assert is_plan_path(doc, path_of(executor), complete=False)
