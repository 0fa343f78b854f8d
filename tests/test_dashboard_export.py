"""A session run in the dashboard downloads from the review as JSON, CSV and MCAP, and
its MCAP file is true to time: each motion's joint states run from the motion's
stored start to its stored end.

The default plan runs in headless chromium, answered by clicks on the simulated
human's buttons at 0.5 seconds per step on the wall clock (the arm's animation
is the motion's player). The review's links are clicked as a user would; the
files the browser saves are read with the `mcap` reader and its ROS 2 decoder,
Python's csv and json.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from app.execution.events import ExecutionEvent  # noqa: E402
from app.execution.timing import segment_seconds  # noqa: E402
from app.sessions.export import CSV_COLUMNS  # noqa: E402
from app.sessions.mcap_export import SessionRun  # noqa: E402
from tests.test_dashboard import (  # noqa: E402
    opened,
    run_by_clicks,
    served,
    shot,
)
from tests.test_dashboard_review import open_session  # noqa: E402

SECONDS_PER_STEP = 0.5
# How far a motion's first and last joint states may lie from its stored start and
# end: the file's nanoseconds round epoch seconds.
SPAN_TOLERANCE_NS = 2_000_000


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(tmp_path_factory.mktemp("data")) as d:
        yield d


def downloaded(page: Page, button: str, name: str, folder: Path) -> Path:
    """Clicks `button`, then the link the page shows for the file, as a user would; the
    file the browser saved (its name checked whole)."""
    page.get_by_role("button", name=button, exact=True).click()
    link = page.locator(f'a[download="{name}"]')
    link.wait_for(timeout=60_000)
    assert link.inner_text().startswith(f"{name} (")  # the name, then the file's size
    # ... shown whole: the label is not cut where the notification ends.
    label = link.locator(".mantine-Button-label")
    assert label.evaluate("l => l.scrollWidth <= l.clientWidth && l.scrollHeight <= l.clientHeight")
    with page.expect_download() as started:
        link.click()
    download = started.value
    assert download.suggested_filename == name
    path = folder / download.suggested_filename
    download.save_as(path)
    return path


def joint_states(path: Path) -> tuple[list[tuple[int, Any]], dict[str, list[Any]]]:
    """The file's joint states (log time in ns, message) in time order, and every
    other topic's messages."""
    states: list[tuple[int, Any]] = []
    others: dict[str, list[Any]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            if channel.topic == "/joint_states":
                states.append((message.log_time, decoded))
            else:
                others.setdefault(channel.topic, []).append(decoded)
    return states, others


def check_motions_span_their_times(run: SessionRun, states: list[tuple[int, Any]]) -> int:
    """Each motion's joint states, in time order, from its stored start to its end,
    spaced as its segments' durations; the number of motions."""
    along = iter(states)
    motions = 0
    for k, event in enumerate(run.events):
        motion = run.motion(k)
        if motion is None or not motion.path:
            continue
        assert event.start is not None and event.end is not None and event.end > event.start
        mine = [next(along) for _ in motion.path]
        assert [list(m.position) for _, m in mine] == motion.path
        times = [t for t, _ in mine]
        assert abs(times[0] - event.start * 1e9) <= SPAN_TOLERANCE_NS, event
        assert abs(times[-1] - event.end * 1e9) <= SPAN_TOLERANCE_NS, event
        assert all(a < b for a, b in zip(times, times[1:], strict=False)), event
        # Each gap is its segment's share of the motion's stored time.
        segments = segment_seconds(motion.joints, motion.path)
        share = (event.end - event.start) / sum(segments)
        gaps = [(b - a) / 1e9 for a, b in zip(times, times[1:], strict=False)]
        assert gaps == pytest.approx([s * share for s in segments], abs=1e-6)
        motions += 1
    assert next(along, None) is None  # no joint state outside a motion
    return motions


def check_csv_and_json(events: list[ExecutionEvent], csv_path: Path, json_path: Path) -> None:
    with csv_path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == CSV_COLUMNS and len(rows) == len(events)
    for row, event in zip(rows, events, strict=True):
        assert (int(row["seq"]), row["node"], row["kind"]) == (event.seq, event.node, event.kind)
        assert float(row["start"]) == event.start and float(row["end"]) == event.end
    doc = json.loads(json_path.read_text(encoding="utf-8"))
    assert doc["format"] == "tandem-session/2"
    assert [e["seq"] for e in doc["events"]] == [e.seq for e in events]


def test_a_clicked_session_downloads_whole_and_true_to_time(
    browser: Browser,
    dashboard: Dashboard,
    tmp_path: Path,
) -> None:
    with opened(browser, dashboard) as page:
        session_id = run_by_clicks(page, dashboard, SECONDS_PER_STEP)
        page.get_by_role("tab", name="Review").click()
        open_session(page, dashboard, session_id)
        files = {
            kind: downloaded(
                page, f"Export {kind.upper()}", f"tandem-session-{session_id}.{kind}", tmp_path
            )
            for kind in ("mcap", "csv", "json")
        }
        page.get_by_role("button", name="Export MCAP", exact=True).scroll_into_view_if_needed()
        shot(page, "review-downloads")
    store = dashboard.store
    assert store.get(session_id).clock == "wall"
    run = SessionRun.load(store, session_id)
    states, others = joint_states(files["mcap"])
    assert check_motions_span_their_times(run, states) > 3
    # The robot's URDF (Baxter's) and its base, once each, and a part pose per step.
    ((description,),) = [others["/robot_description"]]
    assert ElementTree.fromstring(description.data).get("name") == "baxter"
    ((static,),) = [others["/tf_static"]]
    assert [t.child_frame_id for t in static.transforms] == ["base"]
    assert others["/tf"] and others["/rosout"]
    check_csv_and_json(run.events, files["csv"], files["json"])
