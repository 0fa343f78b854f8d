"""One operator, many observers: who may drive the running execution.

Every page of a viser server shares one GUI, so every page sees the same
buttons. The page that starts an execution becomes its operator until it
ends; a click on a control of that execution from any other page is refused
there with a notification, and never reaches the executor. Observers still
see everything live: the log, the tree and the bench are broadcast.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import viser

REFUSED_TITLE = "Only the operator can do that"

# A press of a button; the operator's controls are all buttons.
Click = viser.GuiEvent[viser.GuiButtonHandle]


class Operator:
    """The client id of the page driving the execution (None: nobody, anyone may start)."""

    def __init__(self) -> None:
        self._client: int | None = None
        self._lock = threading.Lock()

    @property
    def client(self) -> int | None:
        with self._lock:
            return self._client

    def take(self, client_id: int | None) -> None:
        with self._lock:
            self._client = client_id

    def release(self) -> None:
        with self._lock:
            self._client = None

    def allows(self, client_id: int | None) -> bool:
        """Whether a control used by `client_id` may act (the server itself always may)."""
        with self._lock:
            return client_id is None or self._client is None or client_id == self._client

    def only(self, what: str, handler: Callable[[Click], None]) -> Callable[[Click], None]:
        """`handler`, run only for the operator's page; other pages are told why not."""

        def guarded(event: Click) -> None:
            if self.allows(event.client_id):
                handler(event)
            else:
                refuse(event.client, f"Another page runs this execution: only it can {what}.")

        return guarded


def refuse(client: viser.ClientHandle | None, body: str) -> None:
    """Tells one page (not all) why its click did nothing."""
    if client is not None:
        client.add_notification(REFUSED_TITLE, body, auto_close_seconds=5.0, color="yellow")
