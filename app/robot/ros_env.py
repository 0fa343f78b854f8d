"""ROS 1 for this venv: the Debian packages' modules, Baxter's message classes, a master.

Debian 12 packages ROS 1 for the system Python (`make robot` installs it);
`use_ros()` makes those modules importable here by appending their folder to
`sys.path` (appended, never prepended, so the venv's numpy and the rest win).
`control_msgs` (FollowJointTrajectory) and Baxter's `baxter_core_msgs` are not
packaged: their definitions ship in `ros_definitions/`, and genpy turns them
(with an action's expansion into its seven messages, as actionlib's genaction
does) into Python classes in the cache folder, keyed by a hash of the
definitions, on first use. The dependencies' definitions (std_msgs/Header,
trajectory_msgs, actionlib_msgs, geometry_msgs) are read from the installed classes, so the
checksums agree with the rest of the graph by construction.

Nothing here imports ROS at module level: the rest of Tandem runs without it.
`RosMaster` starts a private `roscore` on a free port (tests, `tandem robot sim`).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client
from pathlib import Path
from types import ModuleType, TracebackType
from typing import IO, Any

# Where Debian's python3-rospy & co. put their modules (for /usr/bin/python3).
DEBIAN_DIST_PACKAGES = Path("/usr/lib/python3/dist-packages")
DEFINITIONS = Path(__file__).resolve().parent / "ros_definitions"
# Bump when the generation below changes what it writes.
GENERATION_VERSION = 1
# The installed messages ours refer to: their definitions come from their classes.
INSTALLED_DEPENDENCIES = (
    "std_msgs/Header",
    "trajectory_msgs/JointTrajectory",
    "trajectory_msgs/JointTrajectoryPoint",
    "actionlib_msgs/GoalID",
    "actionlib_msgs/GoalStatus",
    "geometry_msgs/Pose",  # baxter_core_msgs/EndpointState
    "geometry_msgs/Twist",
    "geometry_msgs/Wrench",
)
_SECTION = "\n" + "=" * 80 + "\nMSG: "  # between the definitions in a class's _full_text
MASTER_WAIT_S = 30.0

_lock = threading.Lock()
_ready = False


class RosMissing(RuntimeError):
    """ROS 1 is not installed: `make robot` installs it (Debian packages)."""


def use_ros() -> None:
    """Makes rospy, actionlib, the installed messages and the generated
    `control_msgs` and `baxter_core_msgs` importable; idempotent.

    A ROS already on the path (a sourced ROS workspace) is used as it is."""
    global _ready
    with _lock:
        if _ready:
            return
        if importlib.util.find_spec("rospy") is None and DEBIAN_DIST_PACKAGES.is_dir():
            sys.path.append(str(DEBIAN_DIST_PACKAGES))
            importlib.invalidate_caches()
        needed = ("rospy", "actionlib", "genpy", "genmsg", "trajectory_msgs", "sensor_msgs")
        for module in (*needed, "geometry_msgs"):
            if importlib.util.find_spec(module) is None:
                raise RosMissing(f"ROS 1 is not installed (no {module}): run `make robot`")
        generated = str(message_dir())
        if generated not in sys.path:
            sys.path.append(generated)
            importlib.invalidate_caches()
        _ready = True


# -- Message generation ------------------------------------------------------------


def definitions() -> dict[str, str]:
    """Every message to generate, `package/Name` -> its definition text (an action
    expanded into its Goal, Result, Feedback and their Action* wrappers)."""
    out: dict[str, str] = {}
    for path in sorted(DEFINITIONS.glob("*/*/*")):
        package, text = path.parent.parent.name, path.read_text()
        if path.suffix == ".msg":
            out[f"{package}/{path.stem}"] = text
        elif path.suffix == ".action":
            for name, body in action_messages(path.stem, text).items():
                out[f"{package}/{name}"] = body
    return out


def action_messages(name: str, text: str) -> dict[str, str]:
    """An action's messages, as actionlib_msgs' genaction writes them."""
    parts: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            parts.append([])
        else:
            parts[-1].append(line)
    if len(parts) != 3:
        raise ValueError(f"{name}.action: expected goal --- result --- feedback")
    goal, result, feedback = ("\n".join(p) + "\n" for p in parts)
    return {
        f"{name}Goal": goal,
        f"{name}Result": result,
        f"{name}Feedback": feedback,
        f"{name}ActionGoal": f"Header header\nactionlib_msgs/GoalID goal_id\n{name}Goal goal\n",
        f"{name}ActionResult": (
            f"Header header\nactionlib_msgs/GoalStatus status\n{name}Result result\n"
        ),
        f"{name}ActionFeedback": (
            f"Header header\nactionlib_msgs/GoalStatus status\n{name}Feedback feedback\n"
        ),
        f"{name}Action": (
            f"{name}ActionGoal action_goal\n{name}ActionResult action_result\n"
            f"{name}ActionFeedback action_feedback\n"
        ),
    }


def message_dir() -> Path:
    """The folder holding the generated packages (generated now if missing)."""
    from planner.feasibility.cache import default_dir  # pydantic: only when ROS is chosen

    texts = definitions()
    digest = hashlib.sha256(repr((GENERATION_VERSION, sorted(texts.items()))).encode()).hexdigest()[
        :16
    ]
    root = default_dir() / "ros-messages"
    final = root / digest
    if not (final / "control_msgs" / "msg" / "__init__.py").is_file():
        root.mkdir(parents=True, exist_ok=True)
        # Another process may generate at the same time: build aside, rename whole.
        scratch = Path(tempfile.mkdtemp(prefix=f"{digest}.", dir=root))
        generate_messages(texts, scratch)
        try:
            scratch.rename(final)
        except OSError:
            shutil.rmtree(scratch, ignore_errors=True)  # the other one won
    return final


def generate_messages(texts: dict[str, str], out: Path) -> None:
    """Python classes for `texts` (`package/Name` -> definition) under `out/<package>/msg`."""
    loader = importlib.import_module("genmsg.msg_loader")
    generator = importlib.import_module("genpy.generator")
    initpy = importlib.import_module("genpy.generate_initpy")
    context = loader.MsgContext.create_default()
    for type_name in INSTALLED_DEPENDENCIES:
        _register_installed(context, loader, type_name)
    specs = []
    for full_name, text in texts.items():
        spec = loader.load_msg_from_string(context, text, full_name)
        context.register(full_name, spec)
        specs.append(spec)
    for spec in specs:
        folder = out / spec.package / "msg"
        folder.mkdir(parents=True, exist_ok=True)
        lines = generator.msg_generator(context, spec, {})
        (folder / f"_{spec.short_name}.py").write_text("\n".join(lines) + "\n")
    for package in {spec.package for spec in specs}:
        initpy.write_modules(str(out / package / "msg"))
        (out / package / "__init__.py").write_text("")


def _register_installed(context: Any, loader: ModuleType, type_name: str) -> None:
    """Registers an installed message's definition and those it embeds."""
    package, name = type_name.split("/")
    cls = getattr(importlib.import_module(f"{package}.msg"), name)
    own, *embedded = str(cls._full_text).split(_SECTION)
    for full_name, text in [(type_name, own), *(s.split("\n", 1) for s in embedded)]:
        if not context.is_registered(full_name):
            context.register(full_name, loader.load_msg_from_string(context, text, full_name))


