"""What an execution leaves behind in the dashboard while pages watch.

`python -m app.benchmark.memory [--executions 100] [--pages 2] [--trace]` runs
the dashboard in this process with pages connected and runs the plan again and
again at zero step delay, answering every question through the execution
panel's click source. Every few executions a page leaves and a new one joins.
After each execution it samples the process's RSS and the messages viser keeps
in its replay buffer (what a page joining later is sent); `--trace` adds
tracemalloc's biggest growths between the warm-up and the end.

The pages are `WatchingPage`s: websocket clients of the viser server that
receive everything a browser would and render nothing (the server does the
same work for them; a browser's rendering is its own memory, not the server's).

Measured on 2026-12-05 (2 cores shared with a soak and other work; default.toml;
two pages, one replaced every ten executions; not planning again between runs):

- Before: every execution left 29 messages in viser's replay buffer for good
  (1741 after 60 executions): the removals (`GuiRemoveMessage`) of elements
  made and removed during the run, the answer buttons of each question (~8)
  and the selected node's "Go to" buttons, remade at every step (~13), with
  their updates (the "Go to" group now stays and changes its options). viser
  sweeps removals only when a page connects, so pages that stay open never
  free them. RSS grew 57 KB per execution without the
  robot's meshes, 0.65 MB under tracemalloc.
- Replaced, not accumulated, already: the tree's SVG, the timeline strip, the
  log (12 lines), the audio element and the camera frame are one `content`
  each, and viser's buffer keeps only the latest update of each prop (its
  redundancy key); the arms' poses likewise, one per joint. Python's heap
  (tracemalloc, 30 executions) grows 6 KB per execution, the robot's spoken
  lines: kept in a window of 200 now; the review panel lists the newest 200
  sessions.
- After (the screen sweeps the buffer and trims the C heap when an execution
  ends): the buffer stays at ~234 messages (685 with the meshes). Without the
  meshes RSS grows 33 KB per execution, +2.6 MB over the last 80 of 100 (the
  test's bound: 5 MB). With the meshes: 247 → 249 MB over executions 20-60
  (57 KB per execution), against 384 → 393 MB (118 KB) with the sweep alone:
  what is left is native memory (allocator arenas, SQLite's cache), not
  anything Python or viser holds. Planning again before each execution adds
  ~30 KB per execution.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import tempfile
import threading
import time
import tracemalloc
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import msgspec
import viser
from viser._messages import ViewerCameraMessage
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect
from websockets.typing import Subprotocol

from app.benchmark.soak import rss_mb
from app.dashboard.server import Dashboard, DashboardSettings
from app.dashboard.stage import ExecutionFinished
from app.dashboard.widgets import show
from planner.plan.model import format_table

WARM_UP = 20  # executions before the growth counts: caches fill, the voice's files appear
RECONNECT_EVERY = 10  # executions between a page leaving and a new one joining
BOUND_MB = 5.0  # the bound on growth over the executions after the warm-up

# Where a watching page's camera is: viser counts a page as connected once it
# has reported its camera, as a browser does at once.
_CAMERA = ViewerCameraMessage(
    wxyz=(1.0, 0.0, 0.0, 0.0), position=(3.0, 0.0, 1.5), fov=1.0, near=0.01, far=100.0,
    image_height=900, image_width=1400, look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0),
)  # fmt: skip


class WatchingPage:
    """A page that watches the dashboard: it receives every message and renders nothing."""

    def __init__(self, port: int) -> None:
        protocol = Subprotocol(f"viser-v{viser.__version__}")  # viser refuses other versions
        self._socket = connect(f"ws://127.0.0.1:{port}", subprotocols=[protocol], max_size=None)
        self._socket.send(msgspec.msgpack.encode(_CAMERA.as_serializable_dict()))
        self.received = 0  # bytes
        self._thread = threading.Thread(target=self._drain, name="watching-page", daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        try:
            for message in self._socket:
                self.received += len(message)
        except ConnectionClosed:
            pass  # the server stopped

    def close(self) -> None:
        self._socket.close()
        self._thread.join(5.0)


def replayed(server: viser.ViserServer) -> Counter[str]:
    """The messages viser keeps to replay to a page joining now, by type.

    viser has no public view of its buffer; this is its broadcast buffer."""
    buffer = server._websock_server._broadcast_buffer
    with buffer.buffer_lock:
        return Counter(type(m).__name__ for m in buffer.message_from_id.values())


def _wait(condition: Callable[[], object], timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            raise TimeoutError(f"{what}: not within {timeout:.0f} s")
        time.sleep(0.005)


def plan_once(dashboard: Dashboard, timeout: float = 300.0) -> None:
    """Plans the open scenario, as the Plan button does, until Execute may start."""
    dashboard.start_planning()
    _wait(lambda: not dashboard.execution.start_button.disabled, timeout, "planning")


class Finishes:
    """The results of the executions that ended, as the panels hear of them."""

    def __init__(self, dashboard: Dashboard) -> None:
        self.results: list[str] = []
        dashboard.events.subscribe(ExecutionFinished, lambda m: self.results.append(m.result))


def execute_once(dashboard: Dashboard, finishes: Finishes, timeout: float = 120.0) -> str:
    """Runs the shown plan once, as the Execute button does, and answers each
    question through the panel's click source with its last option (as the
    simulated-human buttons do). Returns the result once the panel has finished
    with the execution (its `ExecutionFinished` delivered)."""
    panel = dashboard.execution
    ended = len(finishes.results)
    _wait(lambda: not panel.start_button.disabled, timeout, "the Execute button")
    panel.start()
    end = time.monotonic() + timeout
    while len(finishes.results) == ended:
        if time.monotonic() > end:
            raise TimeoutError(f"the execution did not end within {timeout:.0f} s")
        clicks = panel.clicks if panel.running else None
        offer = clicks.pending() if clicks is not None else None
        if clicks is None or offer is None:
            time.sleep(0.002)
            continue
        clicks.click(offer.options[-1], offer.node_id)
    return finishes.results[ended]


@dataclass(frozen=True)
class Sample:
    """The dashboard after an execution."""

    execution: int
    rss_mb: float
    replayed: int  # messages in viser's replay buffer
    pages: int  # pages connected


@dataclass
class MemoryRun:
    """What `run_day` measured: a sample after each execution, and their results."""

    samples: list[Sample] = field(default_factory=list)
    results: Counter[str] = field(default_factory=Counter)
    reconnects: int = 0
    growth: list[tuple[int, str]] = field(default_factory=list)  # tracemalloc: bytes, where

    def after_warm_up(self) -> tuple[Sample, Sample]:
        """The samples at the end of the warm-up and at the end."""
        return self.samples[min(WARM_UP, len(self.samples)) - 1], self.samples[-1]

    def growth_mb(self) -> float:
        first, last = self.after_warm_up()
        return last.rss_mb - first.rss_mb

    def per_execution_kb(self) -> float:
        first, last = self.after_warm_up()
        return 1024 * self.growth_mb() / max(1, last.execution - first.execution)


@contextmanager
def watched_dashboard(models: bool = True) -> Iterator[Dashboard]:
    """A dashboard on the base scenario with its own data folder, stopped after."""
    with tempfile.TemporaryDirectory(prefix="tandem-memory-") as data:
        settings = DashboardSettings(
            workers=1, data_dir=data, cache_dir=f"{data}/cache", load_models=models
        )
        dashboard = Dashboard("127.0.0.1", 0, "default.toml", settings)
        try:
            yield dashboard
        finally:
            dashboard.close()


def _sample(dashboard: Dashboard, execution: int) -> Sample:
    server = dashboard.server
    return Sample(execution, rss_mb(os.getpid()), sum(replayed(server).values()),
                  len(server.get_clients()))  # fmt: skip


def run_day(
    dashboard: Dashboard,
    executions: int = 100,
    pages: int = 2,
    *,
    replan: bool = False,
    trace: bool = False,
) -> MemoryRun:
    """Runs `executions` of the plan with `pages` watching (one replaced every
    RECONNECT_EVERY executions); `replan`: plans again before each."""
    port = dashboard.server.get_port()
    watching = [WatchingPage(port) for _ in range(pages)]
    run = MemoryRun()
    finishes = Finishes(dashboard)
    try:
        _wait(lambda: len(dashboard.server.get_clients()) == pages, 30, "the pages")
        show(dashboard.execution.speed, 0.0)
        # Muted: a day's executions back to back, not at the pace of the robot's voice
        # (on the wall clock a spoken line lasts as its audio plays).
        show(dashboard.speech.mute, True)
        plan_once(dashboard)
        for k in range(1, executions + 1):
            if replan and k > 1:
                plan_once(dashboard)
            run.results[execute_once(dashboard, finishes)] += 1
            if k % RECONNECT_EVERY == 0:
                # A page leaves, a new one joins (and is sent the replay buffer).
                i = run.reconnects % pages
                watching[i].close()
                watching[i] = WatchingPage(port)
                run.reconnects += 1
                _wait(lambda: len(dashboard.server.get_clients()) == pages, 30, "a new page")
            gc.collect()  # what is held, not what waits to be collected
            if trace and k == WARM_UP:
                tracemalloc.start(8)
                before = tracemalloc.take_snapshot()
            run.samples.append(_sample(dashboard, k))
        if trace and tracemalloc.is_tracing():
            after = tracemalloc.take_snapshot()
            tracemalloc.stop()
            for stat in after.compare_to(before, "traceback")[:6]:
                run.growth.append((stat.size_diff, "\n".join(stat.traceback.format()[-6:])))
    finally:
        for page in watching:
            page.close()
    return run


def table(run: MemoryRun, pages: int) -> str:
    first, last = run.after_warm_up()
    rows: list[tuple[str, ...]] = [
        ("executions", f"{pages} pages", f"{last.execution}",
         ", ".join(f"{n} {r}" for r, n in run.results.items())),
        ("pages replaced", f"every {RECONNECT_EVERY} executions", f"{run.reconnects}", ""),
        ("RSS", f"after {first.execution} → {last.execution}",
         f"{first.rss_mb:.1f} → {last.rss_mb:.1f} MB", f"growth {run.growth_mb():+.2f} MB"),
        ("RSS per execution", f"last {last.execution - first.execution}",
         f"{run.per_execution_kb():.1f} KB", f"bound {BOUND_MB:.0f} MB over 80"),
        ("viser replay buffer", f"after {first.execution} → {last.execution}",
         f"{first.replayed} → {last.replayed} messages", ""),
    ]  # fmt: skip
    return format_table(("measure", "on", "result", "note"), rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m app.benchmark.memory")
    parser.add_argument("--executions", type=int, default=100)
    parser.add_argument("--pages", type=int, default=2)
    parser.add_argument("--replan", action="store_true", help="plan again before each")
    parser.add_argument("--no-models", action="store_true", help="without the robot's meshes")
    parser.add_argument("--trace", action="store_true", help="tracemalloc's biggest growths")
    args = parser.parse_args(argv)
    with watched_dashboard(models=not args.no_models) as dashboard:
        run = run_day(dashboard, args.executions, args.pages, replan=args.replan, trace=args.trace)
    print(table(run, args.pages))
    for size, where in run.growth:
        print(f"{size / 1024:+.1f} KB\n{where}")
    return 0 if run.growth_mb() <= BOUND_MB else 1


if __name__ == "__main__":
    sys.exit(main())
