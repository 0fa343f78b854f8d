"""A real ROS 1 graph for tests: a roscore, the simulated Baxter node, a node here.

- `ros_master`: a fixture giving the test process's one roscore (started on
  first use, stopped at exit: rospy binds a process to one master for good, so
  every module shares it). Skipped only when ROS is not installed (`make test`
  installs it). A test that kills a master starts its own `RosMaster`.
- `sim_baxter(master, start=None)`: `tandem robot sim` as a subprocess, returned
  once it printed its ready line (which it prints after its own joint states
  came back through the master); stopped with SIGTERM after. `kill_sim(sim)`
  kills it (SIGKILL) for fault tests.
- `ros_node(master)` and `JointWatch`: a rospy node in this process, on the
  shared master, and the joint states it hears; `FaultTopic`: the simulated
  node's fault drills ("abort", "mute", "unmute"), sent from that node;
  `SimControls`: the simulated robot's e-stop (`/tandem_sim/estop`), a goal that
  stops short (`/tandem_sim/stall`) and Baxter's own enable topic
  (`/robot/set_super_enable`), sent from that node too.
"""

from __future__ import annotations

import atexit
import importlib
import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from app.robot.ros_env import RosMaster, use_ros

ROOT = Path(__file__).resolve().parent.parent
READY_TIMEOUT_S = 60.0  # generous: the machine may be busy with a benchmark
_shared: list[RosMaster] = []
_node_master: list[str] = []


def ros_installed() -> bool:
    return shutil.which("roscore") is not None or Path("/usr/bin/roscore").is_file()


def shared_master() -> RosMaster:
    """The test process's roscore (started once, stopped at exit)."""
    if not _shared:
        master = RosMaster().start()
        atexit.register(master.stop)
        _shared.append(master)
    return _shared[0]


@pytest.fixture
def ros_master() -> RosMaster:
    if not ros_installed():
        pytest.skip("ROS 1 is not installed: make robot")
    return shared_master()


