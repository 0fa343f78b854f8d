"""Soak benchmark: `tandem dashboard` left running with several pages for minutes.

`python -m app.benchmark.soak [--pages 5] [--minutes 10] [--reconnect-every 4]`
starts the dashboard in its own process and opens the pages in headless
chromium. The pages take turns as operator: plan, execute, answer every
question with a click; the others watch. Every few executions one page is
closed and a new one opened in its place (people come and go during a study
day). It prints one table: executions run and sessions stored, page and server
errors, the server's RSS at 1, 5, 30 and 60 minutes (those the run reaches) and
at the end, the time from a click on an answer to the stored event at the start
and at the end of the run, and until the page has dropped its buttons.
`make soak-hour` runs it for an hour with five pages.
"""

from __future__ import annotations

import argparse
import bisect
import os
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from app.sessions.store import SessionRecord, SessionStore
from planner.plan.model import format_table

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Locator, Page

# Niceness of the browsers (see yield_to_server).
BROWSER_NICE = 15
# When the server's RSS is sampled, in minutes after the pages are up.
RSS_AT_MIN = (1, 5, 30, 60)
# The latency's "start" and "end": the first and last this many minutes of clicks
# (a quarter of the run, if shorter).
LATENCY_WINDOW_MIN = 5.0

# The simulated human's answer buttons are worded "Human holds leg2", "Human says yes", ...
# (and not the "Human view" camera button).
ANSWER = re.compile(r"^Human('s hands| holds| says| attaches| puts| keeps)")


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _descendants(pid: int) -> set[int]:
    """Every process below `pid`, from /proc (a snapshot: processes come and go)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def yield_to_server(server_pid: int) -> None:
    """Run the browsers below the server's priority.

    The pages stand in for people at their own machines; here they share two
    cores with the server, and Chromium raises its software-WebGL GPU process
    above normal priority, so five pages rendering the robot starve the server
    they are meant to test. New renderers appear as pages load: call again.
    """
    server_tree = _descendants(server_pid) | {server_pid}
    for pid in _descendants(os.getpid()) - server_tree:
        # Niceness belongs to each thread on Linux (SwiftShader renders on many).
        for task in Path(f"/proc/{pid}/task").glob("[0-9]*"):
            try:
                os.setpriority(os.PRIO_PROCESS, int(task.name), BROWSER_NICE)
            except OSError:
                pass  # gone meanwhile


def server_latencies(clicks: Sequence[float], answered: Sequence[float]) -> list[float]:
    """For each answer the server stored from a click (wall clock), the time since the
    last click before it: the server's part of an answer, without the page's. A click
    that answered nothing (the question had gone) is not counted."""
    return [latency for _, latency in timed_latencies(clicks, answered)]


def timed_latencies(
    clicks: Sequence[float], answered: Sequence[float]
) -> list[tuple[float, float]]:
    """`server_latencies` with the wall-clock time of each click: (click, latency)."""
    ordered = sorted(clicks)
    out: list[tuple[float, float]] = []
    used: set[int] = set()
    for t in sorted(answered):
        i = bisect.bisect_right(ordered, t) - 1
        if i >= 0 and i not in used:
            used.add(i)
            out.append((ordered[i], t - ordered[i]))
    return out


def start_and_end(
    timed: Sequence[tuple[float, float]], t0: float, t1: float
) -> tuple[list[float], list[float]]:
    """The latencies of clicks in the run's first and last window (wall clock
    `t0`..`t1`): LATENCY_WINDOW_MIN minutes, or a quarter of a shorter run."""
    window = min(60 * LATENCY_WINDOW_MIN, (t1 - t0) / 4)
    start = [latency for t, latency in timed if t <= t0 + window]
    end = [latency for t, latency in timed if t >= t1 - window]
    return start, end


@dataclass
class _Soak:
    """What a soak measured, as it goes."""

    pages: int
    page_errors: list[str] = field(default_factory=list)
    server_errors: list[str] = field(default_factory=list)
    reconnect_every: int = 4  # executions between a page closed and a new one opened
    executions: int = 0
    reconnects: int = 0
    reconnect_s: list[float] = field(default_factory=list)  # a new page until usable
    answer_s: list[float] = field(default_factory=list)  # click -> the buttons gone
    clicked_at: list[float] = field(default_factory=list)  # wall clock, to meet stored events
    rss_at: dict[int, float] = field(default_factory=dict)  # minute -> the server's RSS
    rss_end: float = float("nan")
    ended: float | None = None  # monotonic, when the last execution ended
    load_s: float = 0.0  # until every page was up
    t0: float = field(default_factory=time.monotonic)  # the soak's start, once pages are up
    wall0: float = field(default_factory=time.time)  # the same, on the wall clock


def _start_server(data: Path, scenario: str) -> tuple[subprocess.Popen[str], int]:
    """`tandem dashboard` in its own process, once it listens; and its port."""
    port = _port()
    server = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "dashboard", "--port", str(port), "--workers", "1",
         "--data-dir", str(data), "--scenario", scenario],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert server.stdout is not None
    for line in server.stdout:
        if line.startswith("Tandem dashboard on"):
            break
    return server, port


def _watch_errors(server: subprocess.Popen[str], errors: list[str]) -> None:
    """Collects the server's error lines from its stderr, in a thread; and drains
    its stdout, whose pipe would otherwise fill and stall the server in an hour."""

    def watch(stream: Iterable[str], keep: bool) -> None:
        for line in stream:
            if keep and ("Traceback" in line or "Error" in line):
                errors.append(line.strip())

    assert server.stderr is not None and server.stdout is not None
    threading.Thread(target=watch, args=(server.stderr, True), daemon=True).start()
    threading.Thread(target=watch, args=(server.stdout, False), daemon=True).start()


def _sample_rss(soak: _Soak, server_pid: int, done: threading.Event) -> None:
    """The server's RSS at each of RSS_AT_MIN after the start, in a thread."""
    for minute in RSS_AT_MIN:
        if done.wait(max(0.0, soak.t0 + 60 * minute - time.monotonic())):
            return
        soak.rss_at[minute] = rss_mb(server_pid)


