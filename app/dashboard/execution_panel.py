"""Executing the plan from the dashboard: controls, the simulated human, the log.

The executor runs in its own thread with a `ClickSource` that waits for the
"Simulated human" buttons; each event is stored (committed as it happens), moves
the bench to the node and, for robot actions, plays the arm's path.
"""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING, Any

from app.execution import ExecutionEvent, Executor
from app.outcomes import ClickSource, Offer
from app.store import SessionStore

if TYPE_CHECKING:
    from app.dashboard.server import Dashboard

POLL_S = 0.1  # how often the panel looks for a question waiting for a click
FRAMES_PER_MOTION = 20  # arm poses shown per motion (the path is subsampled)


class ExecutionPanel:
    def __init__(self, dashboard: Dashboard, store: SessionStore) -> None:
        self.dashboard = dashboard
        self.store = store
        self.executor: Executor | None = None
        self.clicks: ClickSource | None = None
        self.session_id: int | None = None
        self._offer: Offer | None = None
        self._answer_buttons: list[Any] = []
        self._log: list[str] = []
        gui = dashboard.server.gui
        with gui.add_folder("Execute"):
            self.start_button = gui.add_button("Execute plan", disabled=True)
            self.start_button.on_click(lambda _: self.start())
            self.pause_button = gui.add_button("Pause / resume", disabled=True)
            self.pause_button.on_click(lambda _: self._pause_resume())
            self.step_button = gui.add_button("Step", disabled=True)
            self.step_button.on_click(lambda _: self.executor.step() if self.executor else None)
            self.abort_button = gui.add_button("Abort", disabled=True)
            self.abort_button.on_click(lambda _: self.executor.abort() if self.executor else None)
            self.speed: Any = gui.add_slider("Seconds per step", 0.0, 3.0, 0.1, 0.5)
            self.human_folder = gui.add_folder("Simulated human")
            with self.human_folder:
                self.question = gui.add_markdown("No question yet.")
            self.log = gui.add_markdown("")
        threading.Thread(target=self._watch_offers, name="offers", daemon=True).start()

    def plan_ready(self, ready: bool) -> None:
        self.start_button.disabled = not ready or self.running

    @property
    def running(self) -> bool:
        return self.executor is not None and not self.executor.done

    def start(self) -> None:
        doc = self.dashboard.doc
        if doc is None or "stats" not in doc or self.running:
            return
        self.clicks = ClickSource(timeout=None)  # a person answers; no timeout
        self.session_id = self.store.start(doc, note="dashboard")
        self._log = []
        self.executor = Executor(
            doc,
            self.clicks,
            [self.store.recorder(self.session_id), self._on_event],
            step_delay=float(self.speed.value),
        )
        self.start_button.disabled = True
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = False
        self.executor.start()
        threading.Thread(target=self._finish, args=(self.executor,), daemon=True).start()

    def _finish(self, executor: Executor) -> None:
        result = executor.wait()
        if self.session_id is not None and result is not None:
            self.store.finish(self.session_id, result)
        self._log.append(f"**Session {self.session_id}: {result}**")
        self.log.content = "\n\n".join(self._log[-12:])
        self.question.content = f"Execution ended: {result}."
        self._clear_answers()
        self.start_button.disabled = False
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = True
        self.dashboard.review.refresh()

    def _pause_resume(self) -> None:
        if self.executor is None:
            return
        if self.executor.paused:
            self.executor.resume()
        else:
            self.executor.pause()

    def _on_event(self, event: ExecutionEvent) -> None:
        # Runs in the executor's thread: a motion takes as long as it is played.
        self.dashboard.tree.expand_to(event.node)
        self.dashboard.select(event.node, show_world=event.motion is None)
        if event.motion:
            self._play(event.motion, float(self.speed.value))
            self.dashboard.show_world(event.node)
        words = event.text or event.action or ""
        self._log.append(f"`{event.node}` {event.action or 'goal'}: {words}")
        self.log.content = "\n\n".join(self._log[-12:])

    def _play(self, motion: Any, seconds: float) -> None:
        path = motion["path"]
        frames = path[:: max(1, len(path) // FRAMES_PER_MOTION)] + [path[-1]]
        arms = dict(self.dashboard.current_arms)
        for q in frames:
            arms[motion["arm"]] = q
            self.dashboard.bench.show_arms(arms)
            time.sleep(seconds / len(frames))

    # -- the simulated human ----------------------------------------------------------

    def _watch_offers(self) -> None:
        while True:
            time.sleep(POLL_S)
            clicks = self.clicks
            offer = clicks.pending() if clicks is not None and self.running else None
            if offer == self._offer:
                continue
            self._offer = offer
            self._clear_answers()
            if offer is None:
                continue
            self.question.content = f"**{offer.action}**: what does the human do?"
            with self.human_folder:
                for label, words in zip(offer.options, offer.words, strict=True):
                    button = self.dashboard.server.gui.add_button(words)
                    button.on_click(self._answer(offer.node_id, label))
                    self._answer_buttons.append(button)

    def _answer(self, node_id: str, label: str) -> Any:
        def handler(_: Any) -> None:
            if self.clicks is not None:
                self.clicks.click(label, node_id)

        return handler

    def _clear_answers(self) -> None:
        for button in self._answer_buttons:
            button.remove()
        self._answer_buttons = []
        self.question.content = "No question waiting."
