"""Where the outcomes of nondeterministic actions come from while a plan runs.

A sensing action (is the human holding a part? which one?) or a question to
the human (askHelp, offerHelp, confirmAttach) has several outcomes; the plan
has a branch for each. During an execution an `OutcomeSource` picks the one
that happened: a click in the dashboard, a line of a script, a seeded random
choice, or the outcome the planner expected. `FallbackSource` chains two, so
a source that has no answer (a timeout, the end of a script) or fails never
stops the session.
"""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Protocol

from app.execution.events import (
    AnswerSource,
    Attachable,
    ExecutionControls,
    Interruptible,
    Node,
    Outcome,
    OutcomeError,
    OutcomeSource,
    describe,
)
from app.execution.evidence import Clicked, Evidence
from app.execution.surprises import SurpriseError, parse_surprise
from planner.vocabulary import (
    Action,
    SenseHumanAttachingWhere,
)


class ScriptError(OutcomeError):
    """A scripted response file is unreadable or names a label the plan does not have."""


class ExpectedSource:
    """The outcome the planner hoped for (the node's `expected`), else the first."""

    name: AnswerSource = "expected"

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        if not options:
            return None
        expected = node.expected
        label = expected if isinstance(expected, str) and expected in options else options[0]
        return Outcome(label, self.name, None, describe(node.action, label))


class RandomSource:
    """A uniform choice among the options; the same seed gives the same choices."""

    name: AnswerSource = "random"

    def __init__(self, seed: int | None = None) -> None:
        self.seed = seed
        self._rng = random.Random(seed)
        self._lock = threading.Lock()

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        if not options:
            return None
        with self._lock:
            label = self._rng.choice(list(options))
        return Outcome(label, self.name, 1.0 / len(options), describe(node.action, label))


@dataclass(frozen=True)
class ScriptLine:
    number: int
    label: str


class ScriptedSource:
    """Outcome labels read from a text file, one a line, `#` starting a comment.

    A line `!attach leg2 top c2` is a surprise (app.execution.surprises): what the human
    did instead of any outcome, which makes the executor repair the plan. At a
    `sense(humanAttachingWhere(P,Q))` node a connection point of Q that is not the
    branch's names the free slot the human really used (the executor follows it).
    Each nondeterministic node takes the next line. When the lines run out
    the source has no answer (None); a label that is not an outcome of the
    node raises `ScriptError` naming the file and the line.
    """

    name: AnswerSource = "scripted"

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            text = self.path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            raise ScriptError(f"{self.path}: cannot read responses: {err}") from err
        self.lines = parse_script(text)
        for line in self.lines:
            if line.label.startswith("!"):
                try:
                    parse_surprise(line.label[1:])
                except SurpriseError as err:
                    raise ScriptError(f"{self.path}:{line.number}: {err}") from None
        self._next = 0
        self._lock = threading.Lock()

    def check_labels(self, known: set[str]) -> None:
        """Raises `ScriptError` for the first line whose label no node of the plan has."""
        for line in self.lines:
            if line.label not in known and not line.label.startswith("!"):
                raise ScriptError(
                    f"{self.path}:{line.number}: '{line.label}' is not an outcome in this plan "
                    f"(known: {', '.join(sorted(known))})"
                )

    @property
    def remaining(self) -> int:
        with self._lock:
            return len(self.lines) - self._next

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        with self._lock:
            if self._next >= len(self.lines):
                return None
            line = self.lines[self._next]
            self._next += 1
        if line.label.startswith("!"):
            surprise = parse_surprise(line.label[1:])
            return Outcome("", self.name, 1.0, str(surprise), surprise=surprise)
        if line.label not in options and isinstance(node.action, SenseHumanAttachingWhere):
            # Another slot than the branch names: the executor checks that it is free.
            return Outcome(
                options[0], self.name, 1.0, describe(node.action, line.label), slot=line.label
            )
        if line.label not in options:
            raise ScriptError(
                f"{self.path}:{line.number}: '{line.label}' is not an outcome of "
                f"{node.action} at {node_id} (one of: {', '.join(options)})"
            )
        return Outcome(line.label, self.name, 1.0, describe(node.action, line.label))


