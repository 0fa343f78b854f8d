"""The ASP program: one file per concern, loaded in a fixed order."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from importlib import resources
from importlib.resources.abc import Traversable

import clingo

from planner.resources import encoding_dir

CONCERNS = (
    "state",
    "actuation",
    "sensing",
    "communication",
    "commonsense",
    "configuration",
    "safety",
    "feasibility",
    "goal",
    "milestones",
    "lookahead",
    "preferences",
)


# The fact that makes the planner choose the final configuration (configuration.lp).
PLANNED = "plannedConfiguration"


class EncodingError(RuntimeError):
    """clingo refused an encoding; the message has clingo's own lines (file:line:column)."""


def encoding_files(
    skip: Iterable[str] = (), directory: Traversable | None = None
) -> list[Traversable]:
    """The encodings in load order; `skip` leaves concerns out (for ablation tests)."""
    skipped = set(skip)
    unknown = skipped - set(CONCERNS)
    if unknown:
        raise ValueError(f"unknown concern(s): {', '.join(sorted(unknown))}")
    base = directory if directory is not None else encoding_dir()
    return [base / f"{name}.lp" for name in CONCERNS if name not in skipped]


class FeasibilityContext:
    """Answers `@reachable(M,P)` from a predicate; counts the calls it served."""

    def __init__(self, reachable: Callable[[str, str], bool]) -> None:
        self.predicate = reachable
        self.calls = 0

    def reachable(self, arm: clingo.Symbol, part: clingo.Symbol) -> clingo.Symbol:
        self.calls += 1
        return clingo.Number(1 if self.predicate(arm.name, part.name) else 0)


def ground(
    facts: Iterable[str],
    horizon: int,
    context: FeasibilityContext,
    *,
    skip: Iterable[str] = (),
    options: Iterable[str] = (),
    directory: Traversable | None = None,
    rules: str = "",
) -> clingo.Control:
    """Ground the domain once for `horizon` steps; later solves only change externals.

    Each encoding is loaded from its own file, so clingo's messages name it
    (`.../state.lp:12:3-9: error: syntax error ...`); `directory` replaces the
    shipped encodings (tests break a copy); `rules` are added to them.
    """
    skipped = tuple(skip)
    messages = ClingoMessages(expect_undefined=bool(skipped))
    ctl = clingo.Control(["-c", f"h={horizon}", *options], logger=messages)
    ground_into(ctl, facts, context, messages, skip=skipped, directory=directory, rules=rules)
    return ctl


def ground_into(
    ctl: clingo.Control,
    facts: Iterable[str],
    context: FeasibilityContext,
    messages: ClingoMessages,
    *,
    skip: tuple[str, ...] = (),
    directory: Traversable | None = None,
    rules: str = "",
) -> None:
    """Loads the encodings, `facts` and `rules` into `ctl` and grounds them (`ground`)."""
    facts = list(facts)
    if PLANNED not in facts:
        # A fixed configuration grounds without the planned one's rules: even
        # rules that instantiate nothing reorder clasp's atoms, and so would
        # change which of several optimal plans a fixed scenario gets.
        skip = (*skip, "configuration")
    try:
        for file in encoding_files(skip, directory):
            with resources.as_file(file) as path:
                ctl.load(str(path))
        ctl.add("base", [], "\n".join([*(f"{f}." for f in facts), rules]))
        ctl.ground([("base", [])], context=context)
    except RuntimeError as err:
        raise EncodingError(messages.errors_or(str(err))) from err


class ClingoMessages:
    """clingo's logger: keeps errors for the exception, logs warnings."""

    def __init__(self, *, expect_undefined: bool) -> None:
        # With concerns skipped, atoms that only those concerns derive never occur.
        self.expect_undefined = expect_undefined
        self.errors: list[str] = []

    def __call__(self, code: clingo.MessageCode, message: str) -> None:
        text = message.rstrip()
        if code in _ERRORS or ": error:" in text:
            self.errors.append(text)
        elif not (self.expect_undefined and code == clingo.MessageCode.AtomUndefined):
            _log.warning("clingo: %s", text)

    def errors_or(self, fallback: str) -> str:
        return "\n".join(self.errors) if self.errors else fallback


_ERRORS = {clingo.MessageCode.RuntimeError, clingo.MessageCode.OperationUndefined}
_log = logging.getLogger(__name__)
