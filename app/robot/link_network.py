"""The address this program's ROS node gives the robot, as rospy chooses it.

A ROS 1 node tells the master where others reach it (its XML-RPC URI); the
robot then connects back there for every topic Tandem publishes and for the
trajectory action's goals. rospy takes that address from `ROS_HOSTNAME`, else
`ROS_IP`, else the machine's name. Rethink's `baxter.sh` sets `ROS_IP` (or
`ROS_HOSTNAME`) to the workstation's address on the robot's network, so both
are respected as they are: loopback is chosen only when neither is set and the
master itself is on loopback (`tandem robot sim` on this machine), where the
machine's name might resolve to an address the loopback master's nodes do not
listen on.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Mapping, MutableMapping
from urllib.parse import urlparse

LOOPBACK_HOST = "127.0.0.1"


def on_loopback(host: str) -> bool:
    """Whether `host` (a name or an address) is this machine's loopback."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def address_override(environ: Mapping[str, str]) -> tuple[str, str] | None:
    """The variable rospy takes this node's address from, and its value (rospy
    prefers `ROS_HOSTNAME` to `ROS_IP`); None when neither is set."""
    for name in ("ROS_HOSTNAME", "ROS_IP"):
        if environ.get(name):
            return name, environ[name]
    return None


def choose_address(master_uri: str, environ: MutableMapping[str, str]) -> None:
    """Sets `ROS_HOSTNAME` to loopback in `environ` only when neither `ROS_HOSTNAME`
    nor `ROS_IP` is set and the master is on loopback (see the module's text)."""
    if address_override(environ) is None and on_loopback(urlparse(master_uri).hostname or ""):
        environ["ROS_HOSTNAME"] = LOOPBACK_HOST


def advertised_line(node_uri: str, master_uri: str, environ: Mapping[str, str]) -> str:
    """One line saying where the robot reaches this node, and why there; a warning
    when that is loopback while the master is not (the robot could not connect back)."""
    override = address_override(environ)
    why = f"{override[0]}={override[1]}" if override else "this machine's name"
    line = f"robot: this node is at {node_uri} ({why}); master {master_uri}"
    node_host = urlparse(node_uri).hostname or ""
    master_host = urlparse(master_uri).hostname or ""
    if on_loopback(node_host) and not on_loopback(master_host):
        line += (
            " - a loopback address the robot cannot reach: set ROS_IP to this machine's "
            "address on the robot's network"
        )
    return line