def _open_page(browser: Browser, soak: _Soak, port: int, server_pid: int) -> Page:
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    # Five pages of software WebGL on two busy cores answer slowly.
    page.set_default_timeout(180_000)
    page.on("pageerror", lambda err: soak.page_errors.append(str(err)))
    yield_to_server(server_pid)
    page.goto(f"http://127.0.0.1:{port}")
    # Generous: on a loaded 2-core machine a page with the robot's meshes
    # and software WebGL can take minutes to come up.
    page.get_by_role("button", name="Plan", exact=True).wait_for(timeout=600_000)
    return page


def _reconnect(pages: list[Page], browser: Browser, soak: _Soak, port: int, pid: int) -> None:
    """Closes one page (in turn) and opens a new one in its place."""
    t = time.monotonic()
    i = soak.reconnects % len(pages)
    pages[i].close()
    pages[i] = _open_page(browser, soak, port, pid)
    soak.reconnects += 1
    soak.reconnect_s.append(time.monotonic() - t)


def _execute(operator: Page, soak: _Soak) -> bool:
    """Plans and executes once on `operator`, answering every question; False if
    the execution did not end within 5 minutes."""
    operator.get_by_role("button", name="Plan", exact=True).click()
    execute = operator.get_by_role("button", name="Execute plan", exact=True)
    execute.wait_for()
    deadline = time.monotonic() + 120
    while not execute.is_enabled() and time.monotonic() < deadline:
        time.sleep(0.1)
    execute.click()
    soak.executions += 1
    print(f"\rexecution {soak.executions}", end="", file=sys.stderr, flush=True)
    # The log's last line says the session ended (ids count the executions).
    finished = operator.get_by_text(f"Session {soak.executions} ended: ", exact=False)
    stuck = time.monotonic() + 300
    while finished.count() == 0 and time.monotonic() < stuck:
        buttons = operator.get_by_role("button", name=ANSWER)
        if buttons.count() == 0:
            time.sleep(0.05)
            continue
        _answer(operator, buttons.last, soak)
    return finished.count() > 0


def _answer(operator: Page, clicked: Locator, soak: _Soak) -> None:
    """Clicks an answer, and times until the server has removed the question's buttons."""
    from playwright.sync_api import Error as PageError

    try:
        words = clicked.inner_text(timeout=5_000)
    except PageError:
        return  # the buttons went between finding and reading them: look again
    t = time.perf_counter()
    soak.clicked_at.append(time.time())
    try:
        # A DOM click, not a mouse click: Playwright's mouse waits until
        # the button has kept still for two animation frames, and five
        # pages of software WebGL make frames seconds apart. The server's
        # and the page's part of the answer are what is measured.
        clicked.dispatch_event("click", timeout=2_000)
    except PageError:
        soak.clicked_at.pop()
        return  # answered meanwhile (it vanished): look again
    # Answered: the server removes the question's buttons on every page.
    gone = operator.get_by_role("button", name=words, exact=True)
    while gone.count() > 0 and time.perf_counter() - t < 10:
        time.sleep(0.01)
    soak.answer_s.append(time.perf_counter() - t)


