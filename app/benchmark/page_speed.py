"""Page speed, measured through headless chromium as a person would meet it.

`python -m app.benchmark.page_speed` prints one table (`make bench` runs it):

- **plan U10 in the page**: a click on Plan to the tree drawn with its root
  selected, against `tandem plan paper/U10.toml` as a process (start to
  exit, no cache for either); target: within 1.3× the command line.
- **node click on U10**: a click on a box of the tree to the box framed as
  selected on the page and its details shown under the tree; target 0.3 s
  (median of 20). The page draws the bench with Baxter's and the human's
  meshes, as a person's does, and each click waits for the bench to follow
  (its world sent) and for a person's glance (`GLANCE_S`) before the next.
  The bench's own time to follow is printed beside it.
- **execution start**: a click on Execute plan to the first step in the
  page's timeline, on the default scenario; target 1 s.

"before" is what the issue that asked for these measured on the page as it
was (its 3D tree and one long panel), on the same kind of 2-core machine.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

from app.benchmark.page_driver import NODES_IN_VIEW, dashboard_page, plan_in_page, wait_for
from app.dashboard.server import Dashboard
from app.dashboard.widgets import show
from planner.plan.model import format_table

BIG = "paper/U10.toml"
GLANCE_S = 0.5  # between a node's bench drawn and the next click, as a person looks


def command_line_plan(scenario: str) -> float:
    """Seconds `tandem plan` takes as a process, without the checks' cache."""
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "app.cli", "plan", scenario, "--quiet", "--no-cache",
             "-o", f"{out}/plan.json"],
            check=True, stdout=subprocess.DEVNULL,
        )  # fmt: skip
        return time.perf_counter() - t0


def node_clicks(dashboard: Dashboard, page: Any, clicks: int) -> tuple[list[float], list[float]]:
    """Seconds per click on a node in view to its frame and its details on the
    page, and to its bench sent (the bench follows the frame)."""
    plan = dashboard.plan
    assert plan is not None
    seen: list[str] = page.evaluate(NODES_IN_VIEW)
    times, benches = [], []
    for k in range(clicks):
        node = seen[k % len(seen)]
        if node == dashboard.selected:
            node = seen[(k + 1) % len(seen)]
        box = page.locator(f'svg.tandem-tree [data-node="{node}"] rect.box').bounding_box()
        assert box is not None
        action = str(plan.nodes[node].action or "goal")
        # The mouse, as a person's: no waiting for the page to settle before it.
        t0 = time.perf_counter()
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.locator(f'svg.tandem-tree [data-node="{node}"] rect[stroke="#d0209c"]').wait_for()
        page.locator("strong").get_by_text(action, exact=True).first.wait_for()
        times.append(time.perf_counter() - t0)
        wait_for(lambda: dashboard.screen.bench_at == node)  # noqa: B023 (waited here)
        benches.append(time.perf_counter() - t0)
        time.sleep(GLANCE_S)
    return times, benches


def execution_starts(dashboard: Dashboard, page: Any, runs: int) -> list[float]:
    """Seconds from a click on Execute plan to the first step on the page."""
    times = []
    for _ in range(runs):
        wait_for(lambda: not dashboard.execution.start_button.disabled)
        page.evaluate("document.querySelectorAll('svg.tandem-strip').forEach(s => s.remove())")
        t0 = time.perf_counter()
        page.get_by_role("button", name="Execute plan", exact=True).click()
        page.locator("svg.tandem-strip").wait_for()
        times.append(time.perf_counter() - t0)
        page.get_by_role("button", name="Abort", exact=True).click()
        wait_for(lambda: not dashboard.execution.running)
    return times


def median(values: list[float]) -> float:
    return statistics.median(values)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.page_speed")
    parser.add_argument("--runs", type=int, default=3, help="plans of U10 each way")
    parser.add_argument("--clicks", type=int, default=20)
    parser.add_argument("--starts", type=int, default=5)
    args = parser.parse_args(argv)
    cli = [command_line_plan(BIG) for _ in range(args.runs)]
    in_page: list[float] = []
    with dashboard_page(BIG, models=True) as (dashboard, page):
        for _ in range(args.runs):
            in_page.append(plan_in_page(dashboard, page))
        clicks, benches = node_clicks(dashboard, page, args.clicks)
    with dashboard_page("default.toml") as (dashboard, page):
        plan_in_page(dashboard, page)
        show(dashboard.execution.speed, 0.5)
        starts = execution_starts(dashboard, page, args.starts)
    ratio = median(in_page) / median(cli)
    rows: list[tuple[str, ...]] = [
        ("plan U10: page / command line", "≤ 1.3×", "11.4 s / 2.8 s = 4.1×",
         f"{median(in_page):.2f} s / {median(cli):.2f} s = {ratio:.2f}×",
         "yes" if ratio <= 1.3 else "no"),
        (f"node click on U10 (median of {len(clicks)})", "≤ 0.3 s", "0.63 s (with meshes)",
         f"{median(clicks):.3f} s (max {max(clicks):.3f})",
         "yes" if median(clicks) <= 0.3 else "no"),
        ("  its bench sent", "", "with the frame",
         f"{median(benches):.3f} s (max {max(benches):.3f})", ""),
        ("execution start to first step", "≤ 1 s", "4.9-13.3 s",
         f"{median(starts):.2f} s (max {max(starts):.2f})",
         "yes" if median(starts) <= 1.0 else "no"),
    ]  # fmt: skip
    print(format_table(("page speed", "target", "before", "now (median)", "met"), rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
