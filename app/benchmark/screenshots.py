"""Screenshots of the dashboard, taken through headless chromium as a person uses it.

`python -m app.benchmark.screenshots [--out FOLDER]` (`make screenshots`,
also run by `make bench`) writes, into `docs/screenshots` by default:

- `tree-default.png`, `tree-U10.png`: each plan just made, its tree opened on
  the expected branch, the root's details under the tree;
- `tree-U10-wide.png`: the U10 tree beside the bench ("Wide"), a sensing node
  selected (its details with why it senses);
- `execution-1600x1000.png`, `execution-1280x800.png`: an execution of the
  default plan while the simulated human's question waits, the path taken
  marked on the tree;
- `review.png`: that session reviewed, half-way through its timeline.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from app.benchmark.page_driver import dashboard_page, plan_in_page, wait_for
from app.dashboard.server import Dashboard
from app.dashboard.widgets import show

SETTLE_S = 4.0  # the robot's meshes arrive and are drawn (software WebGL)


def _quiet(page: Any) -> None:
    """Close the browser's notices (headless chromium warns of software WebGL)."""
    for close in page.locator(".mantine-Notification-root button").all():
        close.click()


def shoot(page: Any, path: Path) -> None:
    _quiet(page)
    time.sleep(0.5)
    page.screenshot(path=str(path))
    print(f"wrote {path}")


def answer(dashboard: Dashboard, page: Any, questions: int | None) -> None:
    """Answer `questions` questions (None: to the end) with the first button."""
    execution = dashboard.execution
    answered = 0
    while execution.running and (questions is None or answered < questions):
        offer = execution.clicks.pending() if execution.clicks is not None else None
        if offer is None:
            time.sleep(0.05)
            continue
        page.get_by_role("button", name=offer.words[0], exact=True).first.click()
        clicks = execution.clicks
        wait_for(lambda: clicks is None or clicks.pending() != offer)  # noqa: B023 (waited here)
        answered += 1


def trees(out: Path) -> None:
    for scenario, name in (("default.toml", "default"), ("paper/U10.toml", "U10")):
        with dashboard_page(scenario, models=True) as (dashboard, page):
            plan_in_page(dashboard, page)
            time.sleep(SETTLE_S)
            shoot(page, out / f"tree-{name}.png")
            if name != "U10":
                continue
            page.get_by_role("button", name="Wide", exact=True).click()
            plan = dashboard.plan
            assert plan is not None
            sensing = next(n for n, _ in plan.expected_path() if plan.nodes[n].kind == "sensing")
            dashboard.go_to(sensing)
            wait_for(lambda: dashboard.screen.bench_at == sensing)  # noqa: B023 (waited here)
            time.sleep(SETTLE_S)
            shoot(page, out / f"tree-{name}-wide.png")


def execution(out: Path, size: tuple[int, int], review: bool) -> None:
    with dashboard_page("default.toml", size, models=True) as (dashboard, page):
        plan_in_page(dashboard, page)
        show(dashboard.execution.speed, 0.2)
        page.get_by_role("button", name="Execute plan", exact=True).click()
        wait_for(lambda: dashboard.execution.running)
        answer(dashboard, page, 3)
        wait_for(lambda: dashboard.execution.clicks is not None
                 and dashboard.execution.clicks.pending() is not None)  # fmt: skip
        time.sleep(SETTLE_S)
        shoot(page, out / f"execution-{size[0]}x{size[1]}.png")
        if not review:
            return
        show(dashboard.execution.speed, 0.0)
        answer(dashboard, page, None)
        session = dashboard.execution.session_id
        # The review opens a session once the execution has ended (its finish is
        # announced from the executor's thread, a moment after the last answer).
        wait_for(lambda: not dashboard.review.executing)
        dashboard.review.refresh()
        label = next(k for k, v in dashboard.review._ids.items() if v == session)
        dashboard.review.open(label)
        wait_for(lambda: dashboard.review.opened == session)
        half = len(dashboard.review.events) // 2
        show(dashboard.review.timeline, half + 1)  # where the slider stands (steps from 1)
        dashboard.review.show_step(half)
        page.get_by_role("tab", name="Review").click()
        time.sleep(1.0)
        shoot(page, out / "review.png")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.screenshots")
    parser.add_argument("--out", default="docs/screenshots", help="folder for the PNG files")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    trees(out)
    execution(out, (1600, 1000), review=True)
    execution(out, (1280, 800), review=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