def _soak(soak: _Soak, minutes: float, port: int, server_pid: int) -> None:
    """Opens the pages, then has them take turns planning and executing for `minutes`."""
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        pages = [_open_page(browser, soak, port, server_pid) for _ in range(soak.pages)]
        # The clock starts once every page is up: loading is not the soak.
        soak.load_s = time.monotonic() - soak.t0
        soak.t0, soak.wall0 = time.monotonic(), time.time()
        end = soak.t0 + 60 * minutes
        done = threading.Event()
        threading.Thread(target=_sample_rss, args=(soak, server_pid, done), daemon=True).start()
        # Steps keep the default 0.5 s: the pace at which a person would watch.
        while time.monotonic() < end:
            yield_to_server(server_pid)
            if not _execute(pages[soak.executions % len(pages)], soak):
                soak.page_errors.append(f"execution {soak.executions} did not end within 5 minutes")
                break
            if soak.executions % soak.reconnect_every == 0 and time.monotonic() < end:
                _reconnect(pages, browser, soak, port, server_pid)
        done.set()
        soak.ended = time.monotonic()
        soak.rss_end = rss_mb(server_pid)
        browser.close()


def _median_ms(values: Sequence[float]) -> str:
    return f"median {1000 * statistics.median(values or [0]):.0f} ms"


def _rss_rows(soak: _Soak) -> list[tuple[str, ...]]:
    rows: list[tuple[str, ...]] = [
        ("server RSS", f"at {minute} min", f"{rss:.0f} MB", "")
        for minute, rss in sorted(soak.rss_at.items())
    ]
    # The growth that counts: after the fifth minute (the first minutes fill caches).
    base_min = 5 if 5 in soak.rss_at else min(soak.rss_at, default=None)
    base = soak.rss_at.get(base_min, soak.rss_end) if base_min is not None else soak.rss_end
    rows.append(("server RSS", "end", f"{soak.rss_end:.0f} MB",
                 f"growth {soak.rss_end - base:+.1f} MB since {base_min or 0} min"))  # fmt: skip
    return rows


def _table(soak: _Soak, sessions: list[SessionRecord], timed: list[tuple[float, float]]) -> str:
    answer_s, errors = soak.answer_s, soak.page_errors + soak.server_errors
    start, end = start_and_end(timed, soak.wall0, soak.wall0 + 60 * _minutes(soak))
    recorded_s = [latency for _, latency in timed]
    rows: list[tuple[str, ...]] = [
        ("run", f"{soak.pages} pages", f"{_minutes(soak):.1f} min",
         f"pages up in {soak.load_s:.0f} s"),
        ("pages reconnected", f"every {soak.reconnect_every} executions", f"{soak.reconnects}",
         f"new page up {_median_ms(soak.reconnect_s)}"),
        ("executions / sessions stored", "", f"{soak.executions} / {len(sessions)}",
         f"{sum(s.result == 'goal' for s in sessions)} at the goal"),
        ("page errors / server errors", "",
         f"{len(soak.page_errors)} / {len(soak.server_errors)}", "; ".join(errors[:2])[:60]),
        *_rss_rows(soak),
        ("answer click → event stored", f"{len(recorded_s)} clicks", _median_ms(recorded_s),
         f"max {1000 * max(recorded_s or [0]):.0f} ms"),
        ("  at the start", f"{len(start)} clicks", _median_ms(start),
         f"max {1000 * max(start or [0]):.0f} ms"),
        ("  at the end", f"{len(end)} clicks", _median_ms(end),
         f"max {1000 * max(end or [0]):.0f} ms"),
        ("answer click → buttons gone", f"{len(answer_s)} clicks", _median_ms(answer_s),
         f"max {1000 * max(answer_s or [0]):.0f} ms"),
    ]  # fmt: skip
    return format_table(("measure", "on", "result", "spread"), rows)


def _minutes(soak: _Soak) -> float:
    """How long the soak ran, once its pages were up (until the table is made)."""
    if soak.ended is None:
        return (time.monotonic() - soak.t0) / 60
    return (soak.ended - soak.t0) / 60


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.soak")
    parser.add_argument("--pages", type=int, default=5)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--scenario", default="default.toml")
    parser.add_argument(
        "--reconnect-every", type=int, default=4,
        help="executions between a page closed and a new one opened (0: never)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    data = Path(tempfile.mkdtemp(prefix="tandem-soak-"))
    server, port = _start_server(data, args.scenario)
    soak = _Soak(args.pages, reconnect_every=args.reconnect_every or 10**9)
    _watch_errors(server, soak.server_errors)
    try:
        _soak(soak, args.minutes, port, server.pid)
    finally:
        # Also when a page fails: never leave the server running.
        server.send_signal(signal.SIGTERM)
        server.wait(60)
    with SessionStore(data, read_only=True) as store:
        sessions = store.list_sessions()
        answered = sorted(
            e.time for s in sessions for e in store.events(s.id) if e.source == "click"
        )
    shutil.rmtree(data, ignore_errors=True)
    print(_table(soak, sessions, timed_latencies(soak.clicked_at, answered)))
    ok = not soak.page_errors and not soak.server_errors and soak.executions == len(sessions)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
