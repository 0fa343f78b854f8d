"""Pydantic models of the sections of a scenario file (docs/scenario.md).

They check types and per-field syntax only; `scenario_model.Scenario` puts
them together and runs the cross-field `scenario_rules`, which read these
sections (so the rules need not import the scenario that calls them).
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

_CONST = re.compile(r"[a-z][A-Za-z0-9_]*")
_WORD = re.compile(r"[A-Za-z0-9_]+")


def _const_id(value: str) -> str:
    # Ids become ASP constants verbatim, so anything else would break the encoding.
    if not _CONST.fullmatch(value):
        raise ValueError(
            f"bad id {value!r}: expected a lowercase letter followed by letters, digits or _"
        )
    if value == "not":  # the one bare keyword of clingo's input language
        raise ValueError("bad id 'not': it is a keyword of ASP")
    return value


def _word(value: str) -> str:
    # Shapes end up inside class constants (`leg_<shape>`), so they must be one word.
    if not _WORD.fullmatch(value):
        raise ValueError(f"bad word {value!r}: expected letters, digits or _ only")
    return value


def _one_line(value: str) -> str:
    # The name is echoed in one-line reports and plan headers.
    if not value.strip() or any(c in value for c in "\r\n"):
        raise ValueError("expected one non-empty line of text")
    return value


ConstId = Annotated[str, AfterValidator(_const_id)]
OneLine = Annotated[str, AfterValidator(_one_line)]
Word = Annotated[str, AfterValidator(_word)]
Extent = Annotated[list[float], Field(min_length=2, max_length=2)]
Pose = Annotated[list[float], Field(min_length=3, max_length=3)]
Pair = Annotated[list[ConstId], Field(min_length=2, max_length=2)]
# A property the robot knows (`"square"`), or the options it may turn out to be
# (`["square", "triangle"]`): a sensing action reveals which (docs/scenario.md).
Property = Word | list[Word]
PartKind = Literal["top", "leg", "foot", "other"]


# Extents along x (metres) of the three regions of the default bench, measured in
# the field notes: used when a region has no `x`, and by the paper's instances.
DEFAULT_REGION_X: dict[str, tuple[float, float]] = {
    "robotOnly": (0.30, 0.65),
    "shared": (0.65, 1.00),
    "humanOnly": (1.00, 1.40),
}
# How many times the human may pick a part up unasked in one execution.
DEFAULT_INITIATIVE = 1
# Printed side of a QR code, quiet zone excluded: 10 cm codes decode from the
# default camera 1.45 m over the bench (perception.bench maps the rest).
DEFAULT_MARKER_SIZE_M = 0.10


class StrictModel(BaseModel):
    # strict: TOML has real types, so "yes" for a boolean is a mistake, not a
    # value to coerce; forbid: a misspelt optional key must not pass silently.
    model_config = ConfigDict(strict=True, extra="forbid", frozen=True)


class Preferences(StrictModel):
    safety: Literal["relaxed", "normal", "strict"] = "normal"
    verbosity: Literal["terse", "normal", "chatty"] = "normal"


class Region(StrictModel):
    id: ConstId
    x: Extent | None = None
    # Required on purpose: guessing "out of reach" would hide the human from safety.
    human_reach: bool


class Robot(StrictModel):
    manipulators: Annotated[list[ConstId], Field(min_length=1)] = ["left", "right"]
    base_pose: Pose = [0.0, 0.0, 0.0]


# The languages the robot can speak and hear (the speech package has the words).
Language = Literal["en-us", "ko"]
DEFAULT_LANGUAGE: Language = "en-us"


# The voice dialogue's times, in seconds (speech.dialogue.DialogueTimes says why):
# how long the robot waits for an answer to begin (Furhat's SDK also waits 5 s),
# the silence that ends an answer (not Furhat's 0.8 s: answers have no pause inside, and
# 0.2 s takes the decision within 0.3 s of the end of speech, the same answers heard), and
# the longest utterance taken as an answer (one to three words last under 1.5 s;
# Furhat's 15 s is for open questions and would only delay asking again).
DEFAULT_NO_SPEECH_S = 5.0
DEFAULT_END_OF_SPEECH_S = 0.2
DEFAULT_MAX_UTTERANCE_S = 5.0


# The simulated human's times (app.execution.timing), lognormal: a median in seconds
# and the spread of its log. Assumed, none measured with this bench: `react`, from a
# request's end to the human starting, a choice reaction time to a spoken request
# (about 0.5 to 1 s in the reaction-time literature); `attach`, screwing a leg or foot
# in by hand (assumed 8 s, ± 35 %); `unhold`, putting a part down (assumed 1.5 s);
# `answer`, from a question's end to the answer's end: a turn gap (about 0.2 s between
# people, Stivers et al. 2009, PNAS 106(26)) plus saying "yes" or "no", taken longer
# (1 s) for a robot partner.
DEFAULT_REACT_S, DEFAULT_REACT_SIGMA = 0.8, 0.3
DEFAULT_ATTACH_S, DEFAULT_ATTACH_SIGMA = 8.0, 0.35
DEFAULT_UNHOLD_S, DEFAULT_UNHOLD_SIGMA = 1.5, 0.3
DEFAULT_ANSWER_S, DEFAULT_ANSWER_SIGMA = 1.0, 0.4


class Human(StrictModel):
    name: str = "teammate"
    initiative: int = Field(default=DEFAULT_INITIATIVE, ge=0, le=3)
    language: Language = DEFAULT_LANGUAGE
    no_speech_s: float = Field(default=DEFAULT_NO_SPEECH_S, ge=1.0, le=60.0)
    end_of_speech_s: float = Field(default=DEFAULT_END_OF_SPEECH_S, ge=0.1, le=3.0)
    max_utterance_s: float = Field(default=DEFAULT_MAX_UTTERANCE_S, ge=1.0, le=60.0)
    react_s: float = Field(default=DEFAULT_REACT_S, gt=0.0, le=60.0)
    react_sigma: float = Field(default=DEFAULT_REACT_SIGMA, ge=0.0, le=2.0)
    attach_s: float = Field(default=DEFAULT_ATTACH_S, gt=0.0, le=600.0)
    attach_sigma: float = Field(default=DEFAULT_ATTACH_SIGMA, ge=0.0, le=2.0)
    unhold_s: float = Field(default=DEFAULT_UNHOLD_S, gt=0.0, le=600.0)
    unhold_sigma: float = Field(default=DEFAULT_UNHOLD_SIGMA, ge=0.0, le=2.0)
    answer_s: float = Field(default=DEFAULT_ANSWER_S, gt=0.0, le=60.0)
    answer_sigma: float = Field(default=DEFAULT_ANSWER_SIGMA, ge=0.0, le=2.0)

    @model_validator(mode="after")
    def _pause_within_an_utterance(self) -> Human:
        if self.end_of_speech_s >= self.max_utterance_s:
            raise ValueError("end_of_speech_s must be shorter than max_utterance_s")
        return self


class Camera(StrictModel):
    # Metres; bounded so a code (with its quiet zone and label) fits an A4 sheet
    # and stays large enough to print its modules sharply.
    marker_size: float = Field(default=DEFAULT_MARKER_SIZE_M, ge=0.02, le=0.16)


class Feasibility(StrictModel):
    source: Literal["declared", "geometry"] = "geometry"
    reachable: dict[str, list[str]] = {}
    unreachable_parts: dict[str, list[str]] = {}
    # "nearest": an arm reaches the top if it reaches its nearest point, and plans
    # name whichever free point; "each": every arm's reach of every point of a
    # fixed part is checked, and plans put parts only where the arm reaches
    # (asp/feasibility.lp, asp/lookahead.lp): exact motions, longer planning.
    points: Literal["nearest", "each"] = "nearest"

    @model_validator(mode="after")
    def _points_need_geometry(self) -> Feasibility:
        if self.points == "each" and self.source != "geometry":
            raise ValueError('points = "each" needs source = "geometry"')
        return self

    @model_validator(mode="before")
    @classmethod
    def _declared_when_tabled(cls, data: object) -> object:
        # Geometry is the default; a file that writes a table means that table.
        if isinstance(data, dict) and "source" not in data:
            tabled = "reachable" in data or "unreachable_parts" in data
            return {**data, "source": "declared" if tabled else "geometry"}
        return data


class Part(StrictModel):
    id: ConstId
    kind: PartKind
    region: str
    connections: list[ConstId] | None = None
    pose: Pose | None = None
    size: Pose | None = None
    marker: Annotated[int, Field(ge=0)] | None = None
    length: Property | None = None
    shape: Property | None = None
    dangerous: bool = False
    class_: ConstId | None = Field(default=None, alias="class")
    attaches_to: list[ConstId] | None = None

    @property
    def class_name(self) -> str:
        """The ASP class; only meaningful once the scenario checks have passed.

        A fixed configuration needs known shapes (`leg_<shape>`); a planned one
        uses the kind alone and matches shapes in ASP (`planner/asp/configuration.lp`).
        """
        if self.kind == "top":
            return "top"
        if self.kind in ("leg", "foot"):
            return f"{self.kind}_{self.shape}" if isinstance(self.shape, str) else self.kind
        return self.class_ or ""

    @property
    def shape_options(self) -> list[str]:
        """What the shape may be: one entry when known."""
        return _options(self.shape)

    @property
    def length_options(self) -> list[str]:
        """What the length may be: one entry when known."""
        return _options(self.length)

    @property
    def unknown(self) -> bool:
        """Whether a property of the part is open among options."""
        return isinstance(self.shape, list) or isinstance(self.length, list)

    @property
    def connection_points(self) -> list[str]:
        if self.connections is not None:
            return list(self.connections)
        return ["foot"] if self.kind == "leg" else []

    @property
    def movable(self) -> bool:
        return self.kind != "top"


def _options(value: str | list[str] | None) -> list[str]:
    if value is None:
        return []
    return [value] if isinstance(value, str) else list(value)


# fixed: the scenario's rules pick the table before planning (`goal(P,Q)` facts);
# planned: the planner picks it per branch, from what it has sensed.
Configuration = Literal["fixed", "planned"]


class Goal(StrictModel):
    table: Literal["stable"] | None = None
    configuration: Configuration | None = None
    attachments: Annotated[list[Pair], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _exactly_one(self) -> Goal:
        if (self.table is None) == (self.attachments is None):
            raise ValueError("expected exactly one of `table` or `attachments`")
        return self

    @property
    def planned(self) -> bool:
        """Whether the planner chooses the final configuration."""
        return self.configuration == "planned"