def parse_script(text: str) -> list[ScriptLine]:
    out: list[ScriptLine] = []
    for number, raw in enumerate(text.splitlines(), 1):
        label = raw.split("#", 1)[0].strip()
        if label:
            out.append(ScriptLine(number, label))
    return out


@dataclass(frozen=True)
class Offer:
    """A question waiting for a click: the node and its outcome labels, with words."""

    node_id: str
    action: Action | None
    options: tuple[str, ...]
    words: tuple[str, ...]
    since: float = field(default_factory=time.monotonic, compare=False)  # when first offered


class SlotChoices(Protocol):
    """Where the human may attach at a humanAttachingWhere node (the executor knows)."""

    def slot_choices(self, node: Node) -> list[str]: ...

    def slot_label(self, node: Node, options: Sequence[str], real: str) -> str: ...


class ClickSource:
    """Outcomes clicked in the dashboard.

    With `slots` (the executor), a humanAttachingWhere node offers every free slot of
    the world, not only the branch's: a click on another one is followed there.

    `choose` (the executor's thread) offers the node's options and waits up to
    `timeout` seconds for `click(label)` from another thread. `on_offer(offer)`
    is called when a question starts waiting and `on_offer(None)` when it is
    answered or given up, so a panel draws its buttons without polling;
    `pending()` is the question waiting now. `interrupt()` makes a waiting (or
    the next) `choose` return None at once, so an aborted execution is not stuck.
    """

    name: AnswerSource = "click"

    def __init__(
        self,
        timeout: float | None = 1.0,
        on_offer: Callable[[Offer | None], None] | None = None,
    ) -> None:
        self.timeout = timeout
        self.on_offer = on_offer
        self.slots: SlotChoices | None = None
        self._cond = threading.Condition()
        self._offer: Offer | None = None
        self._clicked: str | None = None
        self._interrupted = False

    def offer(self, node_id: str, options: Sequence[str], action: Action | None = None) -> Offer:
        with self._cond:
            fresh = self._offer is None or self._offer.node_id != node_id
            if fresh:
                words = tuple(describe(action, o) for o in options)
                self._offer = Offer(node_id, action, tuple(options), words)
                self._clicked = None
            offer = self._offer
            assert offer is not None
        if fresh and self.on_offer is not None:
            self.on_offer(offer)  # outside the lock: the panel may call click() meanwhile
        return offer

    def pending(self) -> Offer | None:
        with self._cond:
            return self._offer

    def click(self, label: str, node_id: str | None = None) -> bool:
        """Answers the pending offer; False if nothing is offered or `label` is not an option."""
        with self._cond:
            offer = self._offer
            if offer is None or label not in offer.options:
                return False
            if node_id is not None and node_id != offer.node_id:
                return False
            self._clicked = label
            self._cond.notify_all()
            return True

    def interrupt(self) -> None:
        with self._cond:
            self._interrupted = True
            self._cond.notify_all()

    def clicked(self, node_id: str) -> bool:
        """Whether the offer at `node_id` has been clicked and not yet taken."""
        with self._cond:
            offer = self._offer
            return offer is not None and offer.node_id == node_id and self._clicked is not None

    def withdraw(self, node_id: str) -> None:
        """Takes the offer at `node_id` back (another source answered it)."""
        with self._cond:
            if self._offer is None or self._offer.node_id != node_id:
                return
            self._offer = None
            self._clicked = None
        if self.on_offer is not None:
            self.on_offer(None)

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        action = node.action
        slots = self.slots if isinstance(action, SenseHumanAttachingWhere) else None
        choices = slots.slot_choices(node) if slots is not None else []
        self.offer(node_id, choices or options, action)
        with self._cond:
            self._cond.wait_for(
                lambda: self._clicked is not None or self._interrupted, self.timeout
            )
            label, offer = self._clicked, self._offer
            if label is None or offer is None:
                # A timeout, or an interrupt (consumed here: at worst one extra "no answer").
                self._interrupted = False
                return None
            self._offer = None
            self._clicked = None
        if self.on_offer is not None:
            self.on_offer(None)
        waited = round(time.monotonic() - offer.since, 3)
        evidence = Evidence(clicked=Clicked(offer.options, waited))
        if slots is not None and choices:
            # A slot of the world was clicked: the branch it falls in, followed there.
            branch = slots.slot_label(node, options, label)
            words = describe(action, label)
            return Outcome(branch, self.name, 1.0, words, evidence, slot=label)
        return Outcome(label, self.name, 1.0, describe(action, label), evidence)


