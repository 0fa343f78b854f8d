"""Dashboard benchmark: page load to interactive, the server-side cost of a click
on a node of a large plan, and how the bench draws in a browser without a GPU.
`python -m app.benchmark.dashboard_benchmark [SCENARIO]` prints a table.

Times are medians; a node click is what the scene's on_click handler runs: select
the node, write its details, move the highlight, place parts and arms for that
node. A page click is playwright's, on a camera button of the bench view: it
waits for the page's frames, so it shows what software WebGL costs a person.
"""

from __future__ import annotations

import argparse
import random
import shutil
import statistics
import sys
import time
from collections.abc import Sequence

from app.benchmark.page_driver import free_port
from app.dashboard.mesh_detail import DEFAULT_DETAIL
from app.dashboard.server import Dashboard, DashboardSettings
from planner.plan.model import format_table
from planner.planning import plan_scenario
from planner.resources import scenario_path
from planner.scenario.loading import load_scenario

DEFAULT = scenario_path("paper/U10.toml")


def page_loads(dashboard: Dashboard, runs: int) -> list[float]:
    """Seconds from navigation to a page whose Plan button works and whose client
    the server knows (chromium, headless, software WebGL)."""
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    out = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        for _ in range(runs):
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            before = set(dashboard.server.get_clients())
            t0 = time.perf_counter()
            page.goto(f"http://127.0.0.1:{dashboard.server.getfree_port()}")
            page.get_by_role("button", name="Plan", exact=True).wait_for()
            while not set(dashboard.server.get_clients()) - before:
                time.sleep(0.01)
            out.append(time.perf_counter() - t0)
            page.close()
        browser.close()
    return out


# Two animation frames, measured in the page: the second starts after the first is drawn.
TWO_FRAMES_JS = """new Promise(done => { const t = performance.now();
  requestAnimationFrame(() => requestAnimationFrame(() => done(performance.now() - t))); })"""
SETTLE_S = 10.0  # the robot's meshes arrive and are drawn once before measuring


def page_drawing(detail: float, frames: int, clicks: int) -> tuple[list[float], list[float]]:
    """Seconds per frame of the bench view and per click on its "Bench" camera button,
    in headless chromium (software WebGL), with the meshes at `detail`."""
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    dashboard = Dashboard(
        "127.0.0.1", free_port(), "default.toml", DashboardSettings(mesh_detail=detail)
    )
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(f"http://127.0.0.1:{dashboard.server.getfree_port()}")
            button = page.get_by_role("button", name="Bench", exact=True)
            button.wait_for()
            time.sleep(SETTLE_S)
            frame_s = [page.evaluate(TWO_FRAMES_JS) / 2000 for _ in range(frames)]
            click_s = []
            for _ in range(clicks):
                t = time.perf_counter()
                button.click(timeout=120_000)
                click_s.append(time.perf_counter() - t)
            browser.close()
    finally:
        dashboard.close()
    return frame_s, click_s


def clicks_while_planning(dashboard: Dashboard, every_s: float = 0.05) -> tuple[list[float], float]:
    """Seconds per node click on the growing tree while the open scenario plans in
    the background (the page must stay usable), and the planning time."""
    rng = random.Random(1)
    clicks: list[float] = []
    t0 = time.perf_counter()
    dashboard.start_planning()
    job = dashboard.job
    while job is not None and (job.running or job.status.state == "idle"):
        plan = dashboard.plan
        if plan is not None:
            node_id = rng.choice(list(plan.nodes))
            t = time.perf_counter()
            dashboard.select(node_id)
            clicks.append(time.perf_counter() - t)
        time.sleep(every_s)
    return clicks, time.perf_counter() - t0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.dashboard_benchmark")
    parser.add_argument("scenario", nargs="?", default=str(DEFAULT))
    parser.add_argument("--clicks", type=int, default=200)
    parser.add_argument("--loads", type=int, default=5)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--page-clicks", type=int, default=3)
    args = parser.parse_args(argv)
    scenario = load_scenario(args.scenario)
    t0 = time.perf_counter()
    plan = plan_scenario(scenario, workers=0).plan
    plan_s = time.perf_counter() - t0
    dashboard = Dashboard("127.0.0.1", free_port(), args.scenario)
    try:
        loads = page_loads(dashboard, args.loads)
        dashboard.plan = plan
        dashboard.tree.show(plan)
        ids = list(plan.nodes)
        rng = random.Random(0)
        clicks = []
        for node_id in rng.sample(ids, min(args.clicks, len(ids))):
            t = time.perf_counter()
            dashboard.select(node_id)
            clicks.append(time.perf_counter() - t)
        t = time.perf_counter()
        dashboard.tree.toggle(plan.root)
        dashboard.tree.toggle(plan.root)
        redraw_s = (time.perf_counter() - t) / 2
        busy, busy_plan_s = clicks_while_planning(dashboard)
    finally:
        dashboard.close()
    rows: list[tuple[str, ...]] = [
        ("plan", scenario.name,
         f"{plan.statistics['dag_nodes']} nodes ({plan.statistics['N']} unfolded)",
         f"{plan_s:.2f} s"),
        ("page load to interactive", f"{len(loads)} loads",
         f"median {statistics.median(loads):.2f} s", f"max {max(loads):.2f} s"),
        ("node click (server)", f"{len(clicks)} clicks",
         f"median {1000 * statistics.median(clicks):.1f} ms", f"max {1000 * max(clicks):.1f} ms"),
        ("collapse/expand redraw", "root", f"{1000 * redraw_s:.0f} ms", ""),
        ("node click while planning", f"{len(busy)} clicks in {busy_plan_s:.1f} s",
         f"median {1000 * statistics.median(busy or [0]):.1f} ms",
         f"max {1000 * max(busy or [0]):.1f} ms"),
    ]  # fmt: skip
    for detail in (DEFAULT_DETAIL, 1.0):
        frame_s, click_s = page_drawing(detail, args.frames, args.page_clicks)
        rows += [
            (f"bench frame, mesh detail {detail:g}", f"{len(frame_s)} frames",
             f"median {1000 * statistics.median(frame_s):.0f} ms",
             f"max {1000 * max(frame_s):.0f} ms"),
            (f"page click, mesh detail {detail:g}", f"{len(click_s)} clicks",
             f"median {statistics.median(click_s):.2f} s", f"max {max(click_s):.2f} s"),
        ]  # fmt: skip
    print(format_table(("measure", "on", "result", "spread"), rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
