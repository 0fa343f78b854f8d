"""The real Baxter (from example-robot-data's data files) in a pybullet DIRECT client.

The world frame is the bench frame of the scenario at the height of Baxter's base
frame (the top of its pedestal, ~0.93 m above the floor), so the bench top sits at
z = BENCH_TOP_Z and the robot base at `scenario.robot.base_pose` (x, y, yaw).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from xml.etree import ElementTree

from planner.feasibility._bullet import pb, silenced
from planner.feasibility.arms import ARMS, HOME, JOINT_SUFFIXES

_URDF_IN_PREFIX = "example-robot-data/robots/baxter_description/urdf/baxter.urdf"
HUMAN_URDF_IN_PREFIX = "example-robot-data/robots/human_description/robots/human.urdf"
# Crude implicit cylinders overlap when the elbow bends (field notes): shoulder vs
# upper elbow, upper elbow vs upper forearm (past e1 ~2.1 rad), plus their "_visual"
# twins, which carry collision shapes too.
_CRUDE_PAIRS = (
    ("{a}_upper_shoulder", "{a}_upper_elbow"),
    ("{a}_upper_shoulder", "{a}_upper_elbow_visual"),
    ("{a}_upper_elbow", "{a}_upper_forearm"),
    ("{a}_upper_elbow", "{a}_upper_forearm_visual"),
    ("{a}_upper_elbow_visual", "{a}_upper_forearm"),
    ("{a}_upper_elbow_visual", "{a}_upper_forearm_visual"),
    ("{a}_lower_elbow", "{a}_upper_forearm_visual"),
    ("{a}_upper_elbow_visual", "{a}_lower_elbow"),
    # The torso's collision mesh becomes its convex hull in pybullet: a slab out to the
    # arm mounts (y +/-0.34, x up to 0.20) that the upper elbow grazes whenever the arm
    # reaches across the front. Forearms and hands are still checked against it.
    ("{a}_upper_elbow", "torso"),
    ("{a}_upper_elbow_visual", "torso"),
)


class RobotModelMissing(RuntimeError):
    """example-robot-data is not installed, so there is no Baxter to load."""


def share_dir() -> Path:
    """`<site-packages>/cmeel.prefix/share`, found through the installed distribution."""
    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        raise RobotModelMissing("pip install example-robot-data (only its data is used)") from None
    share = Path(str(dist.locate_file("cmeel.prefix/share")))
    if not (share / _URDF_IN_PREFIX).is_file():
        raise RobotModelMissing(f"no {_URDF_IN_PREFIX} under {share}")
    return share


def baxter_urdf() -> Path:
    """A copy of baxter.urdf whose `package://` mesh names are absolute paths."""
    return resolved_urdf(_URDF_IN_PREFIX, "baxter")


def baxter_description() -> str:
    """baxter.urdf as shipped, its meshes named `package://example-robot-data/...`: for a
    viewer that resolves ROS packages on its own machine (an exported session)."""
    return (share_dir() / _URDF_IN_PREFIX).read_text()


def human_urdf() -> Path:
    """The same for example-robot-data's human model (drawn by the dashboard)."""
    return resolved_urdf(HUMAN_URDF_IN_PREFIX, "human")


def collision_urdf() -> Path:
    """baxter.urdf as the checks load it: without the bare frames at the ends of its
    chains (`without_bare_frames`)."""
    return resolved_urdf(_URDF_IN_PREFIX, "baxter-collision", without_bare_frames)


def resolved_urdf(
    in_prefix: str, name: str, edit: Callable[[str], str] | None = None
) -> Path:
    """A copy of the URDF at `in_prefix` (under `share_dir()`) with absolute mesh
    paths, and `edit` applied to its text.

    pybullet cannot resolve ROS package URLs; the copy lives in the temp dir, keyed by
    the source path and contents so a reinstall or another venv never reuses it.
    """
    share = share_dir()
    text = (share / in_prefix).read_text().replace("package://", f"{share}/")
    if edit is not None:
        text = edit(text)
    key = hashlib.sha256((str(share) + text).encode()).hexdigest()[:16]
    out = Path(tempfile.gettempdir()) / f"tandem-{name}-{key}.urdf"
    if not out.is_file():
        tmp = out.with_suffix(f".{os.getpid()}.tmp")  # one per process: they may race
        tmp.write_text(text)
        tmp.replace(out)  # atomic, so parallel workers never read half a file
    return out


def without_bare_frames(urdf: str) -> str:
    """`urdf` without the links that have no collision shape and hang, by a fixed
    joint, at the end of a chain (Baxter's cameras, range finders, accelerometers,
    cable guides, display frame: 15 of its 56 links), except the grippers'
    endpoints. Moving an arm moves every link of the body in pybullet, so each of
    them cost time in every collision check (49 us instead of 60 us for a move and
    its collision detection) and none can collide; the other links' poses are the
    same to the bit."""
    robot = ElementTree.fromstring(urdf)
    kept = {f"{arm}_gripper" for arm in ARMS}
    while True:
        joints = robot.findall("joint")
        parents = {_end(j, "parent") for j in joints}
        bare = {
            _end(j, "child"): j
            for j in joints
            if j.get("type") == "fixed" and _end(j, "child") not in parents | kept
        }
        links = [
            link
            for link in robot.findall("link")
            if link.get("name") in bare and link.find("collision") is None
        ]
        if not links:
            return ElementTree.tostring(robot, encoding="unicode")
        for link in links:
            robot.remove(link)
            robot.remove(bare[str(link.get("name"))])


