"""The Robot panel: who makes the plan's motions, and what to do when it stops.

"Moves" chooses between the drawing (nobody: the motions are only drawn, the
default) and a robot over ROS (Baxter, or `tandem robot sim`) at the master
the page names. "Connect" reaches it; if nothing answers, the panel says why
in one line and the motions stay drawn. Once connected the drawn arms follow
the robot's joint states (at most `DRAW_HZ` a second), and every execution
drives it through a `RobotDriver`. When the robot stops mid-motion the cause
and the operator's choice show at the top of the Execution tab
(`add_fault_controls`): **Retry** (back to the motion's start, then again) or
**Abort the execution**; aborting the execution answers Abort.

The execution panel asks `driver(to_start)` when an execution starts, and
`give_up()` when it is aborted; it needs nothing else from this panel.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable

import viser

from app.dashboard.stage import Stage
from app.dashboard.widgets import show
from app.execution.robot_drive import FaultChoice, RobotDriver, ToStart
from app.execution.robot_link import JointState, RobotFault, RobotLink
from app.execution.timing import SPEED_RATIO
from planner.feasibility.arms import ARMS, joint_names

DRAW_HZ = 15.0
CONNECT_TIMEOUT_S = 5.0
MOVES = ("drawing only", "robot over ROS")
DRAWING = "Motions are **drawn only**."


class RobotPanel:
    def __init__(self, gui: viser.GuiApi, stage: Stage) -> None:
        self.stage = stage
        self.link: RobotLink | None = None
        self._drawn = 0.0
        self._stop_watching: Callable[[], None] | None = None
        self._choice: FaultChoice | None = None
        self._chosen = threading.Condition()
        with gui.add_folder("Robot", expand_by_default=False):
            self.moves: viser.GuiDropdownHandle[str] = gui.add_dropdown("Moves", MOVES)
            master = os.environ.get("ROS_MASTER_URI", "http://127.0.0.1:11311")
            self.master: viser.GuiTextHandle = gui.add_text("ROS master", master)
            self.connect_button = gui.add_button("Connect")
            self.connect_button.on_click(lambda _: self._connect_clicked())
            self.status = gui.add_markdown(DRAWING)
        self.moves.on_update(lambda _: self._moves_changed())
        self.gui = gui
        # Made by add_fault_controls, in the Execution tab.
        self.fault: viser.GuiMarkdownHandle | None = None
        self.retry_button: viser.GuiButtonHandle | None = None
        self.abort_button: viser.GuiButtonHandle | None = None

    def add_fault_controls(self) -> None:
        """The fault's line and the operator's two buttons, hidden until a fault, in
        the container being built (the Execution tab, where the operator looks)."""
        self.fault = self.gui.add_markdown("", visible=False)
        self.retry_button = self.gui.add_button("Retry", visible=False, color="green")
        self.retry_button.on_click(lambda _: self._choose("retry"))
        self.abort_button = self.gui.add_button("Abort the execution", visible=False, color="red")
        self.abort_button.on_click(lambda _: self._choose("abort"))

    # -- connecting -----------------------------------------------------------------

    def _moves_changed(self) -> None:
        """The page chose who moves (a page's choice; the server's own settings of
        the dropdown do not come here)."""
        if self.moves.value == MOVES[0]:
            self.disconnect()
        elif self.link is None:
            uri = str(self.master.value).strip()
            self.status.content = (
                f"Press **Connect** to reach the robot at {uri}; until then the motions "
                "are **drawn only**."
            )

    def _connect_clicked(self) -> None:
        self.connect()

    def connect(self) -> bool:
        """Reaches the robot at the page's master; False (and one line) if it is not there."""
        from app.robot.ros_env import RosMissing
        from app.robot.ros_link import RosLink

        self.disconnect()
        show(self.moves, MOVES[1])
        uri = str(self.master.value).strip()
        self.status.content = f"**Connecting** to {uri}…"
        link = RosLink(uri)
        try:
            link.connect(CONNECT_TIMEOUT_S)
        except (RobotFault, RosMissing) as err:
            self.status.content = f"**Not connected:** {err}. {DRAWING}"
            show(self.moves, MOVES[0])
            return False
        self.link = link
        self._stop_watching = link.watch(self._follow)
        self.status.content = f"**Connected** to {uri}: the plan's motions move the robot."
        return True

    def disconnect(self) -> None:
        if self._stop_watching is not None:
            self._stop_watching()
            self._stop_watching = None
        if self.link is not None:
            self.link.close()
            self.link = None
            self.status.content = DRAWING

    def _follow(self, state: JointState) -> None:
        """The drawn arms follow the robot (the ROS thread; thinned to `DRAW_HZ`)."""
        now = time.monotonic()
        if now - self._drawn < 1.0 / DRAW_HZ:
            return
        self._drawn = now
        arms = self.stage.arms()
        for arm in ARMS:
            names = joint_names(arm)
            if all(n in state.positions for n in names):
                arms[arm] = [float(state.positions[n]) for n in names]
        self.stage.show_arms(arms)

    # -- executions ----------------------------------------------------------------------

    def driver(self, to_start: ToStart | None) -> RobotDriver | None:
        """The robot for the next execution (None: the motions are drawn)."""
        if self.link is None:
            return None
        with self._chosen:
            self._choice = None
        return RobotDriver(self.link, to_start, self._ask, SPEED_RATIO)

    def give_up(self) -> None:
        """The execution is aborted: a question waiting on a fault is answered Abort."""
        self._choose("abort")

    def _ask(self, fault: RobotFault) -> FaultChoice:
        """Runs in the executor's thread: shows the fault and waits for the operator."""
        line = (
            f"**The robot stopped:** {fault.line}. **Retry** (back to the motion's start), "
            "or abort?"
        )
        self.status.content = line
        self._show_question(line)
        with self._chosen:
            self._choice = None
            while self._choice is None:
                self._chosen.wait()
            choice = self._choice
        self._show_question(None)
        self.status.content = (
            "**Retrying:** back to the motion's start." if choice == "retry"
            else "**Aborted** after the robot stopped."
        )  # fmt: skip
        return choice

    def _show_question(self, line: str | None) -> None:
        for element in (self.fault, self.retry_button, self.abort_button):
            if element is not None:
                element.visible = line is not None
        if self.fault is not None:
            self.fault.content = line or ""

    def _choose(self, choice: FaultChoice) -> None:
        with self._chosen:
            self._choice = choice
            self._chosen.notify_all()

    def close(self) -> None:
        self.give_up()
        self.disconnect()
