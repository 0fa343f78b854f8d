"""A dashboard session measures what happened: the arm's motions last as long as they
are played, the human's clicked answers are the human's actions, and the metrics of
the stored session count both (issue: every session measures what really happened).

The default plan runs in headless chromium, answered by clicks on the simulated
human's buttons at 0.5 seconds per step, on the wall clock.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from app.execution.events import HUMAN, ExecutionEvent, is_step  # noqa: E402
from app.execution.timing import human_activity, waits_for_human  # noqa: E402
from app.sessions.metrics import session_metrics  # noqa: E402
from planner.plan.model import Motion, Plan  # noqa: E402
from tests.test_dashboard import opened, run_by_clicks, served  # noqa: E402

SECONDS_PER_STEP = 0.5


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(tmp_path_factory.mktemp("data")) as d:
        yield d


def _timed_animations(dashboard: Dashboard) -> list[tuple[float, float]]:
    """When each of the panel's arm animations began and ended (the real animation,
    timed around its call)."""
    played: list[tuple[float, float]] = []
    panel = dashboard.execution
    animate = panel._play

    def timed(motion: Motion, seconds: float) -> None:
        begun = time.time()
        animate(motion, seconds)
        played.append((begun, time.time()))

    panel._play = timed  # type: ignore[method-assign]
    return played


def _timed_tree_moves(dashboard: Dashboard) -> list[tuple[str, float]]:
    """Each node the page's tree and bench went to, and when that drawing ended."""
    moved: list[tuple[str, float]] = []
    stage = dashboard.execution.stage
    go_to = stage.go_to

    def timed(node_id: str, *args: Any, **kwargs: Any) -> None:
        go_to(node_id, *args, **kwargs)
        moved.append((node_id, time.time()))

    stage.go_to = timed  # type: ignore[method-assign]
    return moved


def _check_motions(
    events: list[ExecutionEvent],
    played: list[tuple[float, float]],
    moved: list[tuple[str, float]],
) -> None:
    motions = [e for e in events if e.kind == "actuation"]
    assert motions and len(played) == len(motions)
    for event, (begun, ended) in zip(motions, played, strict=True):
        assert event.start is not None and event.end is not None
        stored = event.end - event.start
        assert stored >= 0.3, event
        # It starts as the animation does, after the tree went to the node.
        drawn = [t for node, t in moved if node == event.node and t <= begun]
        assert drawn and drawn[-1] <= event.start <= begun and ended <= event.end, event
        assert stored == pytest.approx(ended - begun, rel=0.2), (event, begun, ended)


def _check_clicked_humans(plan: Plan, events: list[ExecutionEvent]) -> None:
    """Every click that answered for the human ends a human action of source click; it
    began no later than the robot's request or question it answers."""
    humans = [e for e in events if e.kind == HUMAN]
    assert humans and all(e.source == "click" for e in humans)
    answered = [e for e in events if e.source == "click" and is_step(e)]
    for event in answered:
        node = plan.nodes[event.node]
        if not waits_for_human(node):
            continue
        match = [h for h in humans if h.node == event.node and h.end == event.end]
        assert len(match) == 1, event
        human = match[0]
        assert human.start is not None and event.start is not None
        assert human.start <= human.end  # type: ignore[operator]
        assert human.start >= events[0].start  # type: ignore[operator]
    # Every request the human was asked is followed by the click that reports it done.
    requests = [
        k for k, e in enumerate(events)
        if is_step(e) and human_activity(plan.nodes[e.node], e.outcome) is not None
    ]  # fmt: skip
    for k in requests:
        later = [h for h in humans if events.index(h) > k]
        assert later and later[0].start <= events[k].end + 1e-6  # type: ignore[operator]


def test_a_clicked_session_stores_true_motions_and_the_humans_actions(
    browser: Browser, dashboard: Dashboard
) -> None:
    played = _timed_animations(dashboard)
    moved = _timed_tree_moves(dashboard)
    with opened(browser, dashboard) as page:
        session_id = run_by_clicks(page, dashboard, SECONDS_PER_STEP)
    plan = dashboard.plan
    assert plan is not None
    assert dashboard.store.get(session_id).clock == "wall"
    events = dashboard.store.events(session_id)
    _check_motions(events, played, moved)
    _check_clicked_humans(plan, events)
    metrics = session_metrics(events, clock="wall")
    assert metrics.timed
    assert metrics.human_active_s is not None and metrics.human_active_s > 0
    assert metrics.robot_idle_s is not None and metrics.robot_idle_s > 0
    assert metrics.robot_active_s is not None and metrics.robot_active_s > 0


def test_an_old_wall_session_without_a_clock_is_untimed(tmp_path: Path) -> None:
    """Sessions stored before sessions said their clock (zero-length motions, no human
    actions) give counts, not times."""
    from app.sessions.store import SessionStore
    from tests.plan_fixtures import paper_plan

    plan = paper_plan("paper-09")
    with SessionStore(tmp_path) as store:
        session = store.start(plan)  # as before: no clock said
        store.record(session, ExecutionEvent(0, 1.0, plan.root, None, "goal", start=1.0, end=1.0))
        record = store.get(session)
        events = store.events(session)
    assert record.clock is None
    assert not session_metrics(events, clock=record.clock).timed
