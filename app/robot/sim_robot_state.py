"""The simulated Baxter's robot state (baxter_core_msgs/AssemblyState), without ROS.

Baxter's robot-level state is enabled, stopped (e-stop asserted), error and the
e-stop button and its source. It changes on `/robot/set_super_enable`,
`/robot/set_super_stop` and `/robot/set_super_reset` as Rethink's simulator and
`baxter_interface.RobotEnable` expect:

- enable: only a robot that is not stopped enables (a stopped one stays
  disabled: `RobotEnable.enable` resets it first); disable always disables;
- stop: disabled and stopped, the button unpressed and the source unknown (a
  stop asserted by software, not the red button);
- reset: clears a stop (not while the button is pressed, which a reset cannot
  release): disabled, not stopped, no error, button unpressed, source none;
- the e-stop button (a test drill, no such topic on a real robot): pressed, the
  robot is disabled and stopped with source user; released, the button reads
  released and the robot stays stopped until a reset, then an enable.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Literal

EstopButton = Literal["unpressed", "pressed", "unknown", "released"]
EstopSource = Literal["none", "user", "unknown", "fault", "brain"]
# AssemblyState's constants (ESTOP_BUTTON_*, ESTOP_SOURCE_*).
ESTOP_BUTTON: dict[EstopButton, int] = {"unpressed": 0, "pressed": 1, "unknown": 2, "released": 3}
ESTOP_SOURCE: dict[EstopSource, int] = {"none": 0, "user": 1, "unknown": 2, "fault": 3, "brain": 4}


@dataclass(frozen=True)
class AssemblyFields:
    """One /robot/state message's fields."""

    ready: bool
    enabled: bool
    stopped: bool
    error: bool
    estop_button: int
    estop_source: int


class RobotState:
    """Enabled, stopped and the e-stop; safe to use from several threads."""

    def __init__(self, enabled: bool = True) -> None:
        self._lock = threading.Lock()
        self.enabled = enabled
        self.stopped = False
        self.error = False
        self.button: EstopButton = "unpressed"
        self.source: EstopSource = "none"

    def set_enabled(self, enable: bool) -> None:
        with self._lock:
            self.enabled = enable and not self.stopped

    def stop(self) -> None:
        with self._lock:
            self.enabled, self.stopped = False, True
            if self.button != "pressed":
                self.source = "unknown"

    def reset(self) -> bool:
        """Clears a stop; False (nothing changes) while the button is pressed."""
        with self._lock:
            if self.button == "pressed":
                return False
            self.enabled = self.stopped = self.error = False
            self.button, self.source = "unpressed", "none"
            return True

    def press_estop(self, pressed: bool) -> None:
        with self._lock:
            if pressed:
                self.enabled, self.stopped = False, True
                self.button, self.source = "pressed", "user"
            elif self.button == "pressed":
                self.button = "released"

    def moving_allowed(self) -> bool:
        """Whether the arms follow their commands (enabled, not stopped)."""
        with self._lock:
            return self.enabled and not self.stopped

    def fields(self) -> AssemblyFields:
        with self._lock:
            return AssemblyFields(
                ready=self.enabled and not self.stopped,
                enabled=self.enabled,
                stopped=self.stopped,
                error=self.error,
                estop_button=ESTOP_BUTTON[self.button],
                estop_source=ESTOP_SOURCE[self.source],
            )
