"""What a code says: payloads naming a part or a reference point of the bench.

Payloads are short ASCII so the QR symbol stays at version 1-2 (21-25 modules):
fewer, larger modules decode from further away.

- a part:      ``TDM:P:<marker id>:<part id>``  e.g. ``TDM:P:3:leg1``
- a reference: ``TDM:R:<name>``                 e.g. ``TDM:R:near-left``

Reference markers lie flat on the bench top at known positions and fix the bench
frame: the camera's pose comes from their corners. Their own axes are the bench's
(the code's rightward edge along +x, its upward edge along +y, its face up +z).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

PAYLOAD_PREFIX = "TDM"
DEFAULT_MARKER_SIZE_M = 0.10  # side of a printed code, quiet zone excluded
# Part ids as the scenario spells them; no ':' so the payload splits unambiguously.
_PART_ID = re.compile(r"^[A-Za-z0-9_.\-]{1,40}$")
_NAME = _PART_ID


@dataclass(frozen=True)
class PartCode:
    """A code that identifies a part (and the scenario's marker id for it)."""

    part_id: str
    marker_id: int


@dataclass(frozen=True)
class ReferenceCode:
    """A code that marks a known point of the bench."""

    name: str


@dataclass(frozen=True)
class ReferenceMarker:
    """A reference code lying on the bench top, centred at (x, y) in the bench frame."""

    name: str
    x: float
    y: float


MarkerCode = PartCode | ReferenceCode


def encode_part(part_id: str, marker_id: int) -> str:
    if not _PART_ID.match(part_id):
        raise ValueError(f"part id {part_id!r}: letters, digits, '_', '.', '-' only")
    if marker_id < 0:
        raise ValueError(f"marker id {marker_id}: must be >= 0")
    return f"{PAYLOAD_PREFIX}:P:{marker_id}:{part_id}"


def encode_reference(name: str) -> str:
    if not _NAME.match(name):
        raise ValueError(f"reference name {name!r}: letters, digits, '_', '.', '-' only")
    return f"{PAYLOAD_PREFIX}:R:{name}"


def encode(code: MarkerCode) -> str:
    if isinstance(code, PartCode):
        return encode_part(code.part_id, code.marker_id)
    return encode_reference(code.name)


def parse_payload(text: str) -> MarkerCode | None:
    """The code a payload names, or None for a code that is not one of ours
    (a product label, a URL): foreign codes in view are ignored, not guessed at."""
    fields = text.split(":")
    if len(fields) < 3 or fields[0] != PAYLOAD_PREFIX:
        return None
    if fields[1] == "P" and len(fields) == 4:
        marker, part = fields[2], fields[3]
        if marker.isdigit() and _PART_ID.match(part):
            return PartCode(part, int(marker))
        return None
    if fields[1] == "R" and len(fields) == 3 and _NAME.match(fields[2]):
        return ReferenceCode(fields[2])
    return None


def corner_references(
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    marker_size_m: float = DEFAULT_MARKER_SIZE_M,
    inset_m: float = 0.01,
) -> tuple[ReferenceMarker, ...]:
    """Four reference markers, one in each corner of the bench top, `inset_m` from
    the edges: corners are where parts rarely lie, and four spread-out codes give
    the camera pose from 16 well-separated points."""
    off = marker_size_m / 2 + inset_m
    (x0, x1), (y0, y1) = x_range, y_range
    return (
        ReferenceMarker("near-left", x0 + off, y1 - off),
        ReferenceMarker("near-right", x0 + off, y0 + off),
        ReferenceMarker("far-left", x1 - off, y1 - off),
        ReferenceMarker("far-right", x1 - off, y0 + off),
    )
