"""Evidence in words: one line for a session listing (`tandem sessions show`).

Kept apart from the sources that write the evidence, so listing sessions
imports no speech or camera code: it reads the typed records of
`app.execution.evidence` (a camera reading, a voice hearing, a spoken line and,
in simulated runs, what the simulated human really did).
"""

from __future__ import annotations

from collections.abc import Sequence

from app.execution.events import ExecutionEvent


def summary(event: ExecutionEvent) -> str | None:
    """What decided the event's answer and what was said, if its evidence says (else None)."""
    evidence = event.evidence
    if evidence is None:
        return None
    parts: list[str] = []
    camera = evidence.camera
    if camera is not None:
        # The camera's reason is already in the event's text.
        parts.append(
            f"camera: confidence {camera.confidence}, {camera.frames} frames, {camera.seconds} s"
        )
    if evidence.jpeg is not None:
        parts.append(f"frame {len(evidence.jpeg) / 1024:.1f} kB JPEG")
    voice = evidence.voice
    if voice is not None:
        tries = f"{voice.tries} {'try' if voice.tries == 1 else 'tries'}"
        parts.append(
            f"heard '{voice.heard or '-'}' (confidence {voice.confidence}, {tries}), "
            f"answered by {voice.answered_by}"
        )
    clicked = evidence.clicked
    if clicked is not None:
        parts.append(f"clicked after {clicked.waited_s} s among {len(clicked.offered)} choices")
    truth = evidence.truth
    if truth is not None and truth.said:
        parts.append(f"the simulated human said '{' / '.join(truth.said)}' ({truth.label})")
    elif truth is not None:
        agrees = "agrees" if truth.label == event.outcome else "DISAGREES"
        parts.append(f"truth {truth.label}: {agrees}")
    engine = evidence.spoken.engine if evidence.spoken else voice.engine if voice else None
    if engine is not None:
        parts.append(f"spoken by {engine}")
    return "; ".join(parts) or None


def camera_agreement(events: Sequence[ExecutionEvent]) -> tuple[int, int]:
    """(camera answers equal to the stored truth, camera answers with a truth)."""
    judged = [
        e.outcome == e.evidence.truth.label
        for e in events
        if e.source == "camera" and e.evidence is not None and e.evidence.truth is not None
    ]
    return sum(judged), len(judged)
