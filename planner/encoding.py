"""The ASP program: one file per concern, loaded in a fixed order."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from importlib import resources

import clingo

CONCERNS = (
    "state",
    "actuation",
    "sensing",
    "communication",
    "commonsense",
    "safety",
    "feasibility",
    "goal",
    "milestones",
    "preferences",
)


def program_text(skip: Iterable[str] = ()) -> str:
    """The encodings concatenated; `skip` leaves concerns out (for ablation tests)."""
    skipped = set(skip)
    unknown = skipped - set(CONCERNS)
    if unknown:
        raise ValueError(f"unknown concern(s): {', '.join(sorted(unknown))}")
    base = resources.files("planner") / "asp"
    return "\n".join((base / f"{name}.lp").read_text() for name in CONCERNS if name not in skipped)


class FeasibilityContext:
    """Answers `@reachable(M,P)` from a predicate; counts the calls it served."""

    def __init__(self, reachable: Callable[[str, str], bool]) -> None:
        self._reachable = reachable
        self.calls = 0

    def reachable(self, arm: clingo.Symbol, part: clingo.Symbol) -> clingo.Symbol:
        self.calls += 1
        return clingo.Number(1 if self._reachable(arm.name, part.name) else 0)


def ground(
    facts: Iterable[str],
    horizon: int,
    context: FeasibilityContext,
    *,
    skip: Iterable[str] = (),
    options: Iterable[str] = (),
) -> clingo.Control:
    """Ground the domain once for `horizon` steps; later solves only change externals."""
    ctl = clingo.Control(["-c", f"h={horizon}", *options], logger=_quiet)
    ctl.add("base", [], program_text(skip))
    ctl.add("base", [], "\n".join(f"{f}." for f in facts))
    ctl.ground([("base", [])], context=context)
    return ctl


def _quiet(code: clingo.MessageCode, message: str) -> None:
    # Info messages about atoms that never occur are expected when concerns
    # are skipped; real errors raise from clingo itself.
    return None
