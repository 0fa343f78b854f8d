"""Evidence in words: one line for a session listing (`tandem sessions show`).

Kept apart from the sources that write the evidence, so listing sessions
imports no speech or camera code.
"""

from __future__ import annotations

from collections.abc import Mapping


def summary(detail: Mapping[str, object]) -> str | None:
    """What was heard and said at a node, if its evidence says (else None)."""
    parts = []
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
    if "engine" in detail:
        parts.append(f"spoken by {detail['engine']}")
    return "; ".join(parts) or None
