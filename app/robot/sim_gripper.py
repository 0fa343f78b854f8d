"""The simulated Baxter's grippers, without ROS: an electric parallel gripper or a
suction cup, commanded with baxter_core_msgs/EndEffectorCommand as Rethink's
`baxter_interface.Gripper` commands them.

Both kinds answer only commands carrying their own hardware id (the id is read
from the gripper's state, as `Gripper.hardware_id` does); anything else is
ignored, as the firmware ignores it. A handled command is echoed in the state's
`command`, `command_sender` and `command_sequence` (the acknowledgement
`Gripper.command` waits for); a command repeated with the same sender and
sequence number (as `Gripper.command` resends it until its test passes) is not
carried out again.

Electric (id 65538): it starts uncalibrated. `calibrate` takes
`CALIBRATE_SECONDS` (not ready meanwhile), clears an error, and leaves the
fingers open; `go` with `{"position": 0..100}` moves the fingers at the
configured velocity (full travel in `GRIPPER_SECONDS` at the default 50 %).
A `go` before calibration is refused and sets the error flag, which a `reset`
or a new `calibrate` clears; a `go` while in error is refused likewise. No part
is simulated: a closing move meets a part at `PART_POSITION` and stops there
gripping (the force is the holding force); a move that ends above it does not
grip. `configure` sets the parameters (velocity, moving_force, holding_force,
dead_zone), `stop` halts the fingers, `clear_calibration` uncalibrates. `grip`
and `release` do nothing on an electric gripper (no Rethink client sends them).

Suction (id 65537): always calibrated (it has no calibration). `go` (as
`Gripper.close` sends it, with `grip_attempt_seconds`) or `grip` sucks, and a
part is held after `SUCTION_SECONDS`; `release` stops sucking and blows off for
`blow_off_seconds`. Its state's JSON carries vacuum, sucking, blowing and the
vacuum sensor (0-255), as `Gripper.vacuum()` and `sucking()` read them.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass, field
from typing import Any, Literal

GripperKind = Literal["electric", "suction"]
ELECTRIC_ID = 65538  # the hardware ids Rethink's simulator gives each kind
SUCTION_ID = 65537
# EndEffectorProperties' ui_type constants.
UI_TYPE: dict[GripperKind, int] = {"suction": 1, "electric": 2}
GRIPPER_SECONDS = 0.4  # fully open to closed at the default velocity (50 %)
CALIBRATE_SECONDS = 0.5
SUCTION_SECONDS = 0.2  # from sucking to the vacuum holding a part
PART_POSITION = 30.0  # where closing fingers meet a part (percent open)
VACUUM_HELD = 200  # the vacuum sensor's reading with a part held (0-255)
ELECTRIC_DEFAULTS = {
    "velocity": 50.0,
    "moving_force": 40.0,
    "holding_force": 30.0,
    "dead_zone": 5.0,
}
SUCTION_DEFAULTS = {"vacuum_sensor_threshold": 18.0, "blow_off_seconds": 0.4}
STATE_TRUE, STATE_FALSE = 1, 0


@dataclass(frozen=True)
class Properties:
    """One gripper's EndEffectorProperties fields."""

    id: int
    ui_type: int
    manufacturer: str
    product: str
    serial_number: str
    hardware_rev: str
    firmware_rev: str
    firmware_date: str
    has_calibration: bool
    controls_grip: bool
    senses_grip: bool
    reverses_grip: bool
    controls_force: bool
    senses_force: bool
    controls_position: bool
    senses_position: bool
    properties: str


def properties(kind: GripperKind) -> Properties:
    electric = kind == "electric"
    return Properties(
        id=ELECTRIC_ID if electric else SUCTION_ID,
        ui_type=UI_TYPE[kind],
        manufacturer="Rethink Research Robot",
        product="Electric Parallel Gripper" if electric else "Suction Cup Gripper",
        serial_number="",
        hardware_rev="2" if electric else "",
        # A build date past baxter_interface 1.2.0's firmware check.
        firmware_rev="3.0.0 5.5" if electric else "",
        firmware_date="2014/7/24 18:30:00" if electric else "",
        has_calibration=electric,
        controls_grip=True,
        senses_grip=True,
        reverses_grip=False,
        controls_force=electric,
        senses_force=electric,
        controls_position=electric,
        senses_position=electric,
        properties="{}",
    )


