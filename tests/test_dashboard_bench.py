"""The bench never disagrees with the tree: at every node of a run, what the bench
drew during the execution is what a click on that node in the tree draws (the
real dashboard and viser server; the parts and their labels as sent)."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.dashboard.server import Dashboard
from app.dashboard.stage import NodeSelected
from app.execution.events import ExecutionEvent, is_step
from planner.plan.model import Plan
from tests.plan_fixtures import default_plan
from tests.test_dashboard import served, wait_for

Drawn = dict[str, tuple[tuple[float, ...], str | None]]
_CLICKS = itertools.count()  # each click the page sends is a new value of the field


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(Path(tmp_path_factory.mktemp("data"))) as d:
        yield d


def clicked_in_tree(dashboard: Dashboard, node_id: str) -> Drawn:
    """The bench once `node_id` is clicked in the tree, as the page sends the click
    (its frame at once, its bench a moment later)."""
    tree = dashboard.tree
    tree.bridge.value = f"tree:select:{node_id}:{next(_CLICKS)}"
    wait_for(lambda: dashboard.screen.bench_at == node_id and dashboard.selected == node_id, 20)
    return dashboard.bench.drawn()


def answers_to_the_reported_case(plan: Plan) -> dict[str, str]:
    """The answers that take a run to where the bench once lied: the human is seen
    holding a part (sense(humanHoldingWhichPart)), and the robot then asks whether
    they attached it (confirmAttach): the bench drew the part still lying there."""
    target = next((n, c.outcome) for n, node in sorted(plan.nodes.items())
                  if "humanHoldingWhichPart" in str(node.action) for c in node.children
                  if "confirmAttach" in str(plan.nodes[c.node].action))  # fmt: skip
    way: dict[str, tuple[str, str | None]] = {}  # node -> (parent, outcome), breadth first
    queue = [plan.root]
    while queue and target[0] not in way:
        node_id = queue.pop(0)
        for child in plan.nodes[node_id].children:
            if child.node not in way and child.node != plan.root:
                way[child.node] = (node_id, child.outcome)
                queue.append(child.node)
    answers = {target[0]: str(target[1])}
    node_id = target[0]
    while node_id != plan.root:
        parent, outcome = way[node_id]
        if outcome is not None:
            answers[parent] = outcome
        node_id = parent
    return answers


def test_the_bench_of_a_run_is_the_bench_of_a_click_at_every_node(dashboard: Dashboard) -> None:
    plan = default_plan()
    answers = answers_to_the_reported_case(plan)
    dashboard.show_plan(plan)
    execution = dashboard.execution
    execution.speed.value = 0.0
    asked: dict[str, Drawn] = {}  # the bench while a question waits at a node
    left: list[tuple[str, Drawn]] = []  # the bench as each step leaves it

    def selected(message: NodeSelected) -> None:
        clicks = execution.clicks
        offer = clicks.pending() if clicks is not None else None
        if offer is not None and offer.node_id == message.node_id:
            asked.setdefault(message.node_id, dashboard.bench.drawn())

    def stepped(event: ExecutionEvent) -> None:  # after the panel's own listener
        if is_step(event):
            left.append((event.node, dashboard.bench.drawn()))

    dashboard.events.subscribe(NodeSelected, selected)
    execution.start()
    wait_for(lambda: execution.executor is not None, 30)
    executor = execution.executor
    assert executor is not None
    executor.listeners.append(stepped)
    clicks = execution.clicks
    assert clicks is not None
    compared = 0
    while not executor.done:
        offer = clicks.pending()
        if offer is None or offer.node_id not in asked:
            wait_for(lambda: executor.done or (clicks.pending() is not None
                     and clicks.pending().node_id in asked), 30)  # type: ignore[union-attr]
            continue
        # While the question waits, a click on its node in the tree draws what the
        # run drew (before the answer: nothing is known of it yet).
        assert clicked_in_tree(dashboard, offer.node_id) == asked[offer.node_id], offer.node_id
        compared += 1
        clicks.click(answers.get(offer.node_id, offer.options[-1]), offer.node_id)
        wait_for(lambda o=offer: clicks.pending() is not o or executor.done, 20)  # type: ignore[misc]
    assert executor.result == "goal", executor.events
    assert compared >= 3
    # After the run, its path still marked: each node it passed, clicked, draws the
    # bench the run left there, the answers it got included.
    for node_id, drawn in left:
        assert clicked_in_tree(dashboard, node_id) == drawn, node_id
    holding = [n for n, _ in left if "humanHoldingWhichPart" in str(plan.nodes[n].action)]
    for node_id in holding:  # what the human was seen to hold is in their hands
        words = [w for _, w in dict(left)[node_id].values() if w is not None]
        assert any("held by human" in w for w in words), (node_id, words)