@dataclass
class SimBaxter:
    """A running `tandem robot sim`: its process, and what it wrote (stdout, stderr)."""

    process: subprocess.Popen[str]
    master: RosMaster
    started_s: float = 0.0  # from launch to its ready line
    lines: queue.Queue[str] = field(default_factory=queue.Queue)
    output: list[str] = field(default_factory=list)

    def stop(self, timeout_s: float = 15.0) -> int:
        """SIGTERM, then its exit code (SIGKILL if it does not exit in time)."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout_s)
        except subprocess.TimeoutExpired:
            kill_sim(self)
            raise

    def said(self) -> str:
        return "".join(self.output)


def _drain(stream: Any, sim: SimBaxter) -> None:
    for line in stream:
        sim.output.append(line)
        sim.lines.put(line)


@contextmanager
def sim_baxter(
    master: RosMaster,
    start: Mapping[str, float] | None = None,
    rate: float = 100.0,
    options: Sequence[str] = (),
) -> Iterator[SimBaxter]:
    """`tandem robot sim` on `master` (with `options`), ready (see the module's text);
    stopped after."""
    began = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "robot", "sim", "--master", master.uri,
         "--rate", str(rate), "--start", json.dumps(dict(start)) if start else "home",
         *options],
        cwd=ROOT, env=master.env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    sim = SimBaxter(process, master)
    for stream in (process.stdout, process.stderr):
        threading.Thread(target=_drain, args=(stream, sim), daemon=True).start()
    try:
        _wait_ready(sim, began)
        yield sim
    finally:
        if process.poll() is None:
            sim.stop()
        _unlatch()


# Every latched drill publisher made while a simulated node runs: unregistered when it
# stops, even after a failed test, or the master would hand its last message (an
# "abort") to every later test's node.
_LATCHED: list[Any] = []


_LAST_WORDS: list[FaultTopic] = []


def _unlatch() -> None:
    # A harmless drill last: should a later node still be handed the latched message
    # (rospy keeps it with the topic while any publisher of it lives in this process),
    # it is "unmute", not "abort".
    while _LAST_WORDS:
        topic = _LAST_WORDS.pop()
        if topic._publisher.impl is not None:
            topic.send("unmute")
    while _LATCHED:
        _LATCHED.pop().unregister()


def _wait_ready(sim: SimBaxter, began: float) -> None:
    while True:
        left = READY_TIMEOUT_S - (time.monotonic() - began)
        try:
            line = sim.lines.get(timeout=max(left, 0.01))
        except queue.Empty:
            raise TimeoutError(f"the simulated Baxter never got ready: {sim.said()}") from None
        if line.startswith("simulated Baxter ready on "):
            sim.started_s = time.monotonic() - began
            return


def kill_sim(sim: SimBaxter) -> None:
    """SIGKILL: the node dies without a word (its goals, topics and registrations stay)."""
    if sim.process.poll() is None:
        sim.process.kill()
    sim.process.wait(10.0)


def ros_node(master: RosMaster) -> Any:
    """rospy, initialised once in this process as a node on `master`."""
    use_ros()
    rospy = importlib.import_module("rospy")

    if not rospy.core.is_initialized():
        os.environ.update(
            ROS_MASTER_URI=master.uri, ROS_HOSTNAME="127.0.0.1", ROS_LOG_DIR=str(master.log_dir)
        )
        rospy.init_node("tandem_tests", anonymous=True, disable_signals=True)
        _node_master.append(master.uri)
    elif _node_master and _node_master[0] != master.uri:
        raise RuntimeError("this process's rospy node is on another master")
    return rospy


class JointWatch:
    """The joint states heard on `/robot/joint_states`: (arrival, name -> position)."""

    def __init__(self, master: RosMaster) -> None:
        rospy = ros_node(master)
        joint_state = importlib.import_module("sensor_msgs.msg").JointState

        self._lock = threading.Lock()
        # (arrival, time.monotonic(); the message's stamp, wall clock; name -> position)
        self.samples: list[tuple[float, float, dict[str, float]]] = []
        self._subscriber = rospy.Subscriber(
            "/robot/joint_states", joint_state, self._on_state, queue_size=200
        )

    def _on_state(self, message: Any) -> None:
        state = dict(zip(message.name, message.position, strict=True))
        with self._lock:
            self.samples.append((time.monotonic(), message.header.stamp.to_sec(), state))

    def since(self, t: float) -> list[dict[str, float]]:
        """The states that arrived from `t` (time.monotonic()) on."""
        return [state for _, state in self.arrived_since(t)]

    def arrived_since(self, t: float) -> list[tuple[float, dict[str, float]]]:
        """The states that arrived from `t` on, each with when it arrived."""
        with self._lock:
            return [(at, state) for at, _, state in self.samples if at >= t]

    def latest(self, timeout_s: float = 10.0) -> dict[str, float]:
        """The next state to arrive (it may have been published a moment ago)."""
        return self.wait_for(lambda _: True, timeout_s)

    def current(self, timeout_s: float = 10.0) -> dict[str, float]:
        """The first state published after now: what the robot does from this moment
        (a state arriving now may have been published before an action's result)."""
        now = time.time()  # rospy stamps with the wall clock
        began = time.monotonic()
        while time.monotonic() - began < timeout_s:
            with self._lock:
                later = [state for _, stamp, state in self.samples if stamp > now]
            if later:
                return later[0]
            time.sleep(0.01)
        raise TimeoutError(f"no joint state published in {timeout_s} s")

    def wait_for(
        self, fits: Callable[[dict[str, float]], bool], timeout_s: float = 10.0
    ) -> dict[str, float]:
        """The first state from now on that `fits` (TimeoutError if none comes)."""
        began = time.monotonic()
        while time.monotonic() - began < timeout_s:
            for state in self.since(began):
                if fits(state):
                    return state
            time.sleep(0.01)
        raise TimeoutError(f"no fitting joint state in {timeout_s} s")

    def close(self) -> None:
        self._subscriber.unregister()


class FaultTopic:
    """Publishes the simulated node's faults on `/tandem_sim/fault` (latched, so a
    fault sent before the node listens still reaches it)."""

    def __init__(self, master: RosMaster) -> None:
        rospy = ros_node(master)
        self._string = importlib.import_module("std_msgs.msg").String
        self._publisher = rospy.Publisher(
            "/tandem_sim/fault", self._string, queue_size=1, latch=True
        )
        _LATCHED.append(self._publisher)
        _LAST_WORDS.append(self)

    def send(self, fault: str) -> None:
        self._publisher.publish(self._string(data=fault))

    def close(self) -> None:
        self.send("unmute")  # the latched message a later node is handed, if any
        self._publisher.unregister()


class SimControls:
    """Latched publishers (a message sent before the node listens still reaches it):
    the simulated robot's e-stop button, its stall on each goal's end, and Baxter's
    `/robot/set_super_enable`."""

    def __init__(self, master: RosMaster) -> None:
        rospy = ros_node(master)
        std = importlib.import_module("std_msgs.msg")
        self._std = std
        self._estop = rospy.Publisher("/tandem_sim/estop", std.Bool, queue_size=1, latch=True)
        self._stall = rospy.Publisher("/tandem_sim/stall", std.Float64, queue_size=1, latch=True)
        self._enable = rospy.Publisher(
            "/robot/set_super_enable", std.Bool, queue_size=1, latch=True
        )
        _LATCHED.extend((self._estop, self._stall, self._enable))

    def estop(self, pressed: bool) -> None:
        self._estop.publish(self._std.Bool(data=pressed))

    def stall(self, radians: float) -> None:
        self._stall.publish(self._std.Float64(data=radians))

    def enable(self, enabled: bool) -> None:
        self._enable.publish(self._std.Bool(data=enabled))

    def close(self) -> None:
        for publisher in (self._estop, self._stall, self._enable):
            publisher.unregister()
