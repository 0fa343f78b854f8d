"""The dashboard as a program left running: `tandem dashboard` in its own process.

Two real browser pages: the one that starts an execution is its operator;
the other page watches it live but cannot answer, pause, abort, plan or open.
Then SIGTERM ends the running session as interrupted with every event kept.
Also: a taken port and a non-loopback host without --allow-remote exit 2.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page, expect  # noqa: E402

from app.execution.walker import INTERRUPTED  # noqa: E402
from app.sessions.store import SessionStore  # noqa: E402
from tests.plan_fixtures import ROOT, tandem_command  # noqa: E402
from tests.test_dashboard import free_port, wait_for  # noqa: E402, F401

REFUSED = "Only the operator can do that"


@dataclass
class Running:
    process: subprocess.Popen[str]
    url: str
    data: Path


@pytest.fixture(scope="module")
def running(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Running]:
    data = tmp_path_factory.mktemp("data")
    port = free_port()
    process = subprocess.Popen(
        [*tandem_command(), "dashboard", "--port", str(port), "--workers", "1",
         "--data-dir", str(data)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert f"http://127.0.0.1:{port}" in announced(process)
    yield Running(process, f"http://127.0.0.1:{port}", data)
    if process.poll() is None:
        process.kill()
    process.wait(10)


def announced(process: subprocess.Popen[str]) -> str:
    """The dashboard's own address line (viser prints its banner first)."""
    assert process.stdout is not None
    for line in process.stdout:
        if line.startswith("Tandem dashboard on"):
            return line
    raise AssertionError(f"the dashboard ended: {process.wait()}")


def open_page(chromium: Browser, url: str) -> Page:
    page = chromium.new_page(viewport={"width": 1400, "height": 900})
    page.goto(url)
    page.get_by_role("button", name="Plan", exact=True).wait_for(timeout=60_000)
    return page


def button(page: Page, name: str) -> object:
    return page.get_by_role("button", name=name, exact=True)


def log_text(page: Page) -> str:
    return page.locator("body").inner_text()


def test_one_operator_many_observers_then_sigterm(browser: Browser, running: Running) -> None:
    operator = open_page(browser, running.url)
    observer = open_page(browser, running.url)
    # Chromium draws a page in the background only now and then (the observer's
    # opened last): a click there can wait past its timeout to scroll. Each page
    # is brought to the front before it is used, as a person would.
    operator.bring_to_front()
    operator.get_by_role("button", name="Plan", exact=True).click()
    execute = operator.get_by_role("button", name="Execute plan", exact=True)
    expect(execute).to_be_enabled(timeout=120_000)
    execute.click()
    # The first question of the default plan: is the human holding a part?
    question = "Human holds a part"
    expect(observer.get_by_role("button", name=question, exact=True)).to_be_visible(timeout=60_000)
    # Locked for everyone while it runs: nobody replaces the plan under the robot.
    observer.bring_to_front()
    observer.get_by_role("tab", name="Review").click()  # behind the Execution tab
    for page, names in ((operator, ()), (observer, ("Open session", "Replay"))):
        for name in ("Plan", "Open file", "Save", *names):
            expect(page.get_by_role("button", name=name, exact=True)).to_be_disabled()
    observer.get_by_role("tab", name="Execution").click()
    # The observer's answer, pause and abort are refused on its page only, each
    # saying what it could not do; the notices then close by themselves.
    for name, what in (
        (question, "answer"),
        ("Pause", "pause or resume"),
        ("Abort", "abort"),
    ):
        observer.get_by_role("button", name=name, exact=True).click()
        expect(observer.get_by_text(f"only it can {what}.")).to_be_visible(timeout=10_000)
    assert observer.get_by_text(REFUSED).count() == 3
    observer.get_by_text(REFUSED).first.wait_for(state="detached", timeout=15_000)
    assert operator.get_by_text(REFUSED).count() == 0
    # The question is still waiting: nothing the observer did reached the executor.
    expect(operator.get_by_role("button", name=question, exact=True)).to_be_visible()
    with SessionStore(running.data, read_only=True) as store:
        (session,) = store.list_sessions()
        before = store.events(session.id)
    assert session.result is None and all(e.outcome is None for e in before)
    # The operator answers; the observer sees it happen.
    operator.bring_to_front()
    operator.get_by_role("button", name=question, exact=True).click()
    expect(observer.get_by_text("Human holds a part", exact=False).first).to_be_visible()
    wait_for(lambda: "sense(humanHolding)" in log_text(observer), 30)
    # The next question waits; the server is told to stop.
    wait_for(lambda: observer.get_by_role("button", name="Human holds leg2").count() > 0, 60)
    running.process.send_signal(signal.SIGTERM)
    assert running.process.wait(30) == 0
    with SessionStore(running.data, read_only=True) as store:
        (session,) = store.list_sessions()
        events = store.events(session.id)
    assert session.result == INTERRUPTED and session.ended is not None
    last = events[-1]
    assert last.kind == INTERRUPTED and "SIGTERM" in (last.text or "")
    answered = [e for e in events if e.outcome is not None]
    assert [e.outcome for e in answered][:1] == ["yes"] and answered[0].source == "click"
    assert [e.seq for e in events] == list(range(len(events)))
    operator.close()
    observer.close()


def test_a_taken_port_exits_2() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = subprocess.run(
            [*tandem_command(), "dashboard", "--port", str(port)],
            cwd=ROOT, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
    assert result.returncode == 2, result
    assert result.stderr.strip().splitlines() == [
        f"dashboard: cannot listen on 127.0.0.1:{port}: port {port} is in use"
    ]


def test_a_remote_host_needs_allow_remote() -> None:
    result = subprocess.run(
        [*tandem_command(), "dashboard", "--host", "0.0.0.0", "--port", str(free_port())],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode == 2 and "--allow-remote" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_mesh_detail_outside_zero_to_one_is_refused() -> None:
    for bad in ("0", "1.5", "fine"):
        result = subprocess.run(
            [*tandem_command(), "dashboard", "--mesh-detail", bad, "--port", str(free_port())],
            cwd=ROOT, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        assert result.returncode == 2, result
        assert "argument --mesh-detail:" in result.stderr.strip().splitlines()[-1]


def test_sigint_without_an_execution_stops_cleanly(tmp_path: Path) -> None:
    port = free_port()
    process = subprocess.Popen(
        [*tandem_command(), "dashboard", "--port", str(port), "--data-dir", str(tmp_path)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ},
    )  # fmt: skip
    assert f":{port}" in announced(process)
    time.sleep(0.5)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 0 and "Traceback" not in err
