"""Reviewing stored sessions: list with filters, replay on a timeline, export.

An opened session shows its lanes (timeline_svg.py) under the "Timeline"
slider; the slider, or a click on a bar, moves the tree's selection, the bench,
the camera frame of that step and the transcript together (review_timeline.py
words them), with the session's measures beside (review_metrics.py). Another
session of the same plan can be drawn under it, with where the two parted
(review_compare.py), and a study's table and figure shown (review_study.py); the
opened session downloads as JSON, CSV or MCAP (review_downloads.py).

Drives the dashboard through its `Stage`; refreshes its lists when an execution
finishes (an `ExecutionFinished` event), see stage.py. Every element is made
once and its contents replaced, so a dashboard up all day reviewing session
after session keeps the same page.
"""

from __future__ import annotations

import threading
import time
from datetime import date

import cv2
import numpy as np
import viser

from app.dashboard.lane_marks import legend_html
from app.dashboard.review_compare import CompareView
from app.dashboard.review_downloads import SessionDownloads
from app.dashboard.review_metrics import metrics_markdown
from app.dashboard.review_study import StudyView
from app.dashboard.review_timeline import (
    BRIDGE,
    HIDE_BRIDGE,
    PICTURES,
    SCRIPT_HTML,
    Picture,
    bridged,
    clock_words,
    following,
    lanes_html,
    step_time,
    transcript,
    zoomed,
)
from app.dashboard.stage import Events, ExecutionFinished, ExecutionStarted, Stage
from app.dashboard.timeline_svg import Window, duration, sources
from app.dashboard.tree_svg import Step
from app.dashboard.widgets import show
from app.execution.events import REPAIR, RESULTS, ExecutionEvent
from app.sessions.database import StoreError
from app.sessions.store import SessionRecord, SessionStore, UnknownSession, iso
from planner.plan.model import Plan, PlanFormatError

ANY = "any"
FILTERS = (ANY, *RESULTS)
NONE = "(no sessions)"
LISTED = 200  # sessions offered in the list, newest first
# Plans read back, by hash: a large plan takes seconds to decode and the sessions
# reviewed one after the other often share it; bounded, for a dashboard up all day.
PLANS_KEPT = 4


def session_label(s: SessionRecord) -> str:
    return f"#{s.id} {s.scenario} {s.result or 'running'} {iso(s.started)[:19]}"


