"""A dashboard and a headless chromium page on it, for the page benchmarks and
the screenshots: what a person would do, through the page."""

from __future__ import annotations

import shutil
import socket
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from app.dashboard.server import Dashboard, DashboardSettings

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(condition: Callable[[], object], timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise TimeoutError("the page did not get there in time")
        time.sleep(0.01)


@contextmanager
def dashboard_page(
    scenario: str = "default.toml",
    size: tuple[int, int] = (1600, 1000),
    *,
    models: bool = False,
    workers: int = 0,
) -> Iterator[tuple[Dashboard, Any]]:
    """A dashboard on `scenario` (its own data and cache folders) and a page of it
    whose Plan button is ready."""
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory(prefix="tandem-page-") as data:
        settings = DashboardSettings(workers=workers, data_dir=data, cache_dir=f"{data}/cache",
                                     load_models=models)  # fmt: skip
        dashboard = Dashboard("127.0.0.1", free_port(), scenario, settings)
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
                page = browser.new_page(viewport={"width": size[0], "height": size[1]})
                page.goto(f"http://127.0.0.1:{dashboard.server.get_port()}")
                wait_for(lambda: dashboard.server.get_clients())
                page.get_by_role("button", name="Plan", exact=True).wait_for()
                yield dashboard, page
                browser.close()
        finally:
            dashboard.close()


def plan_shown(dashboard: Dashboard) -> bool:
    plan = dashboard.plan
    return plan is not None and not plan.partial and dashboard.selected == plan.root


def plan_in_page(dashboard: Dashboard, page: Any) -> float:
    """Seconds from a click on Plan to the plan drawn in the tree, its root selected."""
    before = dashboard.job  # the click reaches the server a moment after it returns
    t0 = time.perf_counter()
    page.get_by_role("button", name="Plan", exact=True).click()
    wait_for(lambda: dashboard.job is not before and plan_shown(dashboard), 600)
    page.locator(f'svg.tandem-tree [data-node="{dashboard.selected}"]').wait_for()
    return time.perf_counter() - t0


# The tree's nodes whose boxes lie inside the picture's frame.
NODES_IN_VIEW = """() => { const s = document.querySelector('svg.tandem-tree')
    .getBoundingClientRect();
  return [...document.querySelectorAll('svg.tandem-tree g.node')].filter(g => {
    const r = g.querySelector('rect.box').getBoundingClientRect();
    return r.left >= s.left && r.right <= s.right && r.top >= s.top && r.bottom <= s.bottom;
  }).map(g => g.dataset.node); }"""
