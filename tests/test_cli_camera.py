"""`tandem camera calibrate` and `tandem track`: a calibration from rendered
chessboard frames (real OpenCV), used to track rendered frames of the bench; and
each source that cannot be read is one line, exit 2."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
from pathlib import Path

import cv2
import pytest

from app.responses.sim_camera import sim_scene
from app.sessions.store import SessionStore
from perception.intrinsics import CameraIntrinsics
from perception.sim import CameraPlacement, SimulatedCamera
from planner.resources import find_scenario
from planner.scenario.loading import load_scenario
from tests.chessboard_frames import board_views
from tests.plan_fixtures import ROOT, tandem, tandem_command

SIZE = (800, 800)
HFOV = 50.0  # not the 60 deg default, so only a calibration gives the camera's height
EYE_Z = 1.70  # 1.75 m over the bench: a 50 deg view still holds the corner codes


@pytest.fixture(scope="module")
def truth() -> CameraIntrinsics:
    return CameraIntrinsics.from_fov(*SIZE, hfov_deg=HFOV)


@pytest.fixture(scope="module")
def calibration(tmp_path_factory: pytest.TempPathFactory, truth: CameraIntrinsics) -> Path:
    folder = tmp_path_factory.mktemp("board")
    views = board_views(truth.matrix, (9, 6), 0.025, 8, size=SIZE)
    for i, view in enumerate([*views, views[-1]]):  # the last twice: a board held still
        cv2.imwrite(str(folder / f"view{i:02d}.png"), view)
    out = folder / "calib.json"
    done = tandem("camera", "calibrate", str(folder), "--board", "9x6", "--square", "0.025",
                  "-o", str(out))  # fmt: skip
    assert done.returncode == 0, done.stderr
    kept = int(done.stdout.split()[0])
    assert done.stdout.startswith(f"{kept} views of 9 frames") and 5 <= kept <= 8, done.stdout
    return out


@pytest.fixture(scope="module")
def bench_frames(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("bench")
    scenario = load_scenario(find_scenario(Path("default.toml")))
    placement = CameraPlacement((0.975, 0.0, EYE_Z), (0.975, 0.0, -0.05))
    with SimulatedCamera(sim_scene(scenario), placement, size=SIZE, hfov_deg=HFOV) as camera:
        image = camera.read().image
    for i in range(8):  # a still bench: the same view, frame after frame
        cv2.imwrite(str(folder / f"frame{i:02d}.png"), image)
    return folder


def test_calibration_recovers_the_renderers_intrinsics(
    calibration: Path, truth: CameraIntrinsics
) -> None:
    found = CameraIntrinsics.load(calibration)
    assert (found.width, found.height) == SIZE
    assert found.fx == pytest.approx(truth.fx, rel=0.02)
    assert found.fy == pytest.approx(truth.fy, rel=0.02)
    assert found.cx == pytest.approx(truth.cx, abs=5)
    assert found.cy == pytest.approx(truth.cy, abs=5)


def camera_z(stderr: str) -> float:
    match = re.search(r"camera at x \S+ y \S+ z (\S+) m", stderr)
    assert match, stderr
    return float(match[1])


def test_track_with_the_calibration_places_parts_and_camera(
    calibration: Path, bench_frames: Path
) -> None:
    done = tandem("track", str(bench_frames), "--scenario", "default.toml", "--json",
                  "--calibration", str(calibration))  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = [json.loads(line) for line in done.stdout.splitlines()]
    where = {r["part"]: (r["where"], r["region"]) for r in rows}
    assert where == {
        "top": ("on_bench", "shared"), "leg1": ("on_bench", "robotOnly"),
        "leg2": ("on_bench", "humanOnly"), "foot1": ("on_bench", "shared"),
        "foot2": ("on_bench", "shared"),
    }  # fmt: skip
    assert all(r["frame"] == 0 for r in rows)  # nothing changes after the first frame
    assert f"intrinsics: {calibration}" in done.stderr
    assert camera_z(done.stderr) == pytest.approx(EYE_Z, abs=0.03)
    # Without it, the 60 deg default puts the camera well below where it is.
    default = tandem("track", str(bench_frames), "--scenario", "default.toml")
    assert default.returncode == 0, default.stderr
    assert "leg2 on the bench in humanOnly" in " ".join(default.stdout.split())
    assert EYE_Z - camera_z(default.stderr) > 0.15


def test_track_sim_prints_changes_only(tmp_path: Path) -> None:
    done = tandem("track", "sim", "--scenario", "default.toml", "--frames", "4")
    assert done.returncode == 0, done.stderr
    assert len(done.stdout.splitlines()) == 5  # five parts, seen once, never changing
    assert done.stderr.strip().splitlines()[-1].startswith("4 frames, 9 codes in the last")


def one_line(*args: str) -> str:
    done = tandem(*args, env={**os.environ})
    assert done.returncode == 2, (done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    return lines[0]


def test_sources_that_cannot_be_read_are_one_line(tmp_path: Path) -> None:
    track = ("--scenario", "default.toml")
    assert one_line("track", "webcam:63", *track) == "webcam:63: no camera at 63"
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"not a video" * 200)
    assert one_line("track", str(broken), *track) == (
        f"{broken}: unreadable video file {broken}"
    )
    empty = tmp_path / "empty"
    empty.mkdir()
    assert one_line("track", str(empty), *track) == f"{empty}: no images in folder {empty}"
    assert one_line("camera", "calibrate", "webcam:63", "-o", str(tmp_path / "c.json")) == (
        "webcam:63: no camera at 63"
    )
    # Frames without a board: too few views, said in one line.
    blank = tmp_path / "blank"
    blank.mkdir()
    cv2.imwrite(str(blank / "a.png"), cv2.UMat(480, 640, cv2.CV_8UC3).get() * 0 + 200)
    line = one_line("camera", "calibrate", str(blank), "-o", str(tmp_path / "c.json"))
    assert line.startswith(f"{blank}: chessboard found in 0 views, 5 needed")
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    line = one_line("track", "sim", *track, "--calibration", str(bad))
    assert line.startswith(f"--calibration {bad}: not a camera calibration")
    assert one_line("camera", "calibrate", str(blank), "--board", "9", "-o", "c.json") == (
        "--board 9: expected inner corners COLSxROWS, each 3 or more (9x6)"
    )


def until_said(words: str, *args: str, env: dict[str, str]) -> str:
    """`tandem ARGS`'s standard error until a line holds `words` (or the run ends); a
    run on the wall clock lasts as long as the robot's motions, so it is stopped
    there, as a person stops it (SIGTERM), once it has said what the test reads."""
    run = subprocess.Popen(
        [*tandem_command(), *args], cwd=ROOT, env=env, text=True,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )  # fmt: skip
    assert run.stderr is not None
    lines: list[str] = []
    try:
        for line in run.stderr:
            lines.append(line)
            if words in line:
                run.send_signal(signal.SIGTERM)
                break
        run.wait(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    return "".join(lines)


def test_execute_takes_the_calibration_of_a_real_camera(
    calibration: Path, bench_frames: Path, tmp_path: Path
) -> None:
    env = {**os.environ, "TANDEM_DATA_DIR": str(tmp_path)}
    # The still bench answers the first sensing node (the human's hands are free);
    # the frames end before the rest, which fall back.
    done = tandem("execute", "default.toml", "--responses", f"camera:{bench_frames}",
                  "--calibration", str(calibration), "--seed", "1", env=env)  # fmt: skip
    assert "--seed goes with" in done.stderr  # a real camera's run is not seeded
    camera = f"camera:{bench_frames}"
    said = until_said("-> no (camera)", "execute", "default.toml", "--responses", camera,
                      "--calibration", str(calibration), env=env)  # fmt: skip
    assert "-> no (camera)" in said, said
    # A recording's frames carry no time of this run: the session says it is untimed.
    with SessionStore(tmp_path, read_only=True) as store:
        assert [s.clock for s in store.list_sessions()] == [None]
    missing = tmp_path / "missing.json"
    line = one_line("execute", "default.toml", "--responses", "camera:sim",
                    "--calibration", str(missing))  # fmt: skip
    assert line == f"--calibration {missing}: cannot read: No such file or directory"
    assert one_line("execute", "default.toml", "--responses", "random",
                    "--calibration", str(calibration)) == (
        "--calibration goes with --responses camera:SOURCE"
    )  # fmt: skip