class ReviewPanel:
    def __init__(
        self, gui: viser.GuiApi, stage: Stage, events: Events, store: SessionStore
    ) -> None:
        self.stage = stage
        self.store = store
        self._replaying = threading.Event()
        self.events: list[ExecutionEvent] = []
        self.session: SessionRecord | None = None
        self._ids: dict[str, int] = {}
        self.opened: int | None = None  # set once a session is fully on screen
        self.plans: list[Plan] = []  # the plan of each event (repairs change it)
        self._read_plans: dict[str, Plan] = {}  # the last plans read, by hash
        self.shown: Plan | None = None
        self.shown_step = 0
        with gui.add_folder("Review sessions"):
            self._build_list(gui)
            # Steps counted from 1, as the summary and the comparison count them.
            self.timeline: viser.GuiSliderHandle[int] = gui.add_slider(
                "Timeline", 1, 2, 1, 1, disabled=True
            )
            self.timeline.on_update(self._timeline_moved)
            # The lanes under the slider; a click on a bar, a zoom or a pan comes
            # back through the hidden field (review_timeline.py).
            self.lanes = gui.add_html(HIDE_BRIDGE)
            self.bridge: viser.GuiTextHandle = gui.add_text("lanes events", BRIDGE)
            self.bridge.on_update(lambda _: self._bridged(str(self.bridge.value)))
            # The time each picture shows (None: all of it), kept between drawings.
            self.windows: dict[Picture, Window | None] = dict.fromkeys(PICTURES)
            zoom = gui.add_button_group("Zoom lanes", ("All", "In", "Out"))
            zoom.on_click(lambda e: self._zoom(str(e.target.value)))
            # Another session of the plan, drawn under this one's lanes.
            self.compare = CompareView(gui, store, self._compared)
            self.summary = gui.add_markdown("")
            # The frame that decided a camera answer, beside its event.
            self.frame_caption = gui.add_markdown("")
            self.frame: viser.GuiImageHandle = gui.add_image(
                np.zeros((240, 320, 3), np.uint8), format="jpeg", visible=False
            )
            self.metrics = gui.add_markdown("")
            self.replay_button = gui.add_button("Replay")
            self.replay_button.on_click(lambda _: self._replay())
            self.downloads = SessionDownloads(gui, stage, store, lambda: self.session)
        with gui.add_folder("Study", expand_by_default=False):
            self.study = StudyView(gui, store)
        self.executing = False
        self.refresh()
        events.subscribe(ExecutionStarted, lambda _: self._set_executing(True))
        events.subscribe(ExecutionFinished, lambda _: self._set_executing(False))

    def _build_list(self, gui: viser.GuiApi) -> None:
        self.scenario_filter: viser.GuiTextHandle = gui.add_text("Scenario", "")
        self.result_filter: viser.GuiDropdownHandle[str] = gui.add_dropdown("Result", FILTERS)
        self.since_filter: viser.GuiTextHandle = gui.add_text("Since (YYYY-MM-DD)", "")
        gui.add_button("Refresh list").on_click(lambda _: self.refresh())
        self.pick: viser.GuiDropdownHandle[str] = gui.add_dropdown("Session", [NONE])
        self.open_button = gui.add_button("Open session")
        self.open_button.on_click(lambda _: self.open(self.pick.value))

    def _set_executing(self, executing: bool) -> None:
        """A review would replace the tree the execution runs on: not meanwhile."""
        self.executing = executing
        self._replaying.clear()
        for handle in (self.open_button, self.replay_button):
            handle.disabled = executing
        self.timeline.disabled = executing or not self.events
        if not executing:
            self.refresh()

    def refresh(self) -> None:
        since = None
        text = str(self.since_filter.value).strip()
        if text:
            try:
                since = date.fromisoformat(text)
            except ValueError:
                self.summary.content = f"**Error:** {text!r} is not a date (YYYY-MM-DD)."
                return
        result = self.result_filter.value
        try:
            sessions = self.store.list_sessions(
                scenario=str(self.scenario_filter.value).strip() or None,
                result=None if result == ANY else result,
                since=since,
            )
        except StoreError as err:
            self.summary.content = f"**Error:** {err}"
            return
        # Newest first, and only the newest: a study day's hundreds of sessions would
        # make every page carry them all; the filters reach the older ones.
        listed = sessions[::-1][:LISTED]
        self._ids = {session_label(s): s.id for s in listed}
        options = list(self._ids) or [NONE]
        self.pick.options = options
        show(self.pick, options[0])
        full = len(listed) == LISTED
        more = f" The newest {LISTED} are listed: filter for others." if full else ""
        self.summary.content = f"{len(sessions)} session(s).{more}"
        self.study.refresh()

    def label_of(self, session_id: int) -> str | None:
        """The label under which the picker lists `session_id` (None: not listed)."""
        return next((label for label, i in self._ids.items() if i == session_id), None)

    def open(self, label: str) -> None:
        session_id = self._ids.get(label)
        if session_id is None or self.executing:
            return
        try:
            self.session = self.store.get(session_id)
            self.events = self.store.events(session_id)
            plan = self._plan(self.session.plan_hash)
            self.plans = self._plans_of(plan, self.events)
        except (UnknownSession, StoreError, PlanFormatError) as err:
            self.summary.content = f"**Error:** {err}"
            return
        self.shown = plan
        self.stage.show_plan(plan)
        self.timeline.max = max(2, len(self.events))
        self.timeline.disabled = not self.events
        show(self.timeline, 1)
        self.windows = dict.fromkeys(PICTURES)
        self.metrics.content = metrics_markdown(self.events, self.session.clock)
        self.compare.offer(self.session, self.events)
        self.show_step(0)
        self.opened = session_id

    def _plan(self, digest: str) -> Plan:
        plan = self._read_plans.pop(digest, None) or self.store.plan(digest)
        self._read_plans[digest] = plan  # the newest last
        while len(self._read_plans) > PLANS_KEPT:
            del self._read_plans[next(iter(self._read_plans))]
        return plan

    def _plans_of(self, first: Plan, events: list[ExecutionEvent]) -> list[Plan]:
        """The plan each event ran on: the session's, then each repair's new plan
        from the event after the repair on."""
        plans: list[Plan] = []
        current = first
        for event in events:
            plans.append(current)
            replanned = event.evidence.replanned if event.evidence is not None else None
            if event.kind == REPAIR and replanned is not None:
                current = self._plan(replanned.plan)
        return plans

    def _timeline_moved(self, event: viser.GuiEvent[viser.GuiSliderHandle[int]]) -> None:
        # Moves made here (open, replay) show their step themselves.
        if event.client is not None:
            self.show_step(int(self.timeline.value) - 1)

    def _bridged(self, value: str) -> None:
        message = bridged(value)
        if message is None or not self.events or self.executing:
            return
        # Every message says what its picture showed: the next drawing keeps it.
        if message.window is not None:
            total = self._total(message.picture)
            whole = message.window[0] <= 1e-6 and message.window[1] >= total - 1e-6
            self.windows[message.picture] = None if whole else message.window
        if message.what == "step" and message.step is not None and message.picture == "first":
            k = message.step
            self._replaying.clear()  # the user takes over from a replay
            show(self.timeline, min(k, len(self.events) - 1) + 1)
            self.show_step(k)

    def _total(self, picture: Picture) -> float:
        return duration(self.events) if picture == "first" else self.compare.total()

    def _zoom(self, how: str) -> None:
        for picture in PICTURES:
            self.windows[picture] = zoomed(self.windows[picture], self._total(picture), how)
        self._draw_lanes(self.shown_step)

    def _compared(self) -> None:
        self.windows["second"] = None
        self._draw_lanes(self.shown_step)

    def _draw_lanes(self, k: int) -> None:
        """The session's lanes with the cursor at step `k` (kept in the time shown),
        a compared session's under them, and the legend."""
        if not self.events:
            self.lanes.content = HIDE_BRIDGE
            return
        self.windows["first"] = following(self.windows["first"], step_time(self.events, k),
                                          duration(self.events))  # fmt: skip
        first = lanes_html(self.events, k, self.compare.marked, window=self.windows["first"])
        compared = self.compare.other is not None
        marks = sources(self.events) | (sources(self.compare.other_events) if compared else set())
        self.lanes.content = (HIDE_BRIDGE + SCRIPT_HTML + first
                              + self.compare.below(self.windows["second"])
                              + legend_html(marks, compared))  # fmt: skip

    def show_step(self, k: int) -> None:
        if not self.events or self.session is None or self.executing:
            return
        k = min(max(0, k), len(self.events) - 1)
        event = self.events[k]
        if self.plans and self.plans[k] is not self.shown:
            # The execution changed plans here (a repair): so does the review.
            self.shown = self.plans[k]
            self.stage.show_plan(self.shown)
        # The tree marks the path to this step, as it did during the execution.
        steps = tuple(Step(e.node, e.source, e.confidence, e.outcome) for e in self.events[: k + 1])
        self.stage.go_to(event.node, path=steps)
        self._draw_lanes(k)
        s = self.session
        where = (f"**Session #{s.id}** ({s.scenario}, {s.result}): step {k + 1}/"
                 f"{len(self.events)}, {clock_words(self.events, k)}")  # fmt: skip
        self.summary.content = "\n\n".join([where, *transcript(self.events, k)])
        self._show_frame(s.id, event)
        self.shown_step = k  # last: the step is on screen in every part

    def _show_frame(self, session_id: int, event: ExecutionEvent) -> None:
        evidence = event.evidence
        picture = None if evidence is None else self.store.evidence_jpeg(session_id, event.seq)
        image = None
        if picture is not None:
            image = cv2.imdecode(np.frombuffer(picture, np.uint8), cv2.IMREAD_COLOR)
        if image is None or evidence is None:
            self.frame.visible = False
            self.frame_caption.content = ""
            return
        self.frame.image = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
        self.frame.visible = True
        truth = evidence.truth.label if evidence.truth is not None else None
        agrees = (
            ""
            if truth is None
            else (
                f"; the simulated human did **{truth}**"
                + (" (agrees)" if truth == event.outcome else " (**disagrees**)")
            )
        )
        self.frame_caption.content = (
            f"`{event.node}` answered by the {event.source}: **{event.outcome}**{agrees}"
        )

    def _replay(self) -> None:
        def run() -> None:
            for k in range(len(self.events)):
                if not self._replaying.is_set():
                    return  # closed meanwhile
                show(self.timeline, k + 1)
                self.show_step(k)
                time.sleep(0.3)

        self._replaying.set()
        threading.Thread(target=run, name="replay", daemon=True).start()

    def close(self) -> None:
        self._replaying.clear()