class ConsoleSource:
    """Numbered choices on a terminal: the headless stand-in for clicks.

    Reads a number (or a label) per question from `reader`; at the end of
    input it has no answer (None).
    """

    name: AnswerSource = "console"

    def __init__(self, reader: IO[str], writer: IO[str]) -> None:
        self.reader = reader
        self.writer = writer

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        action = node.action
        if node.say:
            print(f'  robot: "{node.say}"', file=self.writer)
        print(f"{node_id} {action}:", file=self.writer)
        for i, label in enumerate(options, 1):
            print(f"  {i}) {describe(action, label)}", file=self.writer)
        while True:
            print("choice> ", end="", file=self.writer, flush=True)
            line = self.reader.readline()
            if not line:
                print(file=self.writer)
                return None
            answer = line.strip()
            if not self.reader.isatty():
                print(answer, file=self.writer)  # what a terminal would have echoed
            if answer.isdigit() and 1 <= int(answer) <= len(options):
                label = options[int(answer) - 1]
                return Outcome(label, self.name, 1.0, describe(action, label))
            if answer in options:
                return Outcome(answer, self.name, 1.0, describe(action, answer))
            print(f"  answer 1-{len(options)}", file=self.writer)


class FallbackSource:
    """Asks `primary`; when it has no answer, fails or answers wrongly, asks `fallback`.

    `on_fallback(node_id, reason)` is told why (for a log line); the outcome
    taken from the fallback carries the fallback's `source`.
    """

    def __init__(
        self,
        primary: OutcomeSource,
        fallback: OutcomeSource,
        on_fallback: Callable[[str, str], None] | None = None,
    ) -> None:
        self.primary = primary
        self.fallback = fallback
        self.on_fallback = on_fallback

    def interrupt(self) -> None:
        for source in (self.primary, self.fallback):
            if isinstance(source, Interruptible):
                source.interrupt()

    # Both are handed the execution the walker attaches (a live camera keeps the
    # human's actions it sees), as if each answered alone.
    def attach(self, controls: ExecutionControls) -> None:
        for source in (self.primary, self.fallback):
            if isinstance(source, Attachable):
                source.attach(controls)

    def detach(self, controls: ExecutionControls) -> None:
        for source in (self.primary, self.fallback):
            if isinstance(source, Attachable):
                source.detach(controls)

    def choose(self, node_id: str, node: Node, options: Sequence[str]) -> Outcome | None:
        reason: str
        try:
            outcome = self.primary.choose(node_id, node, options)
        except Exception as err:  # any failure of the primary falls back
            reason = str(err) or type(err).__name__
        else:
            if outcome is not None and (outcome.label in options or outcome.surprise):
                return outcome  # a surprise goes to the executor, which plans again
            reason = (
                "no answer"
                if outcome is None
                else f"'{outcome.label}' is not one of {', '.join(options)}"
            )
        if self.on_fallback is not None:
            self.on_fallback(node_id, reason)
        return self.fallback.choose(node_id, node, options)