# -- A master -------------------------------------------------------------------------


def ros_env(master_uri: str, log_dir: Path | None = None) -> dict[str, str]:
    """This process's environment for a ROS child process on `master_uri` (its logs
    and `~/.ros` files in `log_dir`, when given)."""
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = master_uri
    env["ROS_HOSTNAME"] = "127.0.0.1"
    env.pop("ROS_IP", None)  # would override ROS_HOSTNAME
    if log_dir is not None:
        env["ROS_LOG_DIR"] = str(log_dir)
        env["ROS_HOME"] = str(log_dir)
    return env


def master_answers(master_uri: str, timeout_s: float = 1.0) -> bool:
    """Whether a ROS master answers at `master_uri` (XML-RPC getSystemState)."""
    try:
        code, _, _ = _master(master_uri, timeout_s).getSystemState("/tandem")
        return bool(code == 1)
    except (OSError, xmlrpc.client.Error):
        return False


def system_state(master_uri: str) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """The master's publishers and subscribers: topic -> node names."""
    _, _, (publishers, subscribers, _) = _master(master_uri, 2.0).getSystemState("/tandem")
    return {t: list(n) for t, n in publishers}, {t: list(n) for t, n in subscribers}


def _master(master_uri: str, timeout_s: float) -> Any:
    """The master's XML-RPC API (its answers are untyped lists)."""
    return xmlrpc.client.ServerProxy(master_uri, transport=_TimeoutTransport(timeout_s))


