"""A large bench in the page: `python -m app.benchmark.large_page [--n 30]`.

Plans family U continued to n (U30: a top, 30 legs, 30 feet; declared
feasibility) in the dashboard through headless chromium, as a person would,
and prints one table: from the click on Plan to the first partial plan drawn
(the progress a person sees while the rest is planned), to the whole plan
drawn with its root selected, its distinct nodes, and a click on a node of its
tree to that node framed with its details (median of `--clicks`; target 0.3 s).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from app.benchmark.page_driver import dashboard_page, plan_shown, wait_for
from app.benchmark.page_speed import node_clicks
from app.dashboard.server import Dashboard
from planner.plan.model import format_table
from planner.scenario import paper


def _planned(dashboard: Dashboard, page: Any) -> tuple[float | None, float]:
    """Seconds from the click on Plan to the first partial plan in the tree (None if
    none was drawn before the whole plan) and to the whole plan drawn."""
    before = dashboard.job
    t0 = time.perf_counter()
    page.get_by_role("button", name="Plan", exact=True).click()
    first: float | None = None
    while not (dashboard.job is not before and plan_shown(dashboard)):
        plan = dashboard.plan
        if first is None and dashboard.job is not before and plan is not None and plan.partial:
            first = time.perf_counter() - t0
        if time.perf_counter() - t0 > 900:
            raise TimeoutError("the plan was not drawn within 900 s")
        time.sleep(0.05)
    selected = dashboard.selected
    page.locator(f'svg.tandem-tree [data-node="{selected}"]').wait_for()
    return first, time.perf_counter() - t0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.large_page")
    parser.add_argument("--n", type=int, default=30, help="family U's n (default 30: U30)")
    parser.add_argument("--clicks", type=int, default=20)
    parser.add_argument("--screenshot", metavar="PNG", help="the page after the clicks")
    args = parser.parse_args(argv)
    if args.n < 2:
        parser.error(f"--n {args.n}: 2 or more")
    name = f"U{args.n}"
    with tempfile.TemporaryDirectory(prefix="tandem-large-") as folder:
        scenario = Path(folder) / f"{name}.toml"
        scenario.write_text(paper.scenario_toml("U", args.n, "declared"), encoding="utf-8")
        with dashboard_page(str(scenario), workers=0) as (dashboard, page):
            first, whole = _planned(dashboard, page)
            plan = dashboard.plan
            assert plan is not None
            wait_for(lambda: dashboard.screen.bench_at == dashboard.selected)
            clicks, _ = node_clicks(dashboard, page, args.clicks)
            if args.screenshot:
                page.screenshot(path=args.screenshot)
    rows: list[tuple[str, ...]] = [
        ("first partial plan drawn", "-" if first is None else f"{first:.2f} s", "-"),
        ("whole plan drawn, root selected", f"{whole:.2f} s", "-"),
        ("plan nodes", str(len(plan.nodes)), "-"),
        (f"node click (median of {len(clicks)})", f"{statistics.median(clicks):.3f} s",
         "0.3 s"),
    ]  # fmt: skip
    print(f"{name} in the page (declared feasibility, all cores)")
    print(format_table(("", "measured", "target"), rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
