"""A part's top-face outline read from rendered frames: real pybullet renders, real
QR decoding and tracking, real OpenCV contours; truth known from the scene."""

from __future__ import annotations

import math
import random
import time
from collections import Counter

import cv2
import numpy as np
import pytest

from perception.codes_image import QUIET_ZONE_MODULES, modules_across
from perception.frames import Image
from perception.layout import BenchLayout, PartShape, Region
from perception.markers import DEFAULT_MARKER_SIZE_M, PartCode, corner_references, encode_part
from perception.outline import OUTLINES, classify_outline, read_outline
from perception.pipeline import BenchPerception, Perceived
from perception.sim import Degradation, SimPart, SimScene, SimulatedCamera

BENCH_TOP_Z = -0.05
BENCH_X = (0.30, 1.40)
BENCH_Y = (-0.70, 0.70)
HARD = Degradation(jitter_m=0.02, blur_px=1.2, noise=6.0, gain=(0.6, 1.3), light_jitter=0.3)
# (id, footprint side, height, x, y): the real-world task's feet (4 cm) and legs
# (4 cm, standing 20 cm tall), and the paper bench's larger feet (8 cm), over the
# bench from the robot's edge to the human's, 32 cm apart: turned any way, no code's
# card hangs over another part's face (a leg's reaches ~25 cm from its centre).
PARTS = (
    ("foot1", 0.04, 0.03, 0.48, -0.48),
    ("foot2", 0.04, 0.03, 0.48, -0.16),
    ("foot3", 0.04, 0.03, 0.48, 0.16),
    ("foot4", 0.04, 0.03, 0.48, 0.48),
    ("foot5", 0.04, 0.03, 0.80, -0.48),
    ("foot6", 0.04, 0.03, 1.12, -0.48),
    ("big1", 0.08, 0.04, 0.80, 0.48),
    ("big2", 0.08, 0.04, 1.12, -0.16),
    ("leg1", 0.04, 0.20, 0.80, -0.16),
    ("leg2", 0.04, 0.20, 1.12, 0.48),
)
CONFIGURATIONS = 4
FRAMES = 50  # per configuration: 200 frames in all


def _card(part_id: str, marker: int) -> float:
    modules = modules_across(encode_part(part_id, marker))
    return DEFAULT_MARKER_SIZE_M * (modules + 2 * QUIET_ZONE_MODULES) / modules


def _code_offset(part_id: str, marker: int, side: float) -> tuple[float, float]:
    # As app.camera_bench puts them: a leg's code a code's width along x from its foot
    # point; a foot's on a card beside its face, 1 cm clear, towards -y.
    card = _card(part_id, marker)
    if part_id.startswith("leg"):
        return (card + 0.005, 0.0)
    return (0.0, -(side / 2 + 0.01 + card / 2))


def bench(seed: int) -> tuple[BenchLayout, SimScene, dict[str, str]]:
    rng = random.Random(seed)
    shapes: dict[str, PartShape] = {}
    parts: list[SimPart] = []
    truth: dict[str, str] = {}
    for marker, (pid, side, height, x, y) in enumerate(PARTS, start=1):
        size = (side, side, height)
        offset = _code_offset(pid, marker, side)
        slots = {"foot": (0.0, 0.0)} if pid.startswith("leg") else {}
        shapes[pid] = PartShape(size, slots, offset, OUTLINES)
        truth[pid] = rng.choice(OUTLINES)
        parts.append(SimPart(
            pid, size, (x, y, BENCH_TOP_Z + height / 2), encode_part(pid, marker),
            yaw=rng.uniform(-math.pi, math.pi), colour=(0.85, 0.70, 0.70),
            code_offset=offset, profile=truth[pid],
        ))  # fmt: skip
    references = corner_references(BENCH_X, BENCH_Y)
    layout = BenchLayout(
        (Region("robotOnly", 0.30, 0.65), Region("shared", 0.65, 1.00),
         Region("humanOnly", 1.00, 1.40)),
        BENCH_TOP_Z, BENCH_X, BENCH_Y, BENCH_X[1], shapes, references,
    )  # fmt: skip
    scene = SimScene(tuple(parts), references, BENCH_TOP_Z, BENCH_X, BENCH_Y)
    return layout, scene, truth