class _TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC with a socket timeout, so a hung master never blocks the caller."""

    def __init__(self, timeout_s: float) -> None:
        super().__init__()
        self.timeout_s = timeout_s

    def make_connection(self, host: Any) -> Any:
        connection = super().make_connection(host)
        connection.timeout = self.timeout_s
        return connection


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _processes_naming(text: str) -> list[int]:
    """The processes whose command line contains `text` (read from /proc)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if text in cmdline.read_bytes().decode(errors="replace"):
                found.append(int(cmdline.parent.name))
        except OSError:
            continue
    return [pid for pid in found if pid != os.getpid()]


class RosMaster:
    """A private `roscore` on a free port; its logs in a temp folder removed on stop."""

    def __init__(self, port: int | None = None) -> None:
        self.port = port or free_port()
        self.uri = f"http://127.0.0.1:{self.port}"
        self.log_dir = Path(tempfile.mkdtemp(prefix="tandem-ros-"))
        self.process: subprocess.Popen[bytes] | None = None
        self._output: IO[bytes] | None = None
        self.started_s = 0.0  # how long roscore took to answer

    def env(self) -> dict[str, str]:
        """The environment for a ROS process on this master."""
        return ros_env(self.uri, self.log_dir)

    def start(self, timeout_s: float = MASTER_WAIT_S) -> RosMaster:
        roscore = shutil.which("roscore") or "/usr/bin/roscore"
        if not Path(roscore).is_file():
            raise RosMissing("ROS 1 is not installed (no roscore): run `make robot`")
        began = time.monotonic()
        self._output = (self.log_dir / "roscore.out").open("wb")
        # Its own process group: stop() and kill() reach rosmaster and rosout too.
        self.process = subprocess.Popen(
            [roscore, "-p", str(self.port)],
            env=self.env(),
            stdin=subprocess.DEVNULL,
            stdout=self._output,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        while not master_answers(self.uri, 0.5):
            if self.process.poll() is not None or time.monotonic() - began > timeout_s:
                tail = (self.log_dir / "roscore.out").read_text(errors="replace")[-600:]
                self.stop()
                raise RuntimeError(f"roscore on port {self.port} did not start: {tail}")
            time.sleep(0.1)
        self.started_s = time.monotonic() - began
        return self

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stops roscore as Ctrl-C does (then SIGKILL if it lingers)."""
        if self.process is not None and self.process.poll() is None:
            self._signal(signal.SIGINT)
            try:
                self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.kill()
        self._signal(signal.SIGKILL)  # children that outlived roslaunch
        if self._output is not None:
            self._output.close()
        shutil.rmtree(self.log_dir, ignore_errors=True)

    def kill(self) -> None:
        """SIGKILL to roscore, rosmaster and rosout at once: the master dies (faults)."""
        self._signal(signal.SIGKILL)
        if self.process is not None:
            self.process.wait(10.0)

    def _signal(self, sig: signal.Signals) -> None:
        if self.process is None:
            return
        try:
            os.killpg(self.process.pid, sig)
        except ProcessLookupError:
            pass
        # roslaunch starts rosmaster and rosout in sessions of their own: they are
        # found by their log folder, which is this master's.
        for pid in _processes_naming(str(self.log_dir)):
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass

    def __enter__(self) -> RosMaster:
        return self.start()

    def __exit__(
        self, kind: type[BaseException] | None, err: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