def _end(joint: ElementTree.Element, which: str) -> str:
    end = joint.find(which)
    return "" if end is None else str(end.get("link"))


@dataclass
class BaxterBody:
    """A loaded Baxter: body id, joint indices and limits of each arm."""

    client: int
    body: int
    link: dict[str, int]  # link name -> link index (the base link is -1)
    arm_joints: dict[str, list[int]]
    lower: dict[str, list[float]]
    upper: dict[str, list[float]]
    end_effector: dict[str, int]  # the "<arm>_gripper" endpoint link
    movable: list[int]  # joint indices in the order IK results come back
    gripper_links: dict[str, set[int]] = field(default_factory=dict)
    arm_links: dict[str, set[int]] = field(default_factory=dict)

    def set_arm(self, arm: str, q: list[float]) -> None:
        pb.resetJointStatesMultiDof(
            self.body,
            self.arm_joints[arm],
            [[v] for v in q],
            physicsClientId=self.client,
        )

    def go_home(self) -> None:
        for arm in ARMS:
            self.set_arm(arm, HOME[arm])

    def within_limits(self, arm: str, q: list[float], tol: float = 1e-6) -> bool:
        lo, hi = self.lower[arm], self.upper[arm]
        return all(lo[i] - tol <= v <= hi[i] + tol for i, v in enumerate(q))


def load_robot(client: int, base_pose: list[float], urdf: Path | None = None) -> BaxterBody:
    """Load Baxter with a fixed base at (x, y, yaw) and filter its harmless self-contacts
    (from `collision_urdf()`, or from `urdf`)."""
    flags = (
        pb.URDF_USE_SELF_COLLISION
        | pb.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
        | pb.URDF_USE_IMPLICIT_CYLINDER
        | pb.URDF_IGNORE_VISUAL_SHAPES  # 0.06 s instead of 1.2 s; nothing is rendered
    )
    x, y, yaw = base_pose
    with silenced():  # "No inertial data" warnings for the massless frames
        body = pb.loadURDF(
            str(urdf or collision_urdf()),
            basePosition=[x, y, 0.0],
            baseOrientation=pb.getQuaternionFromEuler([0.0, 0.0, yaw]),
            useFixedBase=True,
            flags=flags,
            physicsClientId=client,
        )
    link: dict[str, int] = {pb.getBodyInfo(body, physicsClientId=client)[0].decode(): -1}
    joint: dict[str, int] = {}
    movable: list[int] = []
    lower: dict[str, float] = {}
    upper: dict[str, float] = {}
    for j in range(pb.getNumJoints(body, physicsClientId=client)):
        info = pb.getJointInfo(body, j, physicsClientId=client)
        name, jtype, child = info[1].decode(), info[2], info[12].decode()
        link[child] = j
        joint[name] = j
        lower[name], upper[name] = float(info[8]), float(info[9])
        if jtype != pb.JOINT_FIXED:
            movable.append(j)
    arm_joints = {a: [joint[f"{a}_{s}"] for s in JOINT_SUFFIXES] for a in ARMS}
    robot = BaxterBody(
        client=client,
        body=body,
        link=link,
        arm_joints=arm_joints,
        lower={a: [lower[f"{a}_{s}"] for s in JOINT_SUFFIXES] for a in ARMS},
        upper={a: [upper[f"{a}_{s}"] for s in JOINT_SUFFIXES] for a in ARMS},
        end_effector={a: link[f"{a}_gripper"] for a in ARMS},
        movable=movable,
    )
    for a in ARMS:
        side = a[0]
        # Everything distal to the wrist: these may touch the part being grasped.
        prefixes = (f"{side}_gripper", f"{a}_hand", f"{a}_gripper")
        robot.gripper_links[a] = {i for n, i in link.items() if n.startswith(prefixes)}
        # Links that move with the arm: only these can newly hit the bench or a part.
        robot.arm_links[a] = _descendants(body, client, arm_joints[a][0])
    _disable_harmless_pairs(robot)
    robot.go_home()
    return robot


def _descendants(body: int, client: int, root: int) -> set[int]:
    parent = {
        j: pb.getJointInfo(body, j, physicsClientId=client)[16]
        for j in range(pb.getNumJoints(body, physicsClientId=client))
    }
    out = {root}
    changed = True
    while changed:
        changed = False
        for j, p in parent.items():
            if p in out and j not in out:
                out.add(j)
                changed = True
    return out


def _disable_harmless_pairs(robot: BaxterBody) -> None:
    """Pairs touching at home (and at the all-zero pose) are modelling artefacts."""
    pairs: set[tuple[int, int]] = set()
    for pose in (HOME, {a: [0.0] * 7 for a in ARMS}):
        for a in ARMS:
            robot.set_arm(a, pose[a])
        pb.performCollisionDetection(physicsClientId=robot.client)
        for c in pb.getContactPoints(
            bodyA=robot.body, bodyB=robot.body, physicsClientId=robot.client
        ):
            pairs.add((c[3], c[4]))
    for a in ARMS:
        for left, right in _CRUDE_PAIRS:
            l_name, r_name = left.format(a=a), right.format(a=a)
            if l_name in robot.link and r_name in robot.link:
                pairs.add((robot.link[l_name], robot.link[r_name]))
    for i, j in pairs:
        pb.setCollisionFilterPair(robot.body, robot.body, i, j, 0, physicsClientId=robot.client)
