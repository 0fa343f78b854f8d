"""A part's top-face outline read from rendered frames: real pybullet renders, real
QR decoding and tracking, real OpenCV contours; truth known from the scene."""

from __future__ import annotations

import math
import os
from dataclasses import replace

import cv2
import numpy as np
import pytest

from perception.outline import OUTLINES, classify_outline
from perception.outline_bench import HARD, PARTS, outline_bench, score_outlines
from perception.pipeline import BenchPerception
from perception.sim import SimulatedCamera

BENCHES = 4
FRAMES = 50  # per bench: 200 frames in all


@pytest.mark.parametrize("shape", OUTLINES)
@pytest.mark.parametrize("side_px", [12, 20, 40, 90])
def test_drawn_outlines_are_told_apart(shape: str, side_px: int) -> None:
    """Outlines drawn at sizes from a far 4 cm foot to a near 8 cm one, turned."""
    for turn in (0.0, 0.4, 1.1):
        image = np.zeros((3 * side_px, 3 * side_px), np.uint8)
        c = 1.5 * side_px
        if shape == "circle":
            corners = [
                (c + side_px / 2 * math.cos(a), c + side_px / 2 * math.sin(a))
                for a in np.linspace(0, 2 * math.pi, 64, endpoint=False)
            ]
        else:
            k = 3 if shape == "triangle" else 4
            radius = side_px / math.sqrt(3) if k == 3 else side_px / math.sqrt(2)
            corners = [
                (
                    c + radius * math.cos(turn + 2 * math.pi * i / k),
                    c + radius * math.sin(turn + 2 * math.pi * i / k),
                )
                for i in range(k)
            ]
        cv2.fillPoly(image, [np.round(np.array(corners)).astype(np.int32)], 255)
        contours, _ = cv2.findContours(image, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        scale = side_px / 0.04  # pixels a metre, for a 4 cm face
        reading = classify_outline(contours[0].astype(np.float32), scale, (0.04, 0.04))
        assert reading.shape == shape, (turn, reading)
        assert reading.confidence > 0.3, (turn, reading)


def test_outlines_right_in_200_degraded_frames() -> None:
    """Per frame, each part whose code decodes gets one look: the share of looks that
    read its true outline, over 200 frames at 1024 px with jitter, blur, noise and
    lighting changes, on four benches of random outlines and turns."""
    score = score_outlines(BENCHES, FRAMES, (1024, 1024), HARD, processes=os.cpu_count() or 1)
    feet, legs = score.share("foot"), score.share("leg")
    print(
        f"\n{score.frames} frames: feet {score.right['foot']}/{score.looks['foot']} looks "
        f"right ({feet:.1%}), standing legs {score.right['leg']}/{score.looks['leg']} "
        f"({legs:.1%}); voted wrong {len(score.voted_wrong)}/{score.voted}; "
        f"{dict(score.confusion)}; {score.ms_per_look:.1f} ms a look"
    )
    assert score.frames >= 200
    # Most codes decode in these frames, so most parts are looked at in most frames.
    feet_count = sum(1 for p in PARTS if not p[0].startswith("leg"))
    assert score.looks["foot"] >= 0.8 * score.frames * feet_count
    assert feet >= 0.95
    assert legs >= 0.95
    assert score.voted >= 0.9 * len(PARTS) * BENCHES
    assert not score.voted_wrong


def test_a_face_like_the_bench_reads_nothing() -> None:
    """No guess where the face cannot be told: the camera then has no answer."""
    layout, scene, truth = outline_bench(0)
    bench_colour = (0.45, 0.36, 0.28)  # the simulated bench top's
    parts = tuple(
        replace(p, colour=bench_colour) if p.part_id == "foot1" else p for p in scene.parts
    )
    with SimulatedCamera(replace(scene, parts=parts), size=(640, 640)) as camera:
        perception = BenchPerception(camera.intrinsics, layout)
        for _ in range(3):
            world = perception.process(camera.read()).world
            looks = perception.outlines.readings
            assert looks["foot1"].shape is None
            assert looks["foot1"].reason == "the face does not stand out from the bench"
            assert looks["foot3"].shape == truth["foot3"]
        estimate = world.parts["foot1"].outline
        assert estimate is not None and estimate.shape is None and estimate.looks == 3
