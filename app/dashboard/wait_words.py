"""What a waiting question says while it waits: how long, and what each source
that may answer it is doing (the camera looking, the voice listening).

Pure (no viser): the execution panel calls `wait_line` about twice a second
while a node with outcomes waits for its answer. A wait of many seconds with
only "waiting for an answer" on screen left a person guessing whether anything
was happening.
"""

from __future__ import annotations

from dataclasses import dataclass

STALE_S = 2.0  # a camera with no new view for this long is said to be stuck


@dataclass(frozen=True)
class CameraNews:
    """The running camera's latest view: part codes seen of those it looks for,
    whether its belief still settles, and how old the view is."""

    seen: int
    of: int
    settling: bool
    age_s: float


@dataclass(frozen=True)
class Waiting:
    """A node waiting for its answer: `camera` when the camera answers it, `voice`
    when the voice does, `heard` the voice's last turn in this wait."""

    node_id: str
    action: str
    waited_s: float
    camera: CameraNews | None = None
    camera_on: bool = False
    voice: bool = False
    heard: str | None = None


def camera_words(news: CameraNews | None) -> str:
    if news is None:
        return "the camera is starting: no frame yet"
    if news.age_s > STALE_S:
        return f"the camera has sent no frame for {news.age_s:.0f} s"
    of = f" of {news.of}" if news.of else ""
    settling = ", settling (the parts it sees still move)" if news.settling else ""
    return f"the camera is looking: seen {news.seen}{of} markers{settling}"


def wait_line(waiting: Waiting) -> str:
    """One line: the node, the time waited, each answering source's doing."""
    doing: list[str] = []
    if waiting.camera_on:
        doing.append(camera_words(waiting.camera))
    if waiting.voice:
        heard = f"; heard {waiting.heard}" if waiting.heard else ""
        doing.append(f"the voice is listening{heard}")
    doing.append("a click answers for the human" if len(doing) == 0
                 else "or a click answers for the human")  # fmt: skip
    said = "; ".join(doing)
    return (
        f"`{waiting.node_id}` **{waiting.action}**: waiting for an answer for "
        f"{waiting.waited_s:.0f} s. {said[0].upper()}{said[1:]}."
    )
