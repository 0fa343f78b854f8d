"""A sound test that a grasp pose is out of an arm's reach, decided without IK.

The hand is rigid past the last wrist joint (w2), so a grasp pose fixes where
w2's origin must be. The shoulder joint s1 circles the vertical s0 axis at a
fixed radius and height, and the chain from s1 to w2 is no longer than the sum
of its links. A wrist point farther from that circle than the chain's length
(plus what IK's tolerances allow) has no IK solution: the check can answer
"no IK" at once. Stated in link lengths measured on the loaded robot, so it
holds for any base pose and never rejects a pose IK could meet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.feasibility._bullet import pb
from planner.feasibility.robot import BaxterBody


@dataclass(frozen=True)
class WristBound:
    """Where the w2 origin of one arm can possibly be."""

    axis_point: np.ndarray  # the s0 joint's origin
    axis: np.ndarray  # s0's axis (unit)
    shoulder_radius: float  # s1's distance from that axis
    shoulder_height: float  # s1's height along it, above axis_point
    chain: float  # s1 to w2: sum of the joint-origin distances
    wrist_in_hand: np.ndarray  # w2's origin in the end effector's frame
    slack: float  # how far IK's accepted pose may put the wrist from the asked one

    def out_of_reach(self, pos: list[float], orn: list[float]) -> bool:
        """True if no configuration puts the end effector at (`pos`, `orn`) within
        the tolerances `slack` was made for."""
        rotation = np.array(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
        wrist = np.asarray(pos) + rotation @ self.wrist_in_hand
        rel = wrist - self.axis_point
        height = float(rel @ self.axis)
        radial = float(np.linalg.norm(rel - height * self.axis))
        # The nearest point of s1's circle, however s0 is turned.
        gap = math.hypot(radial - self.shoulder_radius, height - self.shoulder_height)
        return gap > self.chain + self.slack


def wrist_bound(robot: BaxterBody, arm: str, pos_tol: float, orn_tol: float) -> WristBound:
    """The bound of `arm`, measured by forward kinematics at its current pose.

    `pos_tol` (metres) and `orn_tol` (radians) are the tolerances IK solutions are
    accepted with: the wrist of an accepted solution lies within
    pos_tol + orn_tol * |wrist_in_hand| of the asked one.
    """
    client, body = robot.client, robot.body

    def frame(link: int) -> tuple[np.ndarray, np.ndarray]:
        state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        rotation = np.array(pb.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        return np.array(state[4]), rotation

    joints = robot.arm_joints[arm]
    origins = [frame(j)[0] for j in joints]
    s0_position, s0_rotation = frame(joints[0])
    local_axis = np.array(pb.getJointInfo(body, joints[0], physicsClientId=client)[13])
    axis = s0_rotation @ local_axis
    axis = axis / np.linalg.norm(axis)
    rel = origins[1] - s0_position
    height = float(rel @ axis)
    ee_position, ee_rotation = frame(robot.end_effector[arm])
    in_hand = ee_rotation.T @ (origins[-1] - ee_position)
    links = zip(origins[1:], origins[2:], strict=False)
    chain = sum(float(np.linalg.norm(b - a)) for a, b in links)
    return WristBound(
        axis_point=s0_position,
        axis=axis,
        shoulder_radius=float(np.linalg.norm(rel - height * axis)),
        shoulder_height=height,
        chain=chain,
        wrist_in_hand=in_hand,
        # The chord of an orientation error is at most angle x radius; a millimetre
        # more for rounding in the kinematics.
        slack=pos_tol + orn_tol * float(np.linalg.norm(in_hand)) + 1e-3,
    )