@dataclass
class Gripper:
    """One gripper's state; safe to use from several threads."""

    kind: GripperKind
    position: float = 100.0  # percent open (0 closed); a suction cup reports 0
    target: float = 100.0
    calibrated: bool = False
    error: bool = False
    gripping: bool = False
    calibrating_s: float = 0.0  # left of a calibration under way
    sucking: bool = False
    suck_s: float = 0.0  # how long it has sucked
    blowing_s: float = 0.0  # left of a blow-off
    parameters: dict[str, float] = field(default_factory=dict)
    command: str = ""
    sender: str = ""
    sequence: int = 0
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __post_init__(self) -> None:
        electric = self.kind == "electric"
        self.parameters = dict(ELECTRIC_DEFAULTS if electric else SUCTION_DEFAULTS)
        self.calibrated = not electric
        if not electric:
            self.position = self.target = 0.0

    @property
    def id(self) -> int:
        return ELECTRIC_ID if self.kind == "electric" else SUCTION_ID

    @property
    def moving(self) -> bool:
        return self.position != self.target or self.calibrating_s > 0.0

    def handle(self, target_id: int, command: str, args: str, sender: str, sequence: int) -> str:
        """Carries out a command; says what it did or why it ignored it."""
        with self._lock:
            if target_id != self.id:
                return f"ignored {command!r}: id {target_id} is not this gripper's ({self.id})"
            if sequence and (command, sender, sequence) == (
                self.command,
                self.sender,
                self.sequence,
            ):
                # Rethink's Gripper resends a command until its test passes: a repeat
                # (same sender and sequence) is acknowledged, not carried out again.
                return f"repeated {command!r}"
            arguments = _arguments(args)
            if arguments is None:
                return f"ignored {command!r}: its args are not a JSON object: {args!r}"
            did = (self._electric if self.kind == "electric" else self._suction)(command, arguments)
            if did.startswith("ignored"):
                return did
            self.command, self.sender, self.sequence = command, sender, sequence
            return did

    def _electric(self, command: str, arguments: dict[str, Any]) -> str:
        if command == "calibrate":
            self.error, self.calibrated, self.gripping = False, False, False
            self.calibrating_s = CALIBRATE_SECONDS
            return "calibrating"
        if command == "go":
            if not self.calibrated or self.error:
                self.error = True
                why = "not calibrated" if not self.calibrated else "in error"
                return f"refused go: {why} (error set)"
            position = arguments.get("position")
            if not isinstance(position, int | float) or isinstance(position, bool):
                self.error = True
                return f"refused go: no position in {arguments} (error set)"
            self.target = max(0.0, min(100.0, float(position)))
            self.gripping = False
            return f"going to {self.target:.1f}"
        if command == "stop":
            self.target = self.position
            return "stopped"
        if command == "reset":
            self.error = False
            return "reset"
        if command == "clear_calibration":
            self.calibrated = False
            return "calibration cleared"
        if command == "configure":
            return self._configure(arguments)
        return f"ignored {command!r}: an electric gripper does not {command}"

    def _suction(self, command: str, arguments: dict[str, Any]) -> str:
        if command in ("go", "grip"):
            self.sucking, self.blowing_s = True, 0.0
            return "sucking"
        if command in ("release", "stop"):
            if self.sucking and self.gripping:
                self.blowing_s = self.parameters["blow_off_seconds"]
            self.sucking = self.gripping = False
            self.suck_s = 0.0
            return "released"
        if command == "configure":
            return self._configure(arguments)
        return f"ignored {command!r}: a suction gripper does not {command}"

    def _configure(self, arguments: dict[str, Any]) -> str:
        for key, value in arguments.items():
            if key in self.parameters and isinstance(value, int | float):
                self.parameters[key] = float(value)
        return "configured"

    def step(self, seconds: float) -> None:
        """Advances the gripper `seconds` in time."""
        with self._lock:
            if self.kind == "suction":
                self._step_suction(seconds)
                return
            if self.calibrating_s > 0.0:
                self.calibrating_s = max(0.0, self.calibrating_s - seconds)
                if self.calibrating_s == 0.0:
                    self.calibrated = True
                    self.position = self.target = 100.0
                return
            self._step_fingers(seconds)

    def _step_fingers(self, seconds: float) -> None:
        reach = 100.0 * seconds / GRIPPER_SECONDS * self.parameters["velocity"] / 50.0
        before, delta = self.position, self.target - self.position
        self.position = (
            self.target if abs(delta) <= reach else before + reach * (delta / abs(delta))
        )
        # Fingers closing from above the part onto a target at or below it meet it.
        if before > PART_POSITION >= self.target and self.position <= PART_POSITION:
            self.position = self.target = PART_POSITION
            self.gripping = True

    def _step_suction(self, seconds: float) -> None:
        self.blowing_s = max(0.0, self.blowing_s - seconds)
        if self.sucking:
            self.suck_s += seconds
            self.gripping = self.suck_s >= SUCTION_SECONDS

    def state(self) -> dict[str, Any]:
        """The EndEffectorState fields (without the timestamp)."""
        with self._lock:
            electric = self.kind == "electric"
            ready = not self.error and self.calibrating_s == 0.0 and not self.moving
            force = self.parameters["holding_force"] if electric and self.gripping else 0.0
            extra: dict[str, Any] = {}
            if not electric:
                extra = {
                    "vacuum": self.gripping,
                    "sucking": self.sucking,
                    "blowing": self.blowing_s > 0.0,
                    "vacuum sensor": VACUUM_HELD if self.gripping else 0,
                }
            return {
                "id": self.id,
                "enabled": STATE_TRUE,
                "calibrated": int(self.calibrated),
                "ready": int(ready),
                "moving": int(self.moving),
                "gripping": int(self.gripping),
                "missed": STATE_FALSE,
                "error": int(self.error),
                "reverse": STATE_FALSE,
                "position": self.position,
                "force": force,
                "state": json.dumps(extra),
                "command": self.command,
                "command_sender": self.sender,
                "command_sequence": self.sequence,
            }


def _arguments(text: str) -> dict[str, Any] | None:
    """A command's JSON arguments (empty text: none)."""
    if not text.strip():
        return {}
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) else None
