"""The domain's words as typed values: fluents and actions of the paper's vocabulary.

Every ASP term that leaves the solver or a plan file is read here, by one
parse/format pair: `parse_fluent`/`parse_action` give typed values, `str()`
gives the canonical text back (the text the solver prints and plan files store).
Plain Python on purpose: the plan audit must not depend on clingo.

States stay frozensets of canonical fluent text: they are hashed millions of
times while planning, and strings hash faster than nested dataclasses; read
them through `Hands.of` or `parse_fluent` instead of slicing strings.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar, TypeVar

# ---------------------------------------------------------------- terms


@dataclass(frozen=True)
class Term:
    """A ground term such as `sense(humanAttachingWhere(leg2,top))`."""

    name: str
    args: tuple[Term, ...] = ()

    def __str__(self) -> str:
        if not self.args:
            return self.name
        return f"{self.name}({','.join(str(a) for a in self.args)})"


class TermError(ValueError):
    """A string that is not a ground term, or not a word of the domain."""


_NAME = r"[a-z_][A-Za-z0-9_]*"
_TOKEN = re.compile(
    rf"\s*(?:(?P<id>{_NAME})|(?P<num>-?[0-9]+)" r'|(?P<str>"(?:[^"\\]|\\.)*")|(?P<punct>[(),]))'
)
_PUNCT = frozenset("(),")


def parse_term(text: str) -> Term:
    """Parse a ground ASP term: constants, integers, strings, nested functions."""
    tokens: list[str] = []
    pos = 0
    text = text.strip()  # _TOKEN skips leading blanks, so only trailing ones remain
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise TermError(f"cannot parse {text!r} at position {pos}")
        tokens.append(m.group(m.lastgroup or "punct"))
        pos = m.end()
    term, rest = _parse_tokens(text, tokens, 0)
    if rest != len(tokens):
        raise TermError(f"cannot parse {text!r}: unexpected {tokens[rest]!r}")
    return term


def _parse_tokens(text: str, tokens: list[str], i: int) -> tuple[Term, int]:
    if i >= len(tokens) or tokens[i] in _PUNCT:
        raise TermError(f"cannot parse {text!r}: expected a name")
    name = tokens[i]
    i += 1
    if i >= len(tokens) or tokens[i] != "(":
        return Term(name), i
    if not re.fullmatch(_NAME, name):
        raise TermError(f"cannot parse {text!r}: {name!r} cannot take arguments")
    args: list[Term] = []
    i += 1
    while True:
        arg, i = _parse_tokens(text, tokens, i)
        args.append(arg)
        if i < len(tokens) and tokens[i] == ",":
            i += 1
            continue
        if i < len(tokens) and tokens[i] == ")":
            return Term(name, tuple(args)), i + 1
        raise TermError(f"cannot parse {text!r}: expected ',' or ')'")


def constants(term: Term) -> tuple[str, ...] | None:
    """The arguments of `term` as plain strings, or None if any is nested."""
    if any(a.args for a in term.args):
        return None
    return tuple(a.name for a in term.args)


# ---------------------------------------------------------------- words


@dataclass(frozen=True)
class _Word:
    """A predicate with constant arguments; its fields are the arguments in order."""

    name: ClassVar[str]
    # The fields' names in order (made by `dataclass`): `fields()` builds its answer
    # anew on every call, and words are written out tens of thousands of times a plan.
    __match_args__: ClassVar[tuple[str, ...]]

    @property
    def arguments(self) -> tuple[str, ...]:
        return tuple(getattr(self, name) for name in self.__match_args__)

    def __str__(self) -> str:
        args = self.arguments
        return f"{self.name}({','.join(args)})" if args else self.name


W = TypeVar("W", bound=_Word)


def _from_term(registry: dict[str, type[W]], term: Term, what: str) -> W:
    cls = registry.get(term.name)
    args = constants(term)
    if cls is None or args is None or len(args) != len(cls.__match_args__):
        raise TermError(f"not a {what}: {term}")
    return cls(*args)


# ---------------------------------------------------------------- fluents


@dataclass(frozen=True)
class Attached(_Word):
    name: ClassVar[str] = "attached"
    part: str
    onto: str
    slot: str


@dataclass(frozen=True)
class Holding(_Word):
    name: ClassVar[str] = "holding"
    arm: str
    part: str


@dataclass(frozen=True)
class HumanFree(_Word):
    name: ClassVar[str] = "humanFree"


@dataclass(frozen=True)
class HumanHolding(_Word):
    name: ClassVar[str] = "humanHolding"


@dataclass(frozen=True)
class HumanHoldingPart(_Word):
    name: ClassVar[str] = "humanHoldingPart"
    part: str


@dataclass(frozen=True)
class WantToAttach(_Word):
    name: ClassVar[str] = "wantToAttach"
    part: str
    onto: str


@dataclass(frozen=True)
class AcceptToAttach(_Word):
    name: ClassVar[str] = "acceptToAttach"
    part: str
    onto: str


@dataclass(frozen=True)
class RequestedAttach(_Word):
    name: ClassVar[str] = "requestedAttach"
    part: str
    onto: str


@dataclass(frozen=True)
class Reserved(_Word):
    name: ClassVar[str] = "reserved"
    part: str


@dataclass(frozen=True)
class Declined(_Word):
    name: ClassVar[str] = "declined"
    part: str
    onto: str


@dataclass(frozen=True)
class KeepsHolding(_Word):
    name: ClassVar[str] = "keepsHolding"
    part: str


@dataclass(frozen=True)
class Initiatives(_Word):
    """initiatives(N): the human has taken the initiative N times."""

    name: ClassVar[str] = "initiatives"
    count: str


@dataclass(frozen=True)
class ShapeIs(_Word):
    """The robot has seen that `part` (a foot, or a leg's hole) is `shape`."""

    name: ClassVar[str] = "shapeIs"
    part: str
    shape: str


@dataclass(frozen=True)
class LengthIs(_Word):
    """The robot has seen that the leg `part` is `length`."""

    name: ClassVar[str] = "lengthIs"
    part: str
    length: str


Fluent = (
    Attached | Holding | HumanFree | HumanHolding | HumanHoldingPart | WantToAttach
    | AcceptToAttach | RequestedAttach | Reserved | Declined | KeepsHolding | Initiatives
    | ShapeIs | LengthIs
)
FLUENTS: dict[str, type[Fluent]] = {
    c.name: c
    for c in (
        Attached, Holding, HumanFree, HumanHolding, HumanHoldingPart, WantToAttach,
        AcceptToAttach, RequestedAttach, Reserved, Declined, KeepsHolding, Initiatives,
        ShapeIs, LengthIs,
    )
}  # fmt: skip
# A task pending with the human: the goal is not reached while one is.
TASKS = (WantToAttach.name, AcceptToAttach.name, RequestedAttach.name)

State = frozenset[str]  # canonical fluent texts, see the module docstring


@functools.lru_cache(maxsize=65536)
def parse_fluent(text: str) -> Fluent:
    """The typed fluent of its canonical text; `TermError` if it is not a fluent."""
    return _from_term(FLUENTS, parse_term(text), "fluent")


@dataclass(frozen=True)
class Hands:
    """Who holds what and what is attached where, read from a state."""

    holding: dict[str, str]  # arm -> part
    attached: dict[str, tuple[str, str]]  # part -> (onto, slot)
    human: frozenset[str]  # parts in the human's hands

    @classmethod
    def of(cls, state: Iterable[str]) -> Hands:
        holding: dict[str, str] = {}
        attached: dict[str, tuple[str, str]] = {}
        human: set[str] = set()
        for text in state:
            f = parse_fluent(text)
            if isinstance(f, Holding):
                holding[f.arm] = f.part
            elif isinstance(f, Attached):
                attached[f.part] = (f.onto, f.slot)
            elif isinstance(f, HumanHoldingPart):
                human.add(f.part)
        return cls(holding, attached, frozenset(human))


# ---------------------------------------------------------------- actions


@dataclass(frozen=True)
class Hold(_Word):
    name: ClassVar[str] = "hold"
    kind: ClassVar[str] = "actuation"
    arm: str
    part: str


@dataclass(frozen=True)
class Attach(_Word):
    name: ClassVar[str] = "attach"
    kind: ClassVar[str] = "actuation"
    arm: str
    onto: str
    slot: str


@dataclass(frozen=True)
class Unhold(_Word):
    name: ClassVar[str] = "unhold"
    kind: ClassVar[str] = "actuation"
    arm: str


@dataclass(frozen=True)
class ConfirmAttach(_Word):
    name: ClassVar[str] = "confirmAttach"
    kind: ClassVar[str] = "communication"
    part: str
    onto: str


@dataclass(frozen=True)
class AskHelp(_Word):
    name: ClassVar[str] = "askHelp"
    kind: ClassVar[str] = "communication"
    part: str
    onto: str


@dataclass(frozen=True)
class OfferHelp(_Word):
    name: ClassVar[str] = "offerHelp"
    kind: ClassVar[str] = "communication"
    part: str
    onto: str


@dataclass(frozen=True)
class RequestToUnhold(_Word):
    name: ClassVar[str] = "requestToUnhold"
    kind: ClassVar[str] = "communication"
    part: str


@dataclass(frozen=True)
class RequestToAttach(_Word):
    name: ClassVar[str] = "requestToAttach"
    kind: ClassVar[str] = "communication"
    part: str
    onto: str


# The conversation (deterministic, planned around the task plan by
# planner/talk/conversation.py): greeting, goodbye, warnings, explanations.
@dataclass(frozen=True)
class Greet(_Word):
    name: ClassVar[str] = "greet"
    kind: ClassVar[str] = "communication"


@dataclass(frozen=True)
class Farewell(_Word):
    name: ClassVar[str] = "farewell"
    kind: ClassVar[str] = "communication"


@dataclass(frozen=True)
class WarnWorking(_Word):
    """Before an arm works in `region` while the human's hands are at the bench."""

    name: ClassVar[str] = "warnWorking"
    kind: ClassVar[str] = "communication"
    region: str


@dataclass(frozen=True)
class WarnDanger(_Word):
    """Before the human is sent where the dangerous `part` lies loose."""

    name: ClassVar[str] = "warnDanger"
    kind: ClassVar[str] = "communication"
    part: str


@dataclass(frozen=True)
class ExplainAsk(_Word):
    """Why the robot asks for `part`: no arm reaches it."""

    name: ClassVar[str] = "explainAsk"
    kind: ClassVar[str] = "communication"
    part: str


@dataclass(frozen=True)
class ExplainOwnTask(_Word):
    """Why the robot handles `part` itself: it is dangerous."""

    name: ClassVar[str] = "explainOwnTask"
    kind: ClassVar[str] = "communication"
    part: str


# Sensing actions are `sense(Query)`; each query is its own class, so that the
# action `sense(humanHolding)` and the fluent `humanHolding` never share a name.
@dataclass(frozen=True)
class _Sensing(_Word):
    """`name` is the query's; the action's text wraps it in `sense(...)`."""

    def __str__(self) -> str:
        return f"sense({super().__str__()})"


@dataclass(frozen=True)
class SenseHumanHolding(_Sensing):
    name: ClassVar[str] = "humanHolding"
    kind: ClassVar[str] = "sensing"


@dataclass(frozen=True)
class SenseHumanHoldingWhichPart(_Sensing):
    name: ClassVar[str] = "humanHoldingWhichPart"
    kind: ClassVar[str] = "sensing"


@dataclass(frozen=True)
class SenseHumanUnholding(_Sensing):
    name: ClassVar[str] = "humanUnholding"
    kind: ClassVar[str] = "sensing"
    part: str


@dataclass(frozen=True)
class SenseHumanAttachingWhere(_Sensing):
    name: ClassVar[str] = "humanAttachingWhere"
    kind: ClassVar[str] = "sensing"
    part: str
    onto: str


@dataclass(frozen=True)
class SenseShapeOf(_Sensing):
    """Look at `part`: its shape (a leg: its hole's) is one outcome per option."""

    name: ClassVar[str] = "shapeOf"
    kind: ClassVar[str] = "sensing"
    part: str


@dataclass(frozen=True)
class SenseLengthOf(_Sensing):
    """Look at the leg `part`: its length is one outcome per option."""

    name: ClassVar[str] = "lengthOf"
    kind: ClassVar[str] = "sensing"
    part: str


Actuation = Hold | Attach | Unhold
Conversation = Greet | Farewell | WarnWorking | WarnDanger | ExplainAsk | ExplainOwnTask
Communication = (
    ConfirmAttach | AskHelp | OfferHelp | RequestToUnhold | RequestToAttach | Conversation
)
Sensing = (
    SenseHumanHolding | SenseHumanHoldingWhichPart | SenseHumanUnholding | SenseHumanAttachingWhere
    | SenseShapeOf | SenseLengthOf
)
Action = Actuation | Communication | Sensing

_ACTIONS: dict[str, type[Actuation | Communication]] = {
    c.name: c
    for c in (Hold, Attach, Unhold, ConfirmAttach, AskHelp, OfferHelp, RequestToUnhold,
              RequestToAttach, Greet, Farewell, WarnWorking, WarnDanger, ExplainAsk,
              ExplainOwnTask)
}  # fmt: skip
_QUERIES: dict[str, type[Sensing]] = {
    c.name: c
    for c in (SenseHumanHolding, SenseHumanHoldingWhichPart, SenseHumanUnholding,
              SenseHumanAttachingWhere, SenseShapeOf, SenseLengthOf)
}  # fmt: skip
# Sensing what a part is, rather than what the human does (planned configurations).
PROPERTY_QUERIES = (SenseShapeOf.name, SenseLengthOf.name)
ACTION_TYPES: tuple[type[Action], ...] = (*_ACTIONS.values(), *_QUERIES.values())
# Questions the human answers yes or no; requests are complied with.
QUESTIONS = (ConfirmAttach.name, AskHelp.name, OfferHelp.name)
REQUESTS = (RequestToUnhold.name, RequestToAttach.name)
# Beyond the paper's five: counted apart in the statistics (plan.tree_stats).
GREETINGS = (Greet.name, Farewell.name)
WARNINGS = (WarnWorking.name, WarnDanger.name)
EXPLANATIONS = (ExplainAsk.name, ExplainOwnTask.name)
CONVERSATION = (*GREETINGS, *WARNINGS, *EXPLANATIONS)
KINDS = ("actuation", "sensing", "communication")


@functools.lru_cache(maxsize=65536)
def parse_action(text: str) -> Action:
    """The typed action of its canonical text; `TermError` if it is not an action."""
    term = parse_term(text)
    if term.name == "sense" and len(term.args) == 1:
        return _from_term(_QUERIES, term.args[0], "sensing query")
    return _from_term(_ACTIONS, term, "action")

