"""Forward and inverse kinematics of one Baxter arm, in numpy.

pybullet's IK converges slowly on Baxter's arms (linearly, about 22 us an
iteration; after 100 iterations a reachable grasp is often still millimetres
off, so it was refined up to four times): it was four fifths of a reach
check's time. An `ArmChain` is the arm's seven joints measured on the loaded
robot (their frames at the zero pose and their axes), so its forward
kinematics is the robot's. Its IK is damped least squares with an adaptive
damping (Levenberg-Marquardt) on position and orientation within the joint
limits. Like pybullet's, it pulls the joints towards zero in the null space of
the pose: without that pull, more grasps on the paper's benches had only
postures that collide (14 answers of 612 changed, where 5 did with it). It solves
many seeds and poses at once (one numpy pass serves them all), converges
quadratically near a solution, and stops a search as soon as its pose is met,
it stalls, or it is hopelessly far.

Every answer is still checked by pybullet's own forward kinematics and limits
(`World._ik_goals`): this module decides speed, not correctness.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from planner.feasibility._bullet import pb
from planner.feasibility.robot import BaxterBody

# A solution meets the pose this closely (far within the tolerances the checks
# accept, reach.POS_TOL and ORN_TOL); a search that ends short of it, at a joint
# limit or a singular posture, found no grasp.
SOLVED_POS = 1e-3  # metres
SOLVED_ORN = 1e-2  # radians
MAX_ITERATIONS = 30
# Radians weigh as much as metres times this: 1 cm as much as 0.1 rad, the
# ratio of the acceptance tolerances.
ORN_WEIGHT = 0.1
# The pull towards the zero posture in the null space of the pose, per iteration.
REST_GAIN = 0.1
# A step that lowers the squared error by less than this share of it ends a search.
STALL_RATIO = 1e-3
# Still this far (squared error, ~0.25 m) after ten steps: the pose is out of reach.
HOPELESS_COST = 0.0625
HOPELESS_AFTER = 10
_EYE6 = np.eye(6)


@dataclass(frozen=True)
class IkAnswer:
    q: list[float]
    pos_err: float  # metres
    orn_err: float  # radians

    @property
    def solved(self) -> bool:
        return self.pos_err < SOLVED_POS and self.orn_err < SOLVED_ORN


Pose = tuple[Sequence[float], Sequence[float]]  # position, quaternion (x, y, z, w)


@dataclass(frozen=True)
class ArmChain:
    """One arm from its first joint to the gripper endpoint, each joint's frame
    turned so that it rotates about its own z axis."""

    first: np.ndarray  # 4x4 world pose of the first joint's frame at q = 0
    offsets: np.ndarray  # (7, 4, 4): each joint's frame in the previous one's, at q = 0
    tip: np.ndarray  # 4x4: the endpoint's frame in the last joint's frame
    lower: np.ndarray
    upper: np.ndarray

    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For configurations `q` (n, 7): world joint origins (n, 7, 3), world joint
        axes (n, 7, 3) and the endpoint's world poses (n, 4, 4)."""
        c, s = np.cos(q)[..., None], np.sin(q)[..., None]
        # offsets @ (rotation by q about z): only the first two columns change.
        local = np.empty((*q.shape, 4, 4))
        x, y = self.offsets[..., 0], self.offsets[..., 1]
        local[..., 0] = c * x + s * y
        local[..., 1] = c * y - s * x
        local[..., 2:] = self.offsets[..., 2:]
        joints = np.empty_like(local)
        pose = self.first
        for i in range(7):
            pose = pose @ local[:, i]
            joints[:, i] = pose
        return joints[..., :3, 3], joints[..., :3, 2], pose @ self.tip

    def pose(self, q: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """The endpoint's world position and rotation matrix at `q`."""
        end = self.frames(np.asarray([q], dtype=float))[2][0]
        return end[:3, 3], end[:3, :3]

    def search(self, poses: Sequence[Pose], seeds: Sequence[Sequence[float]]) -> Iterator[IkAnswer]:
        """For each (pose, seed) in order, a configuration within the limits that
        meets the pose, searched from the seed; where none is found, where the
        search ended. The searches run side by side, and each answer comes as soon
        as it and those before it are final: a caller that stops early (its first
        goal had a path) leaves the rest unfinished."""
        n = len(poses)
        target_p = np.array([p for p, _ in poses], dtype=float)
        target_r = np.array([pb.getMatrixFromQuaternion(o) for _, o in poses]).reshape(n, 3, 3)
        q = np.clip(np.asarray(seeds, dtype=float), self.lower, self.upper)
        error, jacobian = self._residual(q, target_p, target_r)
        cost = np.einsum("ij,ij->i", error, error)
        damping = np.full(n, 1e-3)
        active = ~_met(error)
        given = 0
        for step_no in range(MAX_ITERATIONS + 1):
            while given < n and not active[given]:
                yield self._answer(q[given], error[given])
                given += 1
            if given == n or step_no == MAX_ITERATIONS:
                break
            # Only the searches still going take a step: in a pass over many checks
            # (grasp_ik) most searches end within a few steps.
            live = np.flatnonzero(active)
            jac = jacobian[live]
            jac_t = jac.transpose(0, 2, 1)
            rest = -REST_GAIN * q[live]
            # The damped least-squares step to the pose plus the pull towards rest in
            # the pose's null space: J+ (e - J r) + r, with J+ = J^T (J J^T + d I)^-1.
            normal = jac @ jac_t + damping[live][:, None, None] * _EYE6
            aim = error[live] - np.einsum("nij,nj->ni", jac, rest)
            step = np.einsum("nij,nj->ni", jac_t, np.linalg.solve(normal, aim[..., None])[..., 0])
            trial = np.clip(q[live] + step + rest, self.lower, self.upper)
            trial_error, trial_jacobian = self._residual(trial, target_p[live], target_r[live])
            trial_cost = np.einsum("ij,ij->i", trial_error, trial_error)
            better = trial_cost < cost[live]
            improved = cost[live] - trial_cost
            up, down = live[better], live[~better]
            q[up], error[up] = trial[better], trial_error[better]
            jacobian[up], cost[up] = trial_jacobian[better], trial_cost[better]
            damping[up] = np.maximum(damping[up] / 3, 1e-7)
            damping[down] *= 5
            ends = better & ((improved < STALL_RATIO * trial_cost) | _met(error[live]))
            ends |= ~better & (damping[live] > 1e3)  # no step, however short, improves
            if step_no + 1 >= HOPELESS_AFTER:
                ends |= cost[live] > HOPELESS_COST
            active[live[ends]] = False
        for i in range(given, n):
            yield self._answer(q[i], error[i])

    @staticmethod
    def _answer(q: np.ndarray, error: np.ndarray) -> IkAnswer:
        return IkAnswer(
            [float(v) for v in q],
            float(np.linalg.norm(error[:3])),
            float(np.linalg.norm(error[3:])) / ORN_WEIGHT,
        )

    def _residual(
        self, q: np.ndarray, target_p: np.ndarray, target_r: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The pose errors (position; weighted rotation vector), (n, 6), and their
        Jacobians, (n, 6, 7)."""
        origins, axes, end = self.frames(q)
        p = end[:, :3, 3]
        error = np.empty((len(q), 6))
        error[:, :3] = target_p - p
        error[:, 3:] = ORN_WEIGHT * _rotation_vectors(target_r @ end[:, :3, :3].transpose(0, 2, 1))
        jacobian = np.empty((len(q), 6, 7))
        jacobian[:, :3] = _cross(axes, p[:, None, :] - origins).transpose(0, 2, 1)
        jacobian[:, 3:] = ORN_WEIGHT * axes.transpose(0, 2, 1)
        return error, jacobian


def _met(error: np.ndarray) -> np.ndarray:
    """Polished to a tenth of the SOLVED tolerances (compared squared)."""
    pos = np.einsum("ij,ij->i", error[:, :3], error[:, :3])
    orn = np.einsum("ij,ij->i", error[:, 3:], error[:, 3:])
    met: np.ndarray = (pos < (SOLVED_POS / 10) ** 2) & (orn < (ORN_WEIGHT * SOLVED_ORN / 10) ** 2)
    return met


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b along the last axis (np.cross costs more than its arithmetic here)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _rotation_vectors(r: np.ndarray) -> np.ndarray:
    """The axis times angle of each rotation matrix in `r` (n, 3, 3), angle in [0, pi]."""
    cos = np.clip((np.trace(r, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    skew = np.stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]], 1)
    sin = np.sin(angle)
    scale = np.where(angle < 1e-6, 0.5, angle / (2.0 * np.where(sin > 1e-12, sin, 1.0)))
    out = skew * scale[:, None]
    for i in np.flatnonzero(math.pi - angle < 1e-4):
        # Half a turn: the axis is the dominant column of r + I (its sign does not matter).
        k = int(np.argmax(np.diag(r[i])))
        axis = (r[i][:, k] + np.eye(3)[k]) / math.sqrt(2.0 * (1.0 + r[i][k, k]))
        out[i] = axis * angle[i]
    return out


def arm_chain(robot: BaxterBody, arm: str) -> ArmChain:
    """The chain of `arm`, measured by pybullet at the zero pose of that arm (the
    other arm does not move it). Leaves the robot at home."""
    client, body = robot.client, robot.body
    joints = robot.arm_joints[arm]
    robot.set_arm(arm, [0.0] * 7)

    def frame(link: int) -> np.ndarray:
        state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        pose = np.eye(4)
        pose[:3, :3] = np.array(pb.getMatrixFromQuaternion(state[5])).reshape(3, 3)
        pose[:3, 3] = state[4]
        return pose

    # A revolute joint's frame is its child link's frame (URDF), where its axis is
    # given; each is turned so the axis is its z axis.
    turned = []
    for j in joints:
        axis = np.array(pb.getJointInfo(body, j, physicsClientId=client)[13], dtype=float)
        turned.append(frame(j) @ _z_onto(axis / np.linalg.norm(axis)))
    offsets = [np.eye(4)] + [np.linalg.inv(a) @ b for a, b in zip(turned, turned[1:], strict=False)]
    tip = np.linalg.inv(turned[-1]) @ frame(robot.end_effector[arm])
    robot.go_home()
    return ArmChain(
        first=turned[0],
        offsets=np.array(offsets),
        tip=tip,
        lower=np.array(robot.lower[arm]),
        upper=np.array(robot.upper[arm]),
    )


def _z_onto(axis: np.ndarray) -> np.ndarray:
    """A 4x4 rotation taking the z axis onto the unit vector `axis`."""
    z = np.array([0.0, 0.0, 1.0])
    turn = np.eye(4)
    v, cos = np.cross(z, axis), float(z @ axis)
    if np.linalg.norm(v) < 1e-12:
        if cos < 0:
            turn[:3, :3] = np.diag([1.0, -1.0, -1.0])  # half a turn about x
        return turn
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    turn[:3, :3] = np.eye(3) + k + k @ k / (1.0 + cos)
    return turn
