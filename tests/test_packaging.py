"""The built wheel, installed (not editable) into a fresh venv outside the checkout.

The fresh venv borrows the dependencies (clingo, pybullet, viser, ...) from the
venv running the tests through a `.pth` line, so nothing is downloaded; Tandem's
own packages and scenarios come only from the wheel.
"""

from __future__ import annotations

import json
import shutil
import signal
import socket
import subprocess
import sys
import sysconfig
import threading
import time
import urllib.error
import urllib.request
import venv
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("app", "planner", "perception", "speech")


@dataclass(frozen=True)
class Installed:
    wheel: Path
    python: Path
    tandem: Path
    elsewhere: Path  # a working directory with no checkout in it


def _copy_sources(to: Path) -> None:
    # Build from a copy: setuptools writes build/ and *.egg-info beside the sources.
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in (*PACKAGES, "static"):
        shutil.copytree(ROOT / name, to / name, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, to / name)


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    work = tmp_path_factory.mktemp("wheel")
    _copy_sources(work / "src")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "--quiet", "-w", str(work / "dist"), str(work / "src")],
        check=True, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    (wheel,) = (work / "dist").glob("tandem-*.whl")
    env_dir = work / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / "bin" / "python"
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True, capture_output=True, text=True,
    ).stdout.strip()  # fmt: skip
    # A plain path line: the dependencies' site-packages, without running its .pth
    # files (one of them is the checkout's editable install).
    (Path(purelib) / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
         "--no-index", "--quiet", str(wheel)],
        check=True, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    elsewhere = work / "elsewhere"
    elsewhere.mkdir()
    return Installed(wheel, python, env_dir / "bin" / "tandem", elsewhere)


def test_the_wheel_carries_every_module_encoding_and_scenario(installed: Installed) -> None:
    names = set(zipfile.ZipFile(installed.wheel).namelist())
    for package in PACKAGES:
        for module in (ROOT / package).rglob("*.py"):
            assert str(module.relative_to(ROOT)) in names, module
    for encoding in (ROOT / "planner" / "asp").glob("*.lp"):
        assert str(encoding.relative_to(ROOT)) in names, encoding
    scenarios = list((ROOT / "static" / "scenarios").rglob("*.toml"))
    assert len(scenarios) > 20
    for scenario in scenarios:
        shipped = "tandem_static/" + str(scenario.relative_to(ROOT / "static"))
        assert shipped in names, scenario


def test_the_installed_code_and_scenarios_come_from_the_venv(installed: Installed) -> None:
    probe = (
        "import json, app, planner, tandem_static\n"
        "from pathlib import Path\n"
        "from app.dashboard.scenario_edit import load_file\n"
        "from app.dashboard.scenario_folders import ScenarioFolders\n"
        "loaded = load_file('paper/U10.toml')\n"
        "names = ScenarioFolders(Path('no-such-folder')).names()\n"
        "print(json.dumps({'modules': [app.__file__, planner.__file__, tandem_static.__file__],"
        " 'source': loaded.source, 'error': loaded.error, 'names': names}))\n"
    )
    result = subprocess.run(
        [str(installed.python), "-c", probe],
        cwd=installed.elsewhere, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout)
    venv_dir = installed.python.parent.parent
    for module in seen["modules"]:
        assert Path(module).is_relative_to(venv_dir) and not Path(module).is_relative_to(ROOT)
    assert Path(seen["source"]).is_relative_to(venv_dir) and seen["error"] == ""
    assert seen["names"][0] == "default.toml" and "paper/U10.toml" in seen["names"]


def test_installed_tandem_plans_the_shipped_default_scenario(installed: Installed) -> None:
    result = subprocess.run(
        [str(installed.tandem), "plan", "default.toml", "--workers", "1", "--quiet"],
        cwd=installed.elsewhere, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("paper-base: plan with "), lines[0]
    header = lines[1].split()
    assert header[:3] == ["instance", "L", "D=A+S+C"] and "N" in header
    row = lines[3].split()
    assert row[0] == "paper-base" and int(row[header.index("N")]) > 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _get(url: str) -> int | None:
    try:
        with urllib.request.urlopen(url, timeout=5) as response:
            return int(response.status)
    except (urllib.error.URLError, ConnectionError, TimeoutError):
        return None


def test_installed_tandem_dashboard_serves_its_page(installed: Installed) -> None:
    port = _free_port()
    ready = f"Tandem dashboard on http://127.0.0.1:{port}"
    server = subprocess.Popen(
        [str(installed.tandem), "dashboard", "--port", str(port),
         "--scenario", "paper/paper-01.toml", "--data-dir", str(installed.elsewhere / "data")],
        cwd=installed.elsewhere, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    assert server.stdout is not None
    lines: list[str] = []
    # viser answers HTTP before the bench is built: wait for the dashboard's own line.
    reader = threading.Thread(target=lambda: lines.extend(server.stdout or ()), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 90
        while not any(ready in line for line in lines) and time.monotonic() < deadline:
            assert server.poll() is None, "".join(lines)
            time.sleep(0.2)
        assert any(ready in line for line in lines), "".join(lines)
        assert _get(f"http://127.0.0.1:{port}/") == 200
    finally:
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        reader.join(timeout=10)
    assert server.returncode == 0, "".join(lines)
    assert not any("Traceback" in line for line in lines), "".join(lines)
