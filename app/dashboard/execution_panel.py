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
from typing import Protocol

import viser

from app.dashboard.log_lines import sentence
from app.dashboard.operator import Click, Operator, refuse
from app.dashboard.stage import (
    CameraAnswers,
    CameraChanged,
    CameraSeen,
    Events,
    ExecutionFinished,
    ExecutionStarted,
    PlanChanged,
    Stage,
)
from app.dashboard.tree_svg import Step, strip_svg
from app.dashboard.wait_words import CameraNews, Waiting, wait_line
from app.execution.events import REPAIR, ExecutionEvent, OutcomeSource, is_step
from app.execution.robot_drive import RobotDriver, ToStart
from app.execution.timing import WallTimeline
from app.execution.walker import Executor, Listener, Narrator
from app.runner.session import Answering, Running, SessionRunner, StoredSession
from app.sessions.database import StoreError
from app.sessions.store import SessionStore
from app.sources.outcomes import ClickSource, FallbackSource, Offer
from planner.plan.model import Motion, Plan, PlanNode
from planner.vocabulary import SenseLengthOf, SenseShapeOf

# Who answers and who speaks in an execution of a plan, given the clicks to fall
# back on (the speech panel's `responses`); without one the clicks answer, silently.
Responses = Callable[[Plan, ClickSource], tuple[OutcomeSource, Narrator | None]]


class RobotChoice(Protocol):
    """Who makes the motions (the robot panel): a driver per execution, or None
    (drawn only); `give_up` answers a fault's question when the run is aborted."""

    def driver(self, to_start: ToStart | None) -> RobotDriver | None: ...

    def give_up(self) -> None: ...


FRAMES_PER_MOTION = 20  # arm poses shown per motion (the path is subsampled)
LOG_LINES = 12  # the page keeps these; the session store keeps every event
IDLE = "**Ready.** Plan, then press **Execute plan**."
TICK_S = 0.5  # how often a waiting question's line is said again


