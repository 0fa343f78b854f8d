"""A reviewed session's measures as a compact markdown table (app.sessions.metrics).

Pure (no viser): `metrics_markdown(events, clock)` puts each agent's active and idle
time (seconds and share of the task) in a small table, then the task time,
the concurrent activity and the functional delay, the questions by kind, the
repairs and the fallbacks to clicks, and, in a simulated run, how often the
camera and the voice agreed with the truth. A session stored before events
were timed says "untimed" and keeps its counts.
"""

from __future__ import annotations

from collections.abc import Sequence

from app.execution.events import ExecutionEvent
from app.sessions.metrics import QUESTION_KINDS, SessionMetrics, session_metrics


def _seconds(value: float | None, task: float | None = None) -> str:
    if value is None:
        return "–"
    share = f" · {value / task:.0%}" if task else ""
    return f"{value:.1f} s{share}"


def _agents(m: SessionMetrics) -> str:
    return "\n".join((
        "| | robot | human |",
        "|---|---|---|",
        f"| active | {_seconds(m.robot_active_s, m.task_s)} | "
        f"{_seconds(m.human_active_s, m.task_s)} |",
        f"| idle | {_seconds(m.robot_idle_s, m.task_s)} | {_seconds(m.human_idle_s, m.task_s)} |",
    ))  # fmt: skip


def _questions(m: SessionMetrics) -> str:
    asked = [(kind, getattr(m, kind), getattr(m, f"{kind}_answer_s")) for kind in QUESTION_KINDS]
    parts = [
        f"{kind} {n}" + (f" (answered in {seconds:.1f} s)" if seconds is not None else "")
        for kind, n, seconds in asked
        if n
    ]
    total = sum(n for _, n, _ in asked)
    return f"**Questions** {total}" + (f": {', '.join(parts)}" if parts else "")


def _agreement(m: SessionMetrics) -> str:
    said = [
        f"{who} agreed {share:.0%} of {n}"
        for who, n, share in (("camera", m.camera_answers, m.camera_agreement),
                              ("voice", m.voice_answers, m.voice_agreement))  # fmt: skip
        if n and share is not None
    ]
    return f" · {'; '.join(said)} with the simulated human" if said else ""


def metrics_markdown(events: Sequence[ExecutionEvent], clock: str | None) -> str:
    """The session's measures, for the review beside its timeline (`clock`: the
    session's, `SessionRecord.clock`)."""
    if not events:
        return ""
    m = session_metrics(events, clock)
    counts = (f"{_questions(m)} · **repairs** {m.repairs} · **fallbacks to clicks** "
              f"{m.fallbacks}{_agreement(m)}")  # fmt: skip
    if not m.timed:
        why = "stored before steps had times and sessions a clock"
        return f"**Metrics** (untimed: {why}): {m.steps} steps. {counts}"
    task = m.task_s
    delay = _seconds(m.functional_delay_s, task)
    return "\n\n".join((
        f"**Metrics**: task {_seconds(task)} · concurrent "
        f"{_seconds(m.concurrent_s, task)} · functional delay {delay}",
        _agents(m),
        counts,
    ))  # fmt: skip
