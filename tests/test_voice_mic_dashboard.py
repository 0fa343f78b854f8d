"""The dashboard's "microphone" answers through the virtual microphone, in a real browser.

The dashboard plays the robot's lines on this machine (`speak="local"`), into
the virtual device whose monitor is the microphone (`tests.audio_device`), so
the ear hears the robot as in a room. The test is the person: once the panel
shows it listens, it says "yes" into the device. After the first answer heard
the device is unplugged: the panel says in one line that the voice has ended,
the clicks answer the rest, and the session is stored.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard, DashboardSettings  # noqa: E402
from app.execution.events import ExecutionEvent  # noqa: E402
from app.execution.walker import Executor  # noqa: E402
from app.sessions.store import SessionStore  # noqa: E402
from tests.audio_device import SoundServer, microphone, sound_server  # noqa: E402, F401
from tests.plan_fixtures import ROOT  # noqa: E402
from tests.test_dashboard import free_port, open_page, shot, wait_for  # noqa: E402
from tests.test_dashboard_speech import answer_by, planned_and_executing  # noqa: E402
from tests.test_voice_mic import spoken  # noqa: E402

ENGLISH_DEFAULT = ROOT / "static" / "scenarios" / "default.toml"


def _click_pending(page: Page, dashboard: Dashboard, clicked: list[str]) -> None:
    """Clicks a choice of whatever waits for a click: "yes" at the first sensing (the
    human holds a part: the path with two questions), else the first choice."""
    clicks = dashboard.execution.clicks
    offer = clicks.pending() if clicks is not None else None
    if offer is None:
        return
    first = not clicked or clicked[0] == offer.node_id
    label = "yes" if first and "yes" in offer.options else offer.options[0]
    try:
        words = offer.words[offer.options.index(label)]
        page.get_by_role("button", name=words, exact=True).click(timeout=3000)
    except Exception:
        return  # the buttons were redrawn meanwhile: look again
    clicked.append(offer.node_id)


def _question_pending(dashboard: Dashboard) -> bool:
    """Whether a question (a communication node, the voice's to answer) waits."""
    clicks = dashboard.execution.clicks
    offer = clicks.pending() if clicks is not None else None
    plan = dashboard.execution.stage.current_plan()
    if offer is None or plan is None:
        return False
    return plan.nodes[offer.node_id].kind == "communication"


def _no_voice_in_the_wait_line(dashboard: Dashboard) -> int:
    """A question waiting for a click once the voice has ended: its wait line names the
    click alone, never "the voice is listening" (1; 0 when no question waits)."""
    clicks = dashboard.execution.clicks
    offer = clicks.pending() if clicks is not None else None
    plan = dashboard.execution.stage.current_plan()
    if offer is None or plan is None or plan.nodes[offer.node_id].kind != "communication":
        return 0
    waiting = dashboard.execution.waiting
    wait_for(lambda: offer.node_id in waiting.content, 5)
    line = waiting.content.lower()
    assert "voice" not in line and "a click answers" in line, waiting.content
    return 1


def _robot_quiet(device: SoundServer) -> bool:
    return not device.pactl("list", "short", "sink-inputs").strip()


def test_the_dashboards_microphone_hears_answers_and_survives_an_unplugged_device(
    browser: Browser,
    microphone: SoundServer,  # noqa: F811 (the fixture imported above)
    tmp_path: Path,
) -> None:
    settings = DashboardSettings(workers=1, cache_dir=str(tmp_path / "cache"),
                                 data_dir=str(tmp_path / "data"), load_models=False,
                                 speak="local")  # fmt: skip
    dashboard = Dashboard("127.0.0.1", free_port(), str(ENGLISH_DEFAULT), settings)
    page = open_page(browser, dashboard, "Answers by", height=1000)
    try:
        answer_by(page, dashboard, "microphone")
        executor = planned_and_executing(page, dashboard)
        assert microphone.recording_streams(), "the microphone opens with the execution"
        speech = dashboard.speech
        unplugged, was_listening = False, False
        clicked: list[str] = []
        lines_checked = 0
        deadline = time.monotonic() + 240
        while not executor.done and time.monotonic() < deadline:
            listening = "Listening" in speech.listening.content
            if not unplugged and listening and not was_listening:  # asked: answer
                wait_for(lambda: _robot_quiet(microphone), 20)
                time.sleep(0.4)
                microphone.play(spoken("yes"), "yes").wait(10)
            was_listening = listening
            if not unplugged and any(e.source == "voice" for e in _asked(executor)):
                microphone.unplug()
                unplugged = True
                page.get_by_text("The voice has ended", exact=False).first.wait_for()
                shot(page, "speech-microphone-ended")
            if unplugged:
                lines_checked += _no_voice_in_the_wait_line(dashboard)
            # Before the unplug a question is the voice's, though its buttons are drawn
            # a moment before the panel says "Listening": only what the voice does not
            # answer is clicked (a click there once took the first question).
            if unplugged or not (listening or _question_pending(dashboard)):
                _click_pending(page, dashboard, clicked)
            time.sleep(0.05)
        assert executor.result == "goal", executor.events
    finally:
        page.close()
        dashboard.close()
    asked = _asked(executor)
    assert asked[0].source == "voice" and asked[0].outcome == "yes", executor.events
    assert lines_checked, ("no question waited for a click after the device went away",
                           executor.events)  # fmt: skip
    assert asked[1:] and all(e.source == "click" for e in asked[1:]), [e.source for e in asked]
    assert "\n" not in speech.heard.content and "The voice has ended" in speech.heard.content
    assert not microphone.recording_streams(), "the device is released"
    session_id = dashboard.execution.session_id
    assert session_id is not None
    with SessionStore(tmp_path / "data") as store:
        record = store.get(session_id)
        events = store.events(session_id)
    assert record.result == "goal"
    assert any(e.kind == "fell-back" and "the voice has ended" in (e.text or "") for e in events)
    assert any(e.kind == "own-voice" for e in events), "the robot's voice reached the microphone"


def _asked(executor: Executor) -> list[ExecutionEvent]:
    return [e for e in executor.events if e.kind == "communication" and e.outcome]
