"""The review's downloads: the opened session as JSON, CSV or MCAP (session_files.py).

A click on "Export MCAP" (or JSON, CSV) makes the file and sends it to the page
that clicked; viser shows it as a link named after the file
(`tandem-session-12.mcap`), and a click on the link saves it under that name.
An MCAP file places the parts and the robot with the session's scenario: the
one loaded when its hash is the session's, else the shipped one with that hash.
"""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.dashboard.operator import Click
from app.dashboard.session_files import FILE_FORMATS, FileFormat, file_name, scenario_of
from app.dashboard.session_files import session_file as make_file
from app.dashboard.stage import Stage
from app.sessions.store import SessionRecord, SessionStore

# viser shows a file sent for download as a link in a notification 20em wide, its
# label cut where it overflows ("tandem-session-1.csv (2"): a notification holding
# a download is made wider, and its label wraps (after the name, before the size)
# instead of being cut.
WHOLE_NAMES = (
    "<style>"
    ".mantine-Notifications-root:has(a[download])"
    "{--notifications-container-width:28em !important}"
    ".mantine-Notification-description a[download] .mantine-Button-root"
    "{height:auto;min-height:var(--button-height);padding-block:0.3em}"
    ".mantine-Notification-description a[download] .mantine-Button-label"
    "{white-space:normal;overflow:visible;overflow-wrap:anywhere;text-align:left}"
    "</style>"
)


class SessionDownloads:
    """One button per file format; `opened` says which session the review shows."""

    def __init__(
        self,
        gui: viser.GuiApi,
        stage: Stage,
        store: SessionStore,
        opened: Callable[[], SessionRecord | None],
    ) -> None:
        self.stage = stage
        self.store = store
        self.opened = opened
        gui.add_html(WHOLE_NAMES)
        for kind in FILE_FORMATS:
            gui.add_button(f"Export {kind.upper()}").on_click(self._sender(kind))

    def _sender(self, kind: FileFormat) -> Callable[[Click], None]:
        return lambda event: self.send(event.client, kind)

    def send(self, client: viser.ClientHandle | None, kind: FileFormat) -> None:
        session = self.opened()
        if session is None or client is None:
            return
        scenario = None
        if kind == "mcap":
            scenario = scenario_of(session.scenario_sha256, self.stage.current_scenario())
        content = make_file(self.store, session.id, kind, scenario)
        client.send_file_download(file_name(session.id, kind), content)
