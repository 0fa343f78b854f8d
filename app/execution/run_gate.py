"""The run's gate: pause, single steps, resume and abort, safe from any thread.

The executor's walk passes the gate before every node (`before_node`), inside
a node's motion (`within_node`: a single step's motion goes to its end) and
while it waits (`sleep`); each raises `Aborted` once the run is aborted. The
controls (`pause`, `resume`, `step`, `abort`, `stop`) come from the dashboard's
buttons, the voice's "stop", a signal.
"""

from __future__ import annotations

import threading
import time


class Aborted(Exception):
    """The run was aborted while the walk waited at the gate."""


class RunGate:
    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._paused = False
        self._credits = 0  # steps allowed while paused
        self._stepping = False  # a single step runs: its motion goes to its end
        self._aborted = False
        self._stopped_by: str | None = None  # why the walk was interrupted

    # -- controls (any thread) ------------------------------------------------

    def pause(self) -> bool:
        """Pauses before the next node; whether it was paused already."""
        with self._cond:
            was = self._paused
            self._paused = True
            self._credits = 0
            self._stepping = False
            self._cond.notify_all()
        return was

    def resume(self) -> bool:
        """Goes on; whether it was paused."""
        with self._cond:
            was = self._paused
            self._paused = False
            self._credits = 0
            self._cond.notify_all()
        return was

    def step(self) -> None:
        """Single-step mode: pauses, and lets exactly one more node run."""
        with self._cond:
            self._paused = True
            self._credits += 1
            self._cond.notify_all()

    def abort(self) -> None:
        with self._cond:
            self._aborted = True
            self._cond.notify_all()

    def stop(self, reason: str) -> None:
        """Aborts, saying why (the program is stopping, not the operator)."""
        with self._cond:
            self._stopped_by = reason
        self.abort()

    @property
    def paused(self) -> bool:
        with self._cond:
            return self._paused

    @property
    def aborted(self) -> bool:
        with self._cond:
            return self._aborted

    @property
    def stopped_by(self) -> str | None:
        with self._cond:
            return self._stopped_by

    # -- the walk's side ---------------------------------------------------------

    def before_node(self) -> None:
        """Waits while paused (unless a single step is allowed); raises when aborted."""
        with self._cond:
            while True:
                if self._aborted:
                    raise Aborted
                if not self._paused:
                    self._stepping = False
                    return
                if self._credits > 0:
                    self._credits -= 1
                    self._stepping = True
                    return
                self._cond.wait()

    def within_node(self) -> None:
        """Waits while paused, unless a single step runs; raises when aborted."""
        with self._cond:
            while self._paused and not self._stepping and not self._aborted:
                self._cond.wait()
            if self._aborted:
                raise Aborted

    def sleep(self, seconds: float) -> None:
        """Waits `seconds`, or raises as soon as the run is aborted."""
        if seconds <= 0:
            if self.aborted:
                raise Aborted
            return
        deadline = time.monotonic() + seconds
        with self._cond:
            while not self._aborted:
                left = deadline - time.monotonic()
                if left <= 0:
                    return
                self._cond.wait(left)
            raise Aborted
