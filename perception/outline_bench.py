"""A bench of parts whose outlines the camera must read, with known truth, and the
share of looks that read them right: for the tests and `python -m perception.bench`.

Feet as the real-world task's (4 cm, 3 cm high) and the paper bench's (8 cm), legs
standing 20 cm tall, each of a random outline and turn, 32 cm apart: turned any
way, no code's card hangs over another part's face (a leg's reaches ~25 cm).
"""

from __future__ import annotations

import math
import multiprocessing as mp
import random
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial

from perception.codes_image import printed_side
from perception.frames import Image
from perception.layout import BenchLayout, PartShape, Region
from perception.markers import DEFAULT_MARKER_SIZE_M, PartCode, corner_references, encode_part
from perception.outline import OUTLINES, read_outline
from perception.pipeline import BenchPerception, Perceived
from perception.sim import Degradation, SimPart, SimScene, SimulatedCamera

BENCH_TOP_Z = -0.05
BENCH_X = (0.30, 1.40)
BENCH_Y = (-0.70, 0.70)
# (id, footprint side, height, x, y)
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
HARD = Degradation(jitter_m=0.02, blur_px=1.2, noise=6.0, gain=(0.6, 1.3), light_jitter=0.3)


def kind(part_id: str) -> str:
    return "leg" if part_id.startswith("leg") else "foot"


def _code_offset(part_id: str, marker: int, side: float) -> tuple[float, float]:
    # As the app puts them: a leg's code a code's width along x from its foot point;
    # a foot's on a card beside its face, 1 cm clear, towards -y.
    card = printed_side(encode_part(part_id, marker), DEFAULT_MARKER_SIZE_M)
    if kind(part_id) == "leg":
        return (card + 0.005, 0.0)
    return (0.0, -(side / 2 + 0.01 + card / 2))


def outline_bench(seed: int) -> tuple[BenchLayout, SimScene, dict[str, str]]:
    """The layout, the scene and each part's true outline, drawn by `seed`."""
    rng = random.Random(seed)
    shapes: dict[str, PartShape] = {}
    parts: list[SimPart] = []
    truth: dict[str, str] = {}
    for marker, (pid, side, height, x, y) in enumerate(PARTS, start=1):
        size = (side, side, height)
        offset = _code_offset(pid, marker, side)
        slots = {"foot": (0.0, 0.0)} if kind(pid) == "leg" else {}
        shapes[pid] = PartShape(size, slots, offset, OUTLINES)
        truth[pid] = rng.choice(OUTLINES)
        parts.append(SimPart(
            pid, size, (x, y, BENCH_TOP_Z + height / 2), encode_part(pid, marker),
            yaw=rng.uniform(-math.pi, math.pi), colour=(0.85, 0.70, 0.70),
            code_offset=offset, profile=truth[pid],
        ))  # fmt: skip
    references = corner_references(BENCH_X, BENCH_Y)
    regions = (Region("robotOnly", 0.30, 0.65), Region("shared", 0.65, 1.00),
               Region("humanOnly", 1.00, 1.40))  # fmt: skip
    layout = BenchLayout(regions, BENCH_TOP_Z, BENCH_X, BENCH_Y, BENCH_X[1], shapes, references)
    scene = SimScene(tuple(parts), references, BENCH_TOP_Z, BENCH_X, BENCH_Y)
    return layout, scene, truth


@dataclass
class OutlineScore:
    """Looks (one per decoded code a frame) and how many read the true outline, by
    kind; the outlines voted at the end of each bench; seconds spent looking."""

    frames: int = 0
    looks: Counter[str] = field(default_factory=Counter)
    right: Counter[str] = field(default_factory=Counter)
    confusion: Counter[tuple[str, str | None]] = field(default_factory=Counter)
    voted: int = 0
    voted_wrong: list[tuple[int, str, str, str | None]] = field(default_factory=list)
    seconds: float = 0.0

    def share(self, part_kind: str) -> float:
        return self.right[part_kind] / self.looks[part_kind] if self.looks[part_kind] else 0.0

    def add(self, other: OutlineScore) -> None:
        """Counts `other`'s frames, looks and votes in with these."""
        self.frames += other.frames
        self.looks.update(other.looks)
        self.right.update(other.right)
        self.confusion.update(other.confusion)
        self.voted += other.voted
        self.voted_wrong.extend(other.voted_wrong)
        self.seconds += other.seconds

    @property
    def ms_per_look(self) -> float:
        return 1e3 * self.seconds / max(1, sum(self.looks.values()))


def _time_looks(image: Image, perception: BenchPerception, perceived: Perceived) -> float:
    """Seconds the frame's looks take, read again outside the pipeline's votes."""
    start = time.perf_counter()
    for detection in perceived.observation.detections:
        if isinstance(detection.code, PartCode):
            face = perception.outlines.face(detection.code.part_id, detection.code.marker_id)
            if face is not None:
                read_outline(image, face, detection.corners)
    return time.perf_counter() - start


def score_outlines(
    benches: int,
    frames: int,
    size: tuple[int, int],
    degradation: Degradation,
    processes: int = 1,
) -> OutlineScore:
    """Renders `benches` benches (seeds 0..) for `frames` frames each and scores every look.

    `processes` > 1 scores benches side by side in fresh processes: a bench's score
    depends on its seed alone, and rendering it is most of the time (the look times
    then share the cores)."""
    seeds = range(benches)
    if processes <= 1:
        scores = [score_bench(seed, frames, size, degradation) for seed in seeds]
    else:
        # Spawned, not forked: the caller may hold threads (a browser driver, a server).
        with ProcessPoolExecutor(processes, mp_context=mp.get_context("spawn")) as pool:
            one = partial(score_bench, frames=frames, size=size, degradation=degradation)
            scores = list(pool.map(one, seeds))
    total = OutlineScore()
    for score in scores:
        total.add(score)
    return total


def score_bench(
    seed: int, frames: int, size: tuple[int, int], degradation: Degradation
) -> OutlineScore:
    """One bench's looks over `frames` frames, and its outlines voted at the end."""
    score = OutlineScore()
    layout, scene, truth = outline_bench(seed)
    with SimulatedCamera(
        scene, size=size, degradation=replace(degradation, seed=100 + seed)
    ) as camera:
        perception = BenchPerception(camera.intrinsics, layout)
        for _ in range(frames):
            frame = camera.read()
            perceived = perception.process(frame)
            score.frames += 1
            for pid, reading in perception.outlines.readings.items():
                score.looks[kind(pid)] += 1
                score.right[kind(pid)] += reading.shape == truth[pid]
                score.confusion[(truth[pid], reading.shape)] += 1
            score.seconds += _time_looks(frame.image, perception, perceived)
    for pid, shape in truth.items():
        estimate = perceived.world.parts[pid].outline
        if estimate is None:
            continue  # its code never decoded (another's card over it): no looks
        score.voted += 1
        if estimate.shape != shape:
            score.voted_wrong.append((seed, pid, shape, estimate.shape))
    return score