class ExecutionPanel:
    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        events: Events,
        store: SessionStore,
        operator: Operator,
        responses: Responses | None = None,
        robot: RobotChoice | None = None,
    ) -> None:
        self.gui = gui
        self.responses = responses
        self.robot = robot
        self.stage = stage
        self.events = events
        self.store = store
        self.operator = operator
        self.refusal = ""  # why executions cannot start (a store that cannot be written)
        self._finisher: threading.Thread | None = None
        self.executor: Executor | None = None
        self.clicks: ClickSource | None = None
        self.session: StoredSession | None = None  # the last execution's
        self.camera: CameraAnswers | None = None  # when set, it answers sensing nodes
        self._answer_buttons: list[viser.GuiButtonHandle] = []
        self._preparing = False
        self._log: list[str] = []
        self._lock = threading.Lock()  # the answer buttons: executor and GUI threads
        self._steps: list[Step] = []
        self.status = gui.add_markdown(IDLE)
        self.waiting = gui.add_markdown("")  # a question waiting: how long, who does what
        self._seen: tuple[CameraSeen, float] | None = None  # the camera's last view, when
        self._voice = False  # the voice answers this execution's questions
        self._heard: str | None = None  # the voice's last turn in the current wait
        self.start_button = gui.add_button("Execute plan", disabled=True, color="green")
        self.start_button.on_click(lambda e: self.start(e.client_id, e.client))
        only = operator.only
        self.pause_button = gui.add_button("Pause", disabled=True)
        self.pause_button.on_click(only("pause or resume", lambda _: self._pause_resume()))
        self.step_button = gui.add_button("Step", disabled=True)
        self.step_button.on_click(
            only("step", lambda _: self.executor.step() if self.executor else None)
        )
        self.abort_button = gui.add_button("Abort", disabled=True, color="red")
        self.abort_button.on_click(only("abort", lambda _: self._abort()))
        self.notice = gui.add_markdown("")
        self.human_folder = gui.add_folder("Simulated human")
        with self.human_folder:
            self.question = gui.add_markdown("No question yet.")
        self.strip = gui.add_html("")
        self.log = gui.add_markdown("")
        self.speed: viser.GuiSliderHandle[float] = gui.add_slider(
            "Seconds per step", 0.0, 3.0, 0.1, 0.5
        )
        events.subscribe(PlanChanged, self._plan_changed)
        events.subscribe(CameraChanged, self._camera_changed)
        events.subscribe(CameraSeen, lambda m: setattr(self, "_seen", (m, time.monotonic())))

    def _camera_changed(self, message: CameraChanged) -> None:
        self.camera = message.camera  # taken by the next execution

    def _plan_changed(self, message: PlanChanged) -> None:
        ready = message.plan is not None and not message.plan.partial
        self.start_button.disabled = not ready or self.running or bool(self.refusal)
        if message.plan is None and not self.running:
            # Another scenario, or planning again: the last run's lines go.
            self._log, self._steps = [], []
            self.log.content = self.strip.content = ""
            self.question.content = "No question yet."
            if not self.refusal:
                self.status.content = IDLE

    def refuse_executions(self, reason: str) -> None:
        """No execution may start (it could not be recorded); `reason` is shown."""
        self.refusal = reason
        self.start_button.disabled = True
        self.notice.content = f"**Execution disabled:** {reason}"

    @property
    def running(self) -> bool:
        return self.executor is not None and not self.executor.done

    @property
    def session_id(self) -> int | None:
        """The stored session of the last execution started (None: none yet)."""
        return self.session.id if self.session is not None else None

    @property
    def preparing(self) -> bool:
        """Between a start and its execution running (or refused)."""
        return self._preparing

    def start(self, client_id: int | None = None, client: viser.ClientHandle | None = None) -> None:
        """Starts executing the shown plan, driven by page `client_id` (None: the server).
        Preparing (the voice, the camera, the repairer) runs in its own thread, so
        the page says so at once."""
        plan = self.stage.current_plan()
        if plan is None or plan.partial or self.running or self.refusal or self._preparing:
            return
        self._preparing = True
        self.start_button.disabled = True
        self.status.content = "**Preparing the execution…** (voice, camera, motions)"
        self.operator.take(client_id)
        threading.Thread(
            target=self._prepare, args=(plan, client), name="prepare-execution", daemon=True
        ).start()

    def _prepare(self, plan: Plan, client: viser.ClientHandle | None) -> None:
        try:
            self._launch(plan, client)
        finally:
            self._preparing = False
            if not self.running:
                self.operator.release()
                self.start_button.disabled = bool(self.refusal)
                if self.status.content.startswith("**Preparing"):
                    self.status.content = IDLE

    def _launch(self, plan: Plan, client: viser.ClientHandle | None) -> None:
        clicks = ClickSource(timeout=None, on_offer=self._offered)  # a person answers
        source: OutcomeSource = clicks
        narrator: Narrator | None = None
        if self.responses is not None:
            # The voice answers the questions (falling back to the clicks) and speaks.
            source, narrator = self.responses(plan, clicks)
        self._voice = source is not clicks
        listeners: list[Listener] = []
        note = "dashboard"
        if self.camera is not None:
            # The camera answers sensing nodes; a click says what the simulated human
            # does (the camera then sees it), and answers what the camera cannot. What
            # it sees that no branch expects is a surprise: the repairer plans again.
            camera, listeners = self.camera.for_execution(plan, clicks)
            source = FallbackSource(camera, source)
            note = f"dashboard, camera {self.camera.name}"
        runner = SessionRunner(plan, self.stage.current_scenario())
        try:
            # Refuse rather than run unrecorded: the session row is written first.
            session = StoredSession(self.store, runner, note=note, clock="wall")
        except StoreError as err:
            self.refuse_executions(str(err))
            refuse(client, str(err))
            return
        self.session = session
        self.clicks = clicks
        self._log, self._steps = [], []
        self.log.content = ""
        running = Running(
            # A person watches and answers: every step takes its real time, a drawn
            # motion as long as its animation plays.
            WallTimeline(),
            self.robot.driver(runner.to_start) if self.robot is not None else None,
            step_delay=float(self.speed.value),
            player=self._play_motion,
        )
        answering = Answering(source, narrator, listeners)
        self.executor = session.executor(answering, [self._on_event], running)
        clicks.slots = self.executor  # a humanAttachingWhere offers every free slot
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = False
        self.notice.content = ""
        self.status.content = f"**Running** session {session.id}."
        self.events.publish(ExecutionStarted(session.id))
        self.executor.start()
        self._finisher = threading.Thread(target=self._finish, args=(self.executor,), daemon=True)
        self._finisher.start()
        threading.Thread(target=self._tick, args=(self.executor,), name="execution-waits",
                         daemon=True).start()  # fmt: skip

    def _finish(self, executor: Executor) -> None:
        executor.wait()
        result = executor.result
        if executor.error is not None:
            # A write that failed mid-session stops it; what was committed stays.
            result = "interrupted"
            self.notice.content = f"**Execution stopped:** {executor.error}"
        session_id = self.session_id
        if self.session is not None and result is not None:
            try:
                self.session.finish(executor, result)
            except StoreError as err:
                self.refuse_executions(str(err))
        self.operator.release()
        self._clear_answers()
        self._add_line(f"**Session {session_id} ended: {result}.**")
        self.stage.show_path(tuple(self._steps), None)
        self.question.content = "No question: the execution ended."
        self.status.content = f"**Ended: {result}** (session {session_id}). {IDLE}"
        self.start_button.disabled = bool(self.refusal)
        self.pause_button.label = "Pause"
        for button in (self.pause_button, self.step_button, self.abort_button):
            button.disabled = True
        if session_id is not None and result is not None:
            self.events.publish(ExecutionFinished(session_id, result))

    def _abort(self) -> None:
        if self.executor is not None:
            self.executor.abort()
        if self.robot is not None:
            self.robot.give_up()  # a question after a robot fault is answered

    def _pause_resume(self) -> None:
        executor = self.executor
        if executor is None or executor.done:
            return
        if executor.paused:
            executor.resume()
            self.pause_button.label = "Pause"
            self.status.content = f"**Running** session {self.session_id}."
        else:
            executor.pause()
            self.pause_button.label = "Resume"
            self.status.content = (
                f"**Paused** (session {self.session_id}): **Resume** goes on, **Step** "
                "runs one node."
            )

    def _add_line(self, line: str) -> None:
        self._log = [*self._log[-(LOG_LINES - 1) :], line]  # windowed: the store has all
        self.log.content = "\n\n".join(self._log)

    def _on_event(self, event: ExecutionEvent) -> None:
        # Runs in the executor's thread, once the step is done (a motion played).
        if not is_step(event):  # a turn of the dialogue: the log, and a voice pause
            self._add_line(sentence(event))
            self._heard = sentence(event)
            if event.kind == "fell-back" and "the voice has ended" in (event.text or ""):
                self._voice = False  # the microphone went away: the clicks answer now
            if event.kind in ("paused", "resumed"):
                paused = event.kind == "paused"
                self.pause_button.label = "Resume" if paused else "Pause"
                self.status.content = (
                    f"**Paused by voice** (session {self.session_id}): say continue, or **Resume**."
                    if paused else f"**Running** session {self.session_id}."
                )  # fmt: skip
            return
        self._steps.append(Step(event.node, event.source, event.confidence, event.outcome))
        self.stage.go_to(event.node, show_world=event.motion is None, path=tuple(self._steps))
        self.strip.content = strip_svg([e.node for e in self._steps], self._kinds())
        if event.kind == REPAIR and event.plan is not None:
            self.stage.show_plan(event.plan)  # the execution goes on with the new plan
        self._add_line(sentence(event))
        robot_moved = event.evidence is not None and event.evidence.robot is not None
        if event.motion and not robot_moved:  # the drawn arm has played its motion
            self.stage.show_world(event.node)

    def _tick(self, executor: Executor) -> None:
        """While `executor` runs: a node with outcomes that waits for its answer says
        so, with how long and what the camera and the voice are doing."""
        node_id, since = None, time.monotonic()
        while not executor.done:
            current = executor.current
            if current != node_id:
                node_id, since, self._heard = current, time.monotonic(), None
            # Answered: its step is kept (a turn of the dialogue at it is not).
            last = next((e for e in reversed(executor.events[-8:]) if is_step(e)), None)
            answered = last is not None and last.node == current
            node = executor.nodes.get(current) if current is not None else None
            if current is None or node is None or not node.outcomes or answered or executor.paused:
                self.waiting.content = ""
            else:
                self.waiting.content = wait_line(self._waiting(current, node, since))
            time.sleep(TICK_S)
        self.waiting.content = ""

    def _waiting(self, node_id: str, node: PlanNode, since: float) -> Waiting:
        now = time.monotonic()
        camera_on = self.camera is not None and node.kind == "sensing"
        news = None
        if camera_on and self._seen is not None:
            seen, at = self._seen
            news = CameraNews(seen.seen, seen.of, seen.settling, now - at)
        voice = self._voice and node.kind == "communication"
        return Waiting(node_id, str(node.action), now - since, news, camera_on, voice,
                       self._heard if voice else None)  # fmt: skip

    def _kinds(self) -> list[str]:
        plan = self.stage.current_plan()
        nodes = plan.nodes if plan is not None else {}
        return [nodes[s.node].kind if s.node in nodes else "open" for s in self._steps]

    def _play_motion(self, node_id: str, motion: Motion) -> float:
        # The executor's player: runs before the motion's event is recorded, so the
        # stored start and end are the animation's (the tree drawn first is not).
        self.stage.go_to(node_id, show_world=False, path=tuple(self._steps))
        began = time.time()
        self._play(motion, float(self.speed.value))
        return began

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
        # The node asking is the one running: the tree, the selection and the bench
        # show it, the bench as a click on it in the tree would (node_world.py).
        self.stage.go_to(offer.node_id, path=tuple(self._steps))
        with self._lock:
            # Sensing a part's shape or length asks what is on the bench, not the human.
            part = isinstance(offer.action, SenseShapeOf | SenseLengthOf)
            asked = "what is it?" if part else "what does the human do?"
            self.question.content = (
                f"`{offer.node_id}` **{offer.action}**: {asked} *(waiting for an answer)*"
            )
            with self.human_folder:
                for label, words in zip(offer.options, offer.words, strict=True):
                    button = self.gui.add_button(words)
                    button.on_click(
                        self.operator.only("answer", self._answer(offer.node_id, label))
                    )
                    self._answer_buttons.append(button)

    def _answer(self, node_id: str, label: str) -> Callable[[Click], None]:
        def handler(_: Click) -> None:
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

    def close(self, reason: str | None = None) -> None:
        """Stops a running execution: `interrupted` with `reason` (the program is
        stopping), else aborted; returns once its end is stored."""
        if self.executor is not None:
            if reason is not None:
                self.executor.interrupt(reason)
            else:
                self.executor.abort()
            self.executor.wait(5.0)
        if self._finisher is not None:
            self._finisher.join(5.0)
