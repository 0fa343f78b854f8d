"""What decided an answer, as typed records: one per source, and its JSON form.

An event's `Evidence` holds at most one record of each kind: what the robot said
(`Spoken`), what the camera read (`CameraReading`), what the voice heard
(`VoiceHearing`), what was clicked (`Clicked`), a slot the human used
(`SlotFollowed`), a motion re-targeted to the world's slots (`Retargeted`), a
new plan after a surprise (`Replanned`), what a robot behind a link did
(`RobotMotion`), and, in simulated runs, what the simulated human really did
(`Truth`). A source writes only its own record; a
node where the robot speaks and then listens merges two.

The JSON form, stored in the session database and in exports, is versioned:

- version 2 (written now): `{"version": 2, "spoken": {...}, "camera": {...},
  "voice": {...}, "clicked": {...}, "slot": {...}, "retargeted": {...},
  "replanned": {...}, "robot": {...}, "truth": {"label": ..., "said": [...]}}`,
  a key only for
  a record that is there; each record's fields are its dataclass's.
- version 1 (no "version" key; sessions stored before the records existed): one
  flat mapping whose keys told the writer (`said`/`engine` a spoken line,
  `camera` a reading, `answered_by` a hearing, `slot`, `retargeted`,
  `surprise`/`observed` a repair) and whose `truth` was a label for the camera
  and a mapping for the voice. `from_json` reads both.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any, Literal, TypeVar

from planner.plan.model import Motion

EVIDENCE_VERSION = 2

R = TypeVar("R")
AnsweredBy = Literal["voice", "fallback"]
CameraDecision = Literal["label", "surprise"]


@dataclass(frozen=True)
class Spoken:
    """A sentence the robot said: its text, the engine and voice, how long it took."""

    said: str
    engine: str
    voice: str | None = None
    duration_s: float | None = None
    speech_error: str | None = None


@dataclass(frozen=True)
class CameraReading:
    """What the camera's settled view said at a sensing node.

    `decided` tells whether `value` is an outcome label or a surprise (in the
    surprise's words); `placements` and `outlines` are the world as read, per part.
    """

    decided: CameraDecision
    value: str
    confidence: float
    reason: str
    frames: int
    frame_index: int
    seconds: float
    placements: dict[str, str] = field(default_factory=dict)
    outlines: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class HeardAttempt:
    """One listening: the words, the recogniser's confidence, the answer they mean."""

    heard: str
    confidence: float
    meaning: str | None
    reason: str | None
    audio: str | None


@dataclass(frozen=True)
class VoiceHearing:
    """The voice at a question: every try, who answered in the end, and with what."""

    answered_by: AnsweredBy
    heard: str
    confidence: float
    meaning: str | None
    tries: int
    attempts: tuple[HeardAttempt, ...] = ()
    engine: str = "none"  # the engine that spoke the question
    recognizer: str = ""
    fallback: str | None = None  # the source that answered after the voice gave up


@dataclass(frozen=True)
class Clicked:
    """A click's answer: what was offered, and how long the question waited."""

    offered: tuple[str, ...]
    waited_s: float


@dataclass(frozen=True)
class SlotFollowed:
    """The human attached at another free point than the branch names (plan's names)."""

    onto: str
    branch: str
    used: str
    real: str
    slots: dict[str, dict[str, str]] = field(default_factory=dict)


@dataclass(frozen=True)
class Retargeted:
    """A motion made for the world's slots instead of the plan's.

    `motion` is the motion made, or None when no motion planner was there to make it
    (`reason` says so) and the stored one was played.
    """

    real_action: str
    slots: dict[str, dict[str, str]] = field(default_factory=dict)
    robot_slot: dict[str, str] | None = None
    motion: Motion | None = None
    reason: str | None = None


@dataclass(frozen=True)
class Replanned:
    """A repair: the surprise, the state observed, the new plan's hash and its time."""

    surprise: str
    observed: tuple[str, ...]
    plan: str
    plan_s: float


@dataclass(frozen=True)
class RobotMotion:
    """What the robot behind a link did at an actuation node (or a fault).

    `link` names the backend (`ros`); `reached` is the arm's last joint state;
    `off_rad` its largest joint difference from the plan's end of the motion;
    `states` the arm's joint states along the motion (seconds from `began`,
    positions in `joints`' order; thinned); `began` the wall-clock time the robot was
    sent the motion (None in sessions stored before it was kept: their states count
    from the step's start); `to_start` whether a planned motion to the plan's start
    came first; `cause`/`detail` a fault's (None when reached).
    """

    link: str
    arm: str
    joints: tuple[str, ...]
    reached: tuple[float, ...]
    off_rad: float
    states: tuple[tuple[float, tuple[float, ...]], ...] = ()
    to_start: bool = False
    cause: str | None = None
    detail: str | None = None
    began: float | None = None


@dataclass(frozen=True)
class Truth:
    """What the simulated human really did: the outcome it acted out or answered, and,
    for a spoken answer, its words."""

    label: str
    said: tuple[str, ...] = ()


@dataclass(frozen=True)
class Evidence:
    """What decided an event's answer, kept with the session for the review.

    `jpeg` is a small picture of the frame that decided a camera answer; it is
    stored beside the JSON, not in it.
    """

    spoken: Spoken | None = None
    camera: CameraReading | None = None
    voice: VoiceHearing | None = None
    clicked: Clicked | None = None
    slot: SlotFollowed | None = None
    retargeted: Retargeted | None = None
    replanned: Replanned | None = None
    robot: RobotMotion | None = None
    truth: Truth | None = None
    jpeg: bytes | None = field(default=None, repr=False)

    def merged(self, other: Evidence | None) -> Evidence:
        """Both in one: `other`'s records win where both have one, its picture if any."""
        if other is None:
            return self
        theirs = {f.name: getattr(other, f.name) for f in fields(other)}
        return replace(self, **{k: v for k, v in theirs.items() if v is not None})

    def to_json(self) -> dict[str, Any]:
        """The version-2 JSON form (without the picture)."""
        out: dict[str, Any] = {"version": EVIDENCE_VERSION}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None or f.name == "jpeg":
                continue
            out[f.name] = _record_json(value)
        return out

    @classmethod
    def from_json(cls, doc: Mapping[str, Any], jpeg: bytes | None = None) -> Evidence:
        """The evidence of a stored JSON form, version 2 or 1."""
        if doc.get("version") == EVIDENCE_VERSION:
            return _from_v2(doc, jpeg)
        return _from_v1(doc, jpeg)


def merged(first: Evidence | None, second: Evidence | None) -> Evidence | None:
    """Both evidences in one (either may be missing)."""
    if first is None:
        return second
    return first.merged(second)


def _record_json(record: object) -> Any:
    if isinstance(record, Retargeted):
        out = _plain(asdict(replace(record, motion=None)))
        out["motion"] = None if record.motion is None else record.motion.model_dump()
        return out
    return _plain(asdict(record))  # type: ignore[call-overload]


def _plain(value: Any) -> Any:
    """JSON's own shapes: tuples become lists, so a form read back equals the one written."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _from_v2(doc: Mapping[str, Any], jpeg: bytes | None) -> Evidence:
    def get(name: str) -> Mapping[str, Any] | None:
        value = doc.get(name)
        return value if isinstance(value, Mapping) else None

    voice, retargeted = get("voice"), get("retargeted")
    truth, replanned, robot = get("truth"), get("replanned"), get("robot")
    return Evidence(
        spoken=_build(Spoken, get("spoken")),
        camera=_build(CameraReading, get("camera")),
        voice=None if voice is None else _hearing(voice),
        clicked=_clicked(get("clicked")),
        slot=_build(SlotFollowed, get("slot")),
        retargeted=None if retargeted is None else _retargeted(retargeted),
        replanned=None if replanned is None else _replanned(replanned),
        robot=None if robot is None else _robot(robot),
        truth=None if truth is None else Truth(truth["label"], tuple(truth.get("said", ()))),
        jpeg=jpeg,
    )


def _build(kind: type[R], doc: Mapping[str, Any] | None) -> R | None:
    if doc is None:
        return None
    names = {f.name for f in fields(kind)}  # type: ignore[arg-type]
    return kind(**{k: v for k, v in doc.items() if k in names})


def _clicked(doc: Mapping[str, Any] | None) -> Clicked | None:
    if doc is None:
        return None
    return Clicked(tuple(doc.get("offered", ())), float(doc.get("waited_s", 0.0)))


def _hearing(doc: Mapping[str, Any]) -> VoiceHearing:
    attempts = tuple(_build(HeardAttempt, a) for a in doc.get("attempts", ()))
    return VoiceHearing(
        answered_by=doc.get("answered_by", "voice"),
        heard=doc.get("heard") or "",
        confidence=float(doc.get("confidence") or 0.0),
        meaning=doc.get("meaning"),
        tries=int(doc.get("tries", len(attempts))),
        attempts=tuple(a for a in attempts if a is not None),
        engine=doc.get("engine") or "none",
        recognizer=doc.get("recognizer") or "",
        fallback=doc.get("fallback"),
    )


def _retargeted(doc: Mapping[str, Any]) -> Retargeted:
    motion = doc.get("motion")
    return Retargeted(
        real_action=doc["real_action"],
        slots=dict(doc.get("slots") or {}),
        robot_slot=doc.get("robot_slot"),
        motion=Motion.model_validate(motion) if isinstance(motion, Mapping) else None,
        reason=doc.get("reason"),
    )


def _replanned(doc: Mapping[str, Any]) -> Replanned:
    return Replanned(
        surprise=doc["surprise"],
        observed=tuple(doc.get("observed", ())),
        plan=doc["plan"],
        plan_s=float(doc.get("plan_s", 0.0)),
    )


def _robot(doc: Mapping[str, Any]) -> RobotMotion:
    return RobotMotion(
        link=str(doc.get("link", "")),
        arm=str(doc.get("arm", "")),
        joints=tuple(doc.get("joints", ())),
        reached=tuple(float(q) for q in doc.get("reached", ())),
        off_rad=float(doc.get("off_rad", 0.0)),
        states=tuple((float(t), tuple(float(q) for q in qs)) for t, qs in doc.get("states", ())),
        to_start=bool(doc.get("to_start", False)),
        cause=doc.get("cause"),
        detail=doc.get("detail"),
        began=None if doc.get("began") is None else float(doc["began"]),
    )


def _from_v1(doc: Mapping[str, Any], jpeg: bytes | None) -> Evidence:
    """The flat mapping of sessions stored before version 2."""
    camera = doc.get("camera")
    return Evidence(
        spoken=_v1_spoken(doc),
        camera=_v1_camera(camera) if isinstance(camera, Mapping) else None,
        voice=_hearing(doc) if "answered_by" in doc else None,
        slot=_v1_slot(doc),
        retargeted=_v1_retargeted(doc),
        replanned=_replanned(doc) if "surprise" in doc and "plan" in doc else None,
        truth=_v1_truth(doc.get("truth")),
        jpeg=jpeg,
    )


def _v1_spoken(doc: Mapping[str, Any]) -> Spoken | None:
    if "said" not in doc:
        return None
    return Spoken(
        said=doc["said"],
        engine=doc.get("engine") or "none",
        voice=doc.get("voice"),
        duration_s=doc.get("duration_s"),
        speech_error=doc.get("speech_error"),
    )


def _v1_camera(doc: Mapping[str, Any]) -> CameraReading:
    decided: CameraDecision = "surprise" if "surprise" in doc else "label"
    return CameraReading(
        decided=decided,
        value=str(doc.get(decided, "")),
        confidence=float(doc.get("confidence", 0.0)),
        reason=doc.get("reason") or "",
        frames=int(doc.get("frames", 0)),
        frame_index=int(doc.get("frame_index", -1)),
        seconds=float(doc.get("seconds", 0.0)),
        placements=dict(doc.get("placements") or {}),
        outlines=dict(doc.get("outlines") or {}),
    )


def _v1_slot(doc: Mapping[str, Any]) -> SlotFollowed | None:
    slot = doc.get("slot")
    if not isinstance(slot, Mapping):
        return None
    return SlotFollowed(
        slot["onto"], slot["branch"], slot["used"], slot["real"], dict(doc.get("slots") or {})
    )


def _v1_retargeted(doc: Mapping[str, Any]) -> Retargeted | None:
    if "retargeted" not in doc:
        return None
    made = doc["retargeted"]
    return Retargeted(
        real_action=doc.get("real_action", ""),
        slots=dict(doc.get("slots") or {}),
        robot_slot=doc.get("robot_slot"),
        motion=Motion.model_validate(made) if isinstance(made, Mapping) else None,
        reason=made if isinstance(made, str) else None,
    )


def _v1_truth(truth: object) -> Truth | None:
    if isinstance(truth, str):
        return Truth(truth)
    if isinstance(truth, Mapping):
        return Truth(str(truth.get("answer")), tuple(str(w) for w in truth.get("said", ())))
    return None
