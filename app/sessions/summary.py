"""Evidence in words: one line for a session listing (`tandem sessions show`).

Kept apart from the sources that write the evidence, so listing sessions
imports no speech or camera code. A camera's evidence has `camera` (its
reading) and, in simulated runs, `truth` (the label the simulated human acted
out); a voice's has `answered_by`, `heard`, `tries` and, simulated, `truth`
(what the human said); a spoken line has `engine`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from app.execution.events import ExecutionEvent


def summary(event: ExecutionEvent) -> str | None:
    """What decided the event's answer and what was said, if its evidence says (else None)."""
    if event.evidence is None:
        return None
    detail = event.evidence.detail
    parts: list[str] = []
    camera = detail.get("camera")
    if isinstance(camera, Mapping):
        # The camera's reason is already in the event's text.
        parts.append(
            f"camera: confidence {camera.get('confidence')}, "
            f"{camera.get('frames')} frames, {camera.get('seconds')} s"
        )
    if event.evidence.jpeg is not None:
        parts.append(f"frame {len(event.evidence.jpeg) / 1024:.1f} kB JPEG")
    if "answered_by" in detail:
        tries = detail.get("tries", 0)
        parts.append(
            f"heard '{detail.get('heard') or '-'}' (confidence {detail.get('confidence', 0.0)}, "
            f"{tries} {'try' if tries == 1 else 'tries'}), answered by {detail['answered_by']}"
        )
    truth = detail.get("truth")
    if isinstance(truth, Mapping):
        said = " / ".join(str(w) for w in truth.get("said", ()))
        parts.append(f"the simulated human said '{said}' ({truth.get('answer')})")
    elif isinstance(truth, str):
        parts.append(f"truth {truth}: " + ("agrees" if truth == event.outcome else "DISAGREES"))
    if "engine" in detail:
        parts.append(f"spoken by {detail['engine']}")
    return "; ".join(parts) or None


def camera_agreement(events: Sequence[ExecutionEvent]) -> tuple[int, int]:
    """(camera answers equal to the stored truth, camera answers with a truth)."""
    judged = [
        e.outcome == e.evidence.detail["truth"]
        for e in events
        if e.source == "camera" and e.evidence is not None and "truth" in e.evidence.detail
    ]
    return sum(judged), len(judged)
