"""The address `tandem execute --robot ros` gives the robot, on a real roscore.

Rethink's baxter.sh sets `ROS_IP` to the workstation's address on the robot's
network; the robot connects back there for every topic and goal. A second
loopback address (127.0.0.2) stands for that network: the node must advertise
it, listen on it, and still drive the simulated Baxter to the goal.
"""

from __future__ import annotations

import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path
from urllib.parse import urlparse

import pytest

from app.robot.ros_env import RosMaster
from tests.robot_graph import ROOT, ros_installed, shared_master, sim_baxter

pytestmark = pytest.mark.skipif(not ros_installed(), reason="ROS 1 is not installed: make robot")

ROBOT_NETWORK_IP = "127.0.0.2"


def _executor_uri(master: RosMaster, run: subprocess.Popen[str]) -> str:
    """The XML-RPC URI the master holds for the run's node (once it registered)."""
    proxy = xmlrpc.client.ServerProxy(master.uri)
    began = time.monotonic()
    while time.monotonic() - began < 60:
        assert run.poll() is None, run.communicate()
        _, _, (publishers, subscribers, services) = proxy.getSystemState("/test")
        nodes = {n for _, names in publishers + subscribers + services for n in names}
        ours = [n for n in nodes if n.startswith("/tandem_executor")]
        if ours:
            code, _, uri = proxy.lookupNode("/test", ours[0])
            assert code == 1
            return str(uri)
        time.sleep(0.1)
    raise TimeoutError("the run's node never registered")


def test_ros_ip_is_the_address_the_node_advertises_and_the_run_reaches_the_goal(
    tmp_path: Path,
) -> None:
    master = shared_master()
    env = master.env()
    env.pop("ROS_HOSTNAME", None)
    env["ROS_IP"] = ROBOT_NETWORK_IP  # as baxter.sh sets it
    with sim_baxter(master):
        run = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "execute", "default.toml", "--responses",
             "random", "--seed", "1", "--robot", f"ros:{master.uri}", "--speed-ratio", "1.0",
             "--data-dir", str(tmp_path)],
            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            stdin=subprocess.DEVNULL,
        )  # fmt: skip
        uri = _executor_uri(master, run)
        out, err = run.communicate(timeout=300)
    assert urlparse(uri).hostname == ROBOT_NETWORK_IP, uri
    assert run.returncode == 0, err
    said = [line for line in out.splitlines() if line.startswith("robot: this node is at")]
    assert said == [
        f"robot: this node is at {uri} (ROS_IP={ROBOT_NETWORK_IP}); master {master.uri}"
    ]
    assert "goal after" in out
