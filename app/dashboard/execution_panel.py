"""Executing the plan from the dashboard: controls, the simulated human, the log.

The executor runs in its own thread with a `ClickSource` that waits for the
"Simulated human" buttons (drawn when the source offers a question: no
polling); each event is stored (committed as it happens), moves the bench to
the node and, for robot actions, plays the arm's path. The panel drives the
dashboard only through its `Stage` and announces starts and ends on `Events`
(see stage.py).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import viser

from app.dashboard.stage import (
    Events,
    ExecutionFinished,
    ExecutionStarted,
    PlanChanged,
    Stage,
)
from app.execution import ExecutionEvent, Executor, Narrator
from app.outcomes import ClickSource, Offer, OutcomeSource
from app.store import SessionStore
from planner.plan import Motion, Plan

# Who answers and who speaks in an execution of a plan, given the clicks to fall
# back on (the speech panel's `responses`); without one the clicks answer, silently.
Responses = Callable[[Plan, ClickSource], tuple[OutcomeSource, Narrator | None]]

FRAMES_PER_MOTION = 20  # arm poses shown per motion (the path is subsampled)
LOG_LINES = 12


class ExecutionPanel:
    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        events: Events,
        store: SessionStore,
        responses: Responses | None = None,
    ) -> None:
        self.gui = gui
        self.responses = responses
        self.stage = stage
        self.events = events
        self.store = store
        self.executor: Executor | None = None
        self.clicks: ClickSource | None = None
        self.session_id: int | None = None
        self._answer_buttons: list[Any] = []
        self._log: list[str] = []
        self._lock = threading.Lock()  # the answer buttons: executor and GUI threads
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
        events.subscribe(PlanChanged, self._plan_changed)

    def _plan_changed(self, message: PlanChanged) -> None:
        ready = message.plan is not None and not message.plan.partial
        self.start_button.disabled = not ready or self.running

    @property
    def running(self) -> bool:
        return self.executor is not None and not self.executor.done

    def start(self) -> None:
        plan = self.stage.current_plan()
        if plan is None or plan.partial or self.running:
            return
        self.clicks = ClickSource(timeout=None, on_offer=self._offered)  # a person answers
        source: OutcomeSource = self.clicks
        narrator: Narrator | None = None
        if self.responses is not None:
            source, narrator = self.responses(plan, self.clicks)
        self.session_id = self.store.start(plan, note="dashboard")
        self._log = []
        self.executor = Executor(
            plan,
            source,
            [self.store.recorder(self.session_id), self._on_event],
            step_delay=float(self.speed.value),
            narrator=narrator,
        )
        self.start_button.disabled = True
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = False
        self.events.publish(ExecutionStarted(self.session_id))
        self.executor.start()
        threading.Thread(target=self._finish, args=(self.executor,), daemon=True).start()

    def _finish(self, executor: Executor) -> None:
        result = executor.wait()
        session_id = self.session_id
        if session_id is not None and result is not None:
            self.store.finish(session_id, result)
        self._clear_answers()
        self._log.append(f"**Session {session_id}: {result}**")
        self.log.content = "\n\n".join(self._log[-LOG_LINES:])
        self.question.content = f"Execution ended: {result}."
        self.start_button.disabled = False
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = True
        if session_id is not None:
            self.events.publish(ExecutionFinished(session_id, str(result)))

    def _pause_resume(self) -> None:
        if self.executor is None:
            return
        if self.executor.paused:
            self.executor.resume()
        else:
            self.executor.pause()

    def _on_event(self, event: ExecutionEvent) -> None:
        # Runs in the executor's thread: a motion takes as long as it is played.
        self.stage.go_to(event.node, show_world=event.motion is None)
        if event.motion:
            self._play(event.motion, float(self.speed.value))
            self.stage.show_world(event.node)
        words = event.text or event.action or ""
        self._log.append(f"`{event.node}` {event.action or 'goal'}: {words}")
        self.log.content = "\n\n".join(self._log[-LOG_LINES:])

    def _play(self, motion: Motion, seconds: float) -> None:
        path = motion.path
        frames = path[:: max(1, len(path) // FRAMES_PER_MOTION)] + [path[-1]]
        arms = self.stage.arms()
        for q in frames:
            arms[motion.arm] = q
            self.stage.show_arms(arms)
            time.sleep(seconds / len(frames))

    # -- the simulated human ----------------------------------------------------------

    def _offered(self, offer: Offer | None) -> None:
        """The click source's callback: a question waits (buttons), or it was answered."""
        self._clear_answers()
        if offer is None:
            return
        with self._lock:
            self.question.content = f"**{offer.action}**: what does the human do?"
            with self.human_folder:
                for label, words in zip(offer.options, offer.words, strict=True):
                    button = self.gui.add_button(words)
                    button.on_click(self._answer(offer.node_id, label))
                    self._answer_buttons.append(button)

    def _answer(self, node_id: str, label: str) -> Any:
        def handler(_: Any) -> None:
            if self.clicks is not None:
                self.clicks.click(label, node_id)

        return handler

    def _clear_answers(self) -> None:
        with self._lock:
            for button in self._answer_buttons:
                button.remove()
            self._answer_buttons = []
            if self.running:
                self.question.content = "No question waiting."

    def close(self) -> None:
        if self.executor is not None:
            self.executor.abort()
            self.executor.wait(5.0)