def _time_looks(image: Image, perception: BenchPerception, perceived: Perceived) -> float:
    """Seconds the frame's looks take, read again outside the pipeline's votes."""
    start = time.perf_counter()
    for detection in perceived.observation.detections:
        if isinstance(detection.code, PartCode):
            face = perception.outlines.face(detection.code.part_id, detection.code.marker_id)
            if face is not None:
                read_outline(image, face, detection.corners)
    return time.perf_counter() - start


@pytest.mark.parametrize("shape", OUTLINES)
@pytest.mark.parametrize("side_px", [12, 20, 40, 90])
def test_drawn_outlines_are_told_apart(shape: str, side_px: int) -> None:
    """Outlines drawn at sizes from a far 4 cm foot to a near 8 cm one, turned."""
    for turn in (0.0, 0.4, 1.1):
        image = np.zeros((3 * side_px, 3 * side_px), np.uint8)
        c = 1.5 * side_px
        if shape == "circle":
            corners = [(c + side_px / 2 * math.cos(a), c + side_px / 2 * math.sin(a))
                       for a in np.linspace(0, 2 * math.pi, 64, endpoint=False)]
        else:
            k = 3 if shape == "triangle" else 4
            radius = side_px / math.sqrt(3) if k == 3 else side_px / math.sqrt(2)
            corners = [(c + radius * math.cos(turn + 2 * math.pi * i / k),
                        c + radius * math.sin(turn + 2 * math.pi * i / k)) for i in range(k)]
        cv2.fillPoly(image, [np.round(np.array(corners)).astype(np.int32)], 255)
        contours, _ = cv2.findContours(image, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        scale = side_px / 0.04  # pixels a metre, for a 4 cm face
        reading = classify_outline(contours[0].astype(np.float32), scale, (0.04, 0.04))
        assert reading.shape == shape, (turn, reading)
        assert reading.confidence > 0.3, (turn, reading)


def test_outlines_right_in_200_degraded_frames() -> None:
    """Per frame, each part whose code decodes gets one look: the share of looks that
    read its true outline, over 200 frames with jitter, blur, noise and lighting."""
    right: Counter[str] = Counter()
    looks: Counter[str] = Counter()
    confusion: Counter[tuple[str, str | None]] = Counter()
    voted_wrong: list[tuple[int, str, str, object]] = []
    voted = frames = 0
    seconds = 0.0
    for seed in range(CONFIGURATIONS):
        layout, scene, truth = bench(seed)
        degradation = Degradation(**{**HARD.__dict__, "seed": 100 + seed})
        with SimulatedCamera(scene, degradation=degradation) as camera:
            perception = BenchPerception(camera.intrinsics, layout)
            for _ in range(FRAMES):
                frame = camera.read()
                perceived = perception.process(frame)
                world = perceived.world
                frames += 1
                for pid, reading in perception.outlines.readings.items():
                    kind = "leg" if pid.startswith("leg") else "foot"
                    looks[kind] += 1
                    right[kind] += reading.shape == truth[pid]
                    confusion[(truth[pid], reading.shape)] += 1
                seconds += _time_looks(frame.image, perception, perceived)
        for pid, shape in truth.items():
            estimate = world.parts[pid].outline
            if estimate is None:
                continue  # its code never decoded (another's card over it): no looks
            voted += 1
            if estimate.shape != shape:
                voted_wrong.append((seed, pid, shape, estimate))
    feet = right["foot"] / looks["foot"]
    legs = right["leg"] / looks["leg"]
    print(f"\n{frames} frames: feet {right['foot']}/{looks['foot']} looks right ({feet:.1%}), "
          f"standing legs {right['leg']}/{looks['leg']} ({legs:.1%}); "
          f"voted wrong {len(voted_wrong)}/{voted}; {dict(confusion)}; "
          f"{seconds / frames * 1e3:.1f} ms of looks a frame")
    assert frames >= 200
    # Most codes decode in these frames, so most parts are looked at in most frames.
    assert looks["foot"] >= 0.8 * frames * 8
    assert feet >= 0.95
    assert legs >= 0.95
    assert voted >= 0.9 * len(PARTS) * CONFIGURATIONS
    assert not voted_wrong
