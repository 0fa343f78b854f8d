"""The dashboard drives the simulated Baxter node over ROS (real roscore, real
chromium): the Robot panel connects, an execution moves the robot, and the drawn
arms follow the joint states it publishes; with no master the page says so and
the motions stay drawn."""

from __future__ import annotations

import functools
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from app.execution.robot_link import farthest  # noqa: E402
from app.robot.ros_env import free_port as free_ros_port  # noqa: E402
from app.sources.outcomes import Offer  # noqa: E402
from planner.feasibility.arms import HOME, joint_names  # noqa: E402
from tests.robot_graph import (  # noqa: E402
    FaultTopic,
    JointWatch,
    ros_installed,
    shared_master,
    sim_baxter,
)
from tests.test_dashboard import (  # noqa: E402
    choose,
    execute_clicked,
    field,
    opened,
    plan_clicked,
    plan_shown,
    served,
    wait_for,
)

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")
SHOTS = Path(__file__).resolve().parent / "artifacts"


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    # With the robot's meshes: the test checks the arms as drawn.
    with served(tmp_path_factory.mktemp("data"), load_models=True) as d:
        yield d


@pytest.fixture(scope="module")
def page(browser: Browser, dashboard: Dashboard) -> Iterator[Page]:
    with opened(browser, dashboard) as page:
        yield page


def _connect(page: Page, uri: str) -> None:
    if not field(page, "ROS master").is_visible():  # type: ignore[attr-defined]
        page.get_by_text("Robot", exact=True).first.click()  # a folder, closed at first
    box = field(page, "ROS master")
    box.fill(uri)  # type: ignore[attr-defined]
    box.press("Enter")  # type: ignore[attr-defined]
    page.get_by_role("button", name="Connect", exact=True).click()


def _fewest_motions(dashboard: Dashboard, offer: Offer) -> int:
    """Which of the offer's answers leads to the goal with the fewest motions: the
    tests watch the arms move, and any branch shows that; the shortest (6 motions of
    the default plan, 9 by the last answers) keeps them quick."""
    plan = dashboard.current_plan()
    assert plan is not None

    @functools.cache
    def motions(node_id: str) -> int:
        node = plan.nodes[node_id]
        below = [motions(child.node) for child in node.children]
        return (node.motion is not None) + min(below, default=0)

    node = plan.nodes[offer.node_id]
    after = [node.child(option) for option in offer.options]
    costs = [motions(child) if child is not None else len(plan.nodes) for child in after]
    return costs.index(min(costs))


def test_without_a_master_the_page_says_so_and_keeps_the_drawing(
    page: Page, dashboard: Dashboard
) -> None:
    uri = f"http://127.0.0.1:{free_ros_port()}"
    page.get_by_text("Robot", exact=True).first.click()  # a folder, closed at first
    choose(page, "Moves", "robot over ROS")  # chosen, not yet connected: the page says so
    page.get_by_text("Press Connect to reach the robot", exact=False).first.wait_for()
    assert dashboard.robot.link is None
    _connect(page, uri)
    page.get_by_text("Not connected", exact=False).first.wait_for()
    page.get_by_text(f"no ROS master answers at {uri}", exact=False).first.wait_for()
    assert dashboard.robot.link is None


def test_an_execution_moves_the_simulated_baxter_and_the_drawn_arm_follows(
    page: Page, dashboard: Dashboard
) -> None:
    master = shared_master()
    with sim_baxter(master):
        watch = JointWatch(master)
        _connect(page, master.uri)
        page.get_by_text("the plan's motions move the robot", exact=False).first.wait_for(
            timeout=20_000
        )
        assert dashboard.robot.link is not None
        if not plan_shown(dashboard)():
            plan_clicked(page, dashboard, 120)
        dashboard.execution.speed.value = 0.0
        wait_for(lambda: not dashboard.execution.start_button.disabled)
        executor = execute_clicked(page, dashboard)
        drawn: list[list[float]] = []  # the drawn left arm, while the robot moves
        while not executor.done:
            # A fault waits for the operator's Retry or Abort: said here, not waited on.
            fault = dashboard.robot.fault
            assert fault is None or not fault.visible, fault.content
            drawn.append(list(dashboard.bench.drawn_arms["left"]))
            offer = dashboard.execution.clicks.pending() if dashboard.execution.clicks else None
            if offer is not None:
                best = _fewest_motions(dashboard, offer)
                button = page.get_by_role("button", name=offer.words[best], exact=True)
                try:
                    button.click(timeout=5000)
                except Exception:  # the buttons went as it was clicked: look again
                    pass
                wait_for(lambda o=offer: dashboard.execution.clicks.pending() != o or executor.done)
            time.sleep(0.05)
        assert executor.result == "goal", executor.events
        page.screenshot(path=str(SHOTS / "dashboard-robot.png"))
        # The drawn arms are where the robot says it is...
        robot = watch.latest()
        watch.close()
        for arm in ("left", "right"):
            names = joint_names(arm)
            drawn_now = dashboard.bench.drawn_arms[arm]
            assert farthest(drawn_now, [robot[n] for n in names]) <= 0.01
    # ...and they moved through the robot's poses on the way, not only the poses the
    # plan's world gives at each node's end (what a drawing without the robot shows).
    plan = dashboard.current_plan()
    assert plan is not None
    ends = [list(HOME["left"])] + [
        list(n.motion.path[-1]) for n in plan.nodes.values() if n.motion is not None
    ]
    between = {
        tuple(round(q, 2) for q in pose)
        for pose in drawn
        if all(farthest(pose, end) > 0.02 for end in ends)
    }
    assert len(between) > 5
    moves = [e for e in executor.events if e.kind == "actuation"]
    assert moves and all(e.evidence and e.evidence.robot for e in moves)


def test_a_robot_fault_asks_the_operator_and_retry_goes_on(
    page: Page, dashboard: Dashboard
) -> None:
    master = shared_master()
    with sim_baxter(master):
        faults = FaultTopic(master)
        if dashboard.robot.link is None:
            _connect(page, master.uri)
            wait_for(lambda: dashboard.robot.link is not None, 20)
        if not plan_shown(dashboard)():
            plan_clicked(page, dashboard, 120)
        dashboard.execution.speed.value = 0.0
        wait_for(lambda: not dashboard.execution.start_button.disabled)
        faults.send("abort")  # the first goal is aborted halfway
        page.get_by_role("button", name="Execute plan", exact=True).click()
        retry = page.get_by_role("button", name="Retry", exact=True)
        retry.wait_for(timeout=60_000)  # the operator is asked
        page.get_by_text("The robot stopped:", exact=False).first.wait_for()
        page.screenshot(path=str(SHOTS / "dashboard-robot-fault.png"))
        retry.click()
        executor = dashboard.execution.executor
        assert executor is not None
        # Bounded, and saying where the run stood: a run that waits for ever (the
        # operator asked again, a goal never ended) fails here with its events.
        deadline = time.monotonic() + 240
        while not executor.done:
            assert time.monotonic() < deadline, executor.events
            offer = dashboard.execution.clicks.pending() if dashboard.execution.clicks else None
            if offer is not None:
                best = _fewest_motions(dashboard, offer)
                dashboard.execution.clicks.click(offer.options[best], offer.node_id)
            time.sleep(0.05)
        faults.close()
    assert executor.result == "goal", executor.events
    kinds = [e.kind for e in executor.events]
    assert kinds.count("robot-fault") == 1
    assert not retry.is_visible()  # the question went once answered
