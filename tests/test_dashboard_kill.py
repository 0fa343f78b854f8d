"""SIGKILL the dashboard server in the middle of a session: nothing committed is lost,
and after a restart the session is listed as interrupted and can be reviewed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser  # noqa: E402

from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from app.sessions.store import SessionStore  # noqa: E402
from tests.test_dashboard import free_port, wait_for  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def test_killed_server_keeps_events_and_the_session_is_reviewed(
    browser: Browser, tmp_path: Path
) -> None:
    data = tmp_path / "data"
    port = free_port()
    server = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "dashboard", "--port", str(port),
         "--data-dir", str(data), "--workers", "1"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        assert server.stdout is not None
        lines = []
        while not any("Tandem dashboard on http://127.0.0.1" in line for line in lines):
            lines.append(server.stdout.readline())
            assert lines[-1] or server.poll() is None, "".join(lines)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        try:
            page.goto(f"http://127.0.0.1:{port}")
            page.get_by_role("button", name="Plan", exact=True).click()
            page.get_by_role("button", name="Execute plan", exact=True).wait_for()
            wait_for(lambda: page.get_by_text("planned in").count() > 0, 120)
            page.get_by_role("button", name="Execute plan", exact=True).click()
            # The first question waits for the simulated human; the steps before it
            # are stored by then.
            page.get_by_text("what does the human do?").wait_for(timeout=60_000)
            with SessionStore(data) as store:
                sessions = store.list_sessions()
                assert len(sessions) == 1 and sessions[0].result is None
                before = store.events(sessions[0].id)
            assert len(before) >= 3
            os.kill(server.pid, signal.SIGKILL)
            server.wait(timeout=10)
        finally:
            page.close()
    finally:
        if server.poll() is None:
            server.kill()
    with SessionStore(data) as store:
        session = store.list_sessions()[0]
        assert session.result == "interrupted"
        assert store.events(session.id) == before
    # A restarted dashboard lists it and replays it.
    dashboard = Dashboard(
        "127.0.0.1",
        free_port(),
        "default.toml",
        DashboardSettings(data_dir=str(data), load_models=False),
    )
    try:
        label = dashboard.review.label_of(session.id)
        assert label is not None and "interrupted" in label
        assert dashboard.review.pick.options == (label,)  # the one session, listed
        dashboard.review.open(label)
        dashboard.review.show_step(len(before) - 1)
        assert dashboard.selected == before[-1].node
    finally:
        dashboard.close()
