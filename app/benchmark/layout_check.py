"""The layout holds: the camera's Enlarge, then reloads, through headless chromium.

`python -m app.benchmark.layout_check` (`make bench` runs it) prints, at
1600×1000 and 1280×800, the bench's width (the 3D view between the docked
panels) on a fresh page, after ticking and unticking the camera's "Enlarge the
frame", after reloading that page, and on a page opened afterwards. They must
be equal: each page's layout is its own (app/dashboard/layout.py). Before, one
tick and untick left every later page a 665-684 px left column and the bench
121 px at 1280×800.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from typing import Any

from app.benchmark.page_driver import dashboard_page, wait_for
from planner.plan.model import format_table

SIZES = ((1600, 1000), (1280, 800))
BENCH = "() => Math.round(document.querySelector('canvas').getBoundingClientRect().width)"


def bench_width(page: Any) -> int:
    """The bench's width in px once the docked panels stand still."""
    last = -1
    end = time.monotonic() + 30
    while time.monotonic() < end:
        now = int(page.evaluate(BENCH))
        if now == last:
            return now
        last = now
        time.sleep(0.3)
    raise TimeoutError("the panels kept moving")


def toggle_enlarge(page: Any) -> None:
    label = page.get_by_text("Enlarge the frame", exact=True).first
    box = label.locator("xpath=ancestor::*[.//input][1]").locator("input").first
    ticked = box.is_checked()
    box.click()
    wait_for(lambda: box.is_checked() != ticked, 20)


def check(size: tuple[int, int]) -> tuple[str, ...]:
    with dashboard_page("default.toml", size) as (dashboard, page):
        before = bench_width(page)
        page.get_by_role("button", name="Start camera", exact=True).click()
        wait_for(lambda: dashboard.camera_panel.last_annotated is not None, 60)
        toggle_enlarge(page)
        toggle_enlarge(page)
        after = bench_width(page)
        page.reload()
        page.get_by_role("button", name="Plan", exact=True).wait_for()
        reloaded = bench_width(page)
        later = page.context.browser.new_page(viewport={"width": size[0], "height": size[1]})
        later.goto(page.url)
        later.get_by_role("button", name="Plan", exact=True).wait_for()
        visitor = bench_width(later)
    widths = (before, after, reloaded, visitor)
    return (f"{size[0]}×{size[1]}", *(f"{w} px" for w in widths),
            "yes" if len(set(widths)) == 1 else "no")  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    argparse.ArgumentParser(prog="python -m app.benchmark.layout_check").parse_args(argv)
    rows = [check(size) for size in SIZES]
    print(format_table(("page", "bench at first", "Enlarge on and off", "reloaded",
                        "a later page", "held"), rows))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
