"""Camera loop benchmark: from the simulated human's move to the chosen branch.

`python -m app.benchmark.camera_benchmark [SCENARIO] [--seeds N]` runs the
scenario's plan with the simulated camera, a seeded simulated human and the
camera answering every sensing node, two ways:

- live: frames at the camera's 30 fps in a `LiveCamera` thread, as in the
  dashboard; the time runs from the human's act (the parts moved in the
  simulated world) to the camera's answer, so it includes the render of the
  changed bench, the frames until the tracker and the estimate settle, and the
  wait for each frame;
- flat out: the headless feed of `tandem execute`, the same `CameraSource`
  pulling frames as fast as they come (rendering only when the world changed).

Prints medians, 90th percentiles and maxima per kind of sensing action, and how
many answers agree with what the human did.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import cv2

from app.execution.walker import Executor
from app.responses.sim_camera import SIM_SIZE, sim_camera
from app.sim.human import SimulatedHuman, SimulatedWorld
from app.sources.bench_layout import bench_layout
from app.sources.camera import CameraSource
from app.sources.camera_feed import PulledFeed
from app.sources.live_camera import LiveCamera, live_source
from app.sources.outcomes import FallbackSource, RandomSource
from perception.pipeline import BenchPerception
from planner.feasibility.scene import part_boxes
from planner.plan.model import Plan
from planner.planning import plan_scenario
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from planner.scenario.model import Scenario

TARGET_S = 0.5

Times = dict[str, list[float]]


def _kind(action: str | None) -> str:
    return (action or "").split("(")[1].rstrip(")") if action and "(" in action else "?"


def live_run(scenario: Scenario, plan: Plan, seed: int, times: Times) -> tuple[int, int]:
    camera = sim_camera(scenario)
    live = LiveCamera(camera, camera.camera.intrinsics, scenario, name="sim", simulated=camera)
    live.start()
    try:
        world = SimulatedWorld(part_boxes(scenario), live.layout, live)
        human = SimulatedHuman(plan, world, seed)
        source = live_source(live, human)
        executor = Executor(plan, FallbackSource(source, RandomSource(seed)), [human.on_event])
        executor.run()
    finally:
        live.stop()
    return _collect(executor, human, times)


def flat_out_run(scenario: Scenario, plan: Plan, seed: int, times: Times) -> tuple[int, int]:
    camera = sim_camera(scenario)
    layout = bench_layout(scenario)
    try:
        world = SimulatedWorld(part_boxes(scenario), layout, camera)
        human = SimulatedHuman(plan, world, seed)
        feed = PulledFeed(camera, BenchPerception(camera.camera.intrinsics, layout))
        source = CameraSource(feed, human)
        executor = Executor(plan, FallbackSource(source, RandomSource(seed)), [human.on_event])
        executor.run()
    finally:
        camera.close()
    return _collect(executor, human, times)


def _collect(executor: Executor, human: SimulatedHuman, times: Times) -> tuple[int, int]:
    for event in executor.events:
        camera = event.evidence.camera if event.evidence is not None else None
        if event.source == "camera" and camera is not None:
            times[_kind(None if event.action is None else str(event.action))].append(camera.seconds)
    return human.agreement(executor.events)


def _row(name: str, values: list[float]) -> str:
    values = sorted(values)
    p90 = values[min(len(values) - 1, int(len(values) * 0.9))]
    return (f"{name:>28} {len(values):>4} {statistics.median(values):>9.3f} {p90:>8.3f} "
            f"{values[-1]:>8.3f}")  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.camera_benchmark")
    parser.add_argument("scenario", nargs="?", default="default.toml")
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)  # one core, as the target says
    scenario = load_scenario(find_scenario(Path(args.scenario)))
    plan = plan_scenario(scenario, workers=1).plan
    print(f"From the simulated human's move to the chosen branch, {scenario.name}, "
          f"{args.seeds} seeds, {SIM_SIZE[0]}x{SIM_SIZE[1]} frames (target <= {TARGET_S} s)")
    print(f"{'':>28} {'n':>4} {'median s':>9} {'p90 s':>8} {'max s':>8}")
    for label, run in (("live, 30 fps", live_run), ("flat out", flat_out_run)):
        times: Times = defaultdict(list)
        agree = total = 0
        start = time.perf_counter()
        for seed in range(args.seeds):
            a, t = run(scenario, plan, seed, times)
            agree, total = agree + a, total + t
        wall = time.perf_counter() - start
        everything = [s for values in times.values() for s in values]
        print(f"{label}: {agree}/{total} answers agree with the human, {wall:.1f} s in all")
        for kind, values in sorted(times.items()):
            print(_row(kind, values))
        print(_row("all", everything))
        median = statistics.median(everything)
        print(f"{'':>28} median {median:.3f} s: "
              f"{'meets' if median <= TARGET_S else 'misses'} the {TARGET_S} s target")
    return 0


if __name__ == "__main__":
    sys.exit(main())
