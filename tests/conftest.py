"""Test-wide settings: caches and stores live in temporary folders, never in $HOME; the
real recordings the voice is measured on in the checkout's `.cache/`, fetched once."""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
import types
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from playwright.sync_api import Browser

_made: list[str] = []


def pytest_configure(config: pytest.Config) -> None:
    # Set before any test runs, so subprocesses (the CLI) inherit it too.
    for variable in ("TANDEM_CACHE_DIR", "TANDEM_DATA_DIR"):
        folder = tempfile.mkdtemp(prefix=f"tandem-test-{variable[7:11].lower()}-")
        _made.append(folder)
        os.environ[variable] = folder
    # The real recordings are fetched once per checkout (`make recordings`), not per run.
    checkout = Path(__file__).resolve().parent.parent
    os.environ.setdefault("TANDEM_REAL_SPEECH_DIR", str(checkout / ".cache" / "real-speech"))


def pytest_unconfigure(config: pytest.Config) -> None:
    for folder in _made:
        shutil.rmtree(folder, ignore_errors=True)


# What a module's tests need, read off what the module uses: a test that drives
# chromium is `browser`, one on a roscore `ros`, one on Ray `cluster`, one in a room
# or on a microphone that runs in real time `live_audio`, a study day's executions
# `soak`. Marked here so a new test file is marked without anyone remembering to.
_NEEDS: dict[str, tuple[str, ...]] = {
    "browser": ("playwright",),
    "ros": ("robot_graph", "tests.robot_graph"),
    "cluster": ("ray",),
    "live_audio": (
        "app.responses.voice_room", "app.responses.voice_mic", "speech.microphone",
        "tests.audio_device", "speech.sources.SimulatedRoom",
    ),
    "soak": ("app.benchmark.memory",),
}


def _uses(module: types.ModuleType, prefixes: tuple[str, ...]) -> bool:
    """Whether `module` holds a module, or a class or function of a module, named in
    `prefixes` (a top-level package, a module, or a module's class)."""
    for value in vars(module).values():
        if isinstance(value, types.ModuleType):
            names = (value.__name__,)
        else:
            home = getattr(value, "__module__", None)
            if not isinstance(home, str):
                continue
            names = (home, f"{home}.{getattr(value, '__qualname__', '')}")
        if any(n in prefixes or n.split(".")[0] in prefixes for n in names):
            return True
    return False


# Files run heaviest first (seconds of one worker, measured: `TANDEM_TEST_DURATIONS=FILE
# pytest ...` writes them), so the last files of a run are short ones and the workers
# end together instead of one finishing a long file alone; a file's tests keep their
# order. A file not yet measured counts as light.
DURATIONS = Path(__file__).with_name("durations.json")


def _heaviest_first(items: list[pytest.Item]) -> None:
    weights: dict[str, float] = json.loads(DURATIONS.read_text()) if DURATIONS.exists() else {}
    items.sort(key=lambda item: -weights.get(item.path.name, 0.0))  # stable: order kept


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    _heaviest_first(items)
    seen: dict[str, set[str]] = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is None:
            continue
        if module.__name__ not in seen:
            seen[module.__name__] = {m for m, p in _NEEDS.items() if _uses(module, p)}
        for marker in seen[module.__name__]:
            item.add_marker(marker)


# Under pytest-xdist a file's tests run on one worker, in their order, so its module
# fixtures (a server, a page) are made once and its tests may build on each other;
# every file on Ray runs on one worker, so two local clusters never meet through
# `address="auto"`. (xdist's own `xdist_group` marks are lost from the test ids under
# pytest 9.2, which keeps its ids apart from the `_nodeid` xdist rewrites; a file's
# tests were then split over both workers, each making its own server.)
_RAY = re.compile(r"""^\w+ = pytest\.importorskip\("ray"|^import ray|^from ray""", re.M)
# Files that mostly wait on real time (the simulated robot's motions, speech played
# and heard in real time) and drive no page: a few CPU-seconds a minute of wall.
_WAITS = re.compile(
    r"^from (tests\.robot_graph|app\.responses\.voice_room|speech\.microphone"
    r"|tests\.audio_device) import|^from speech\.sources import .*\bSimulatedRoom\b",
    re.M,
)
# The lane is made from this many workers on (`make test`'s default on two cores):
# with three, two workers computing are too few for the suite.
LANE_FROM = 4
_PAGE = re.compile(r"^from playwright|^import playwright|\bpage: Page\b", re.M)


def _scope_of(root: Path, path: str) -> tuple[str, bool]:
    """A file's scope (every file on Ray shares one) and whether it mostly waits."""
    source = root / path
    text = source.read_text() if source.suffix == ".py" else ""
    waits = _WAITS.search(text) is not None and _PAGE.search(text) is None
    return ("cluster" if _RAY.search(text) else path), waits


def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    from xdist.scheduler import LoadFileScheduling

    root, scopes, waiting = config.rootpath, {}, set()

    # Files are handed out in the order collected (heaviest first), not by their count
    # of tests.
    config.option.loadscopereorder = False

    class FileScheduling(LoadFileScheduling):  # type: ignore[misc]
        """With `LANE_FROM` workers or more, the last is a lane for the files that wait:
        it takes them heaviest first, while the others take the files that compute
        (and the waiting ones left at the end, lightest first). Waiting files then
        overlap computing ones instead of leaving the cores idle together."""

        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            if path not in scopes:
                scopes[path], waits = _scope_of(root, path)
                if waits:
                    waiting.add(scopes[path])
            return scopes[path]

        def _assign_work_unit(self, node: Any) -> None:
            if len(self.nodes) < LANE_FROM:  # no lane: every file in the order collected
                super()._assign_work_unit(node)
                return
            queue = list(self.workqueue)
            lane = node is max(self.nodes, key=_worker_number)
            mine = [s for s in queue if (s in waiting) == lane]
            if lane:
                # The lane's own first; then the lightest file that computes.
                scope = mine[0] if mine else queue[-1]
            else:
                others = [s for s in queue if s in waiting]
                scope = mine[0] if mine else others[-1]
            self.workqueue.move_to_end(scope, last=False)
            super()._assign_work_unit(node)

    return FileScheduling(config, log)


def _worker_number(node: Any) -> int:
    return int(str(node.gateway.id).removeprefix("gw"))


_spent: dict[str, float] = {}


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    # Each phase's report reaches the controller (or the only process) once.
    name = report.nodeid.split("::", 1)[0].rsplit("/", 1)[-1]
    _spent[name] = _spent.get(name, 0.0) + report.duration


def pytest_sessionfinish(session: pytest.Session) -> None:
    target = os.environ.get("TANDEM_TEST_DURATIONS")
    if target and not hasattr(session.config, "workerinput"):
        rounded = {name: round(seconds, 1) for name, seconds in sorted(_spent.items())}
        Path(target).write_text(json.dumps(rounded, indent=1) + "\n")


CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"


@pytest.fixture(scope="session")
def browser() -> Iterator[Browser]:
    """One Debian chromium per test process, shared by every browser test: a page is
    each test's own (`Browser.new_page` makes a fresh context), the browser is not.
    One playwright driver per thread is all the sync API allows, so no test starts
    its own. Pages may play audio without a click (the speech panel's lines)."""
    if not Path(CHROMIUM).exists():
        pytest.fail("chromium is missing: `make test` installs it (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as driver:
        launched = driver.chromium.launch(
            executable_path=CHROMIUM,
            args=["--no-sandbox", "--autoplay-policy=no-user-gesture-required"],
        )
        yield launched
        launched.close()
