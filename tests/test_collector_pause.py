"""Planning pauses Python's cycle collector while it runs, and gives it back."""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator

import pytest

from planner.collector_pause import cycle_collection_paused
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from planner.search.hcp import ConditionalPlanner


@pytest.fixture
def collector_on() -> Iterator[None]:
    was = gc.isenabled()
    gc.enable()
    yield
    if not was:
        gc.disable()


@pytest.mark.usefixtures("collector_on")
def test_the_collector_is_paused_while_a_plan_is_made_and_runs_after() -> None:
    seen: list[bool] = []

    def hook(_: ConditionalPlanner) -> None:
        seen.append(gc.isenabled())

    result = plan_scenario(
        load_scenario(find_scenario("declared.toml")), workers=1, planner_hook=hook
    )
    assert seen == [False] and result.plan.nodes
    assert gc.isenabled()


@pytest.mark.usefixtures("collector_on")
def test_overlapping_plans_give_the_collector_back_when_the_last_ends() -> None:
    second_in, first_out = threading.Event(), threading.Event()
    during: list[bool] = []

    def second() -> None:
        with cycle_collection_paused():
            second_in.set()
            first_out.wait(10)
            during.append(gc.isenabled())  # the first plan is done, this one is not

    with cycle_collection_paused():
        thread = threading.Thread(target=second)
        thread.start()
        assert second_in.wait(10)
    first_out.set()
    thread.join(10)
    assert during == [False]
    assert gc.isenabled()


def test_a_collector_paused_before_stays_paused() -> None:
    was = gc.isenabled()
    gc.disable()
    try:
        with cycle_collection_paused():
            assert not gc.isenabled()
        assert not gc.isenabled()
    finally:
        if was:
            gc.enable()
