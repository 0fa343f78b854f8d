"""IK for top-down grasps: the kinematic half of a reach check, for many at once.

A reach check (`reach.World.decide_reach`) looks for IK solutions of a grasp from a
fixed sequence of seeds, in batches, then for a collision-free path to one of them.
The IK half needs the robot and the parts' boxes but no collision world, and the
searches of many checks run in one numpy pass (`kinematics.ArmChain.search`) at a
sixth of their cost one check at a time (paper-05: 624 searches in 140 ms, 900 ms
in checks of 8), with the same answers to the last bit: each search in a pass
takes its own steps. `GraspIk.first_batches` solves the first seed batches of
every check of a bench at once; a check none of whose answers meets its grasp is
"no IK" there and then, without a collision check, and the others take their
answers along (`IkAnswers`) to the process that checks their paths.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from planner.feasibility._bullet import pb
from planner.feasibility.arms import ARMS, HOME
from planner.feasibility.kinematics import IkAnswer, arm_chain
from planner.feasibility.robot import BaxterBody
from planner.feasibility.scene import PartBox, Site
from planner.feasibility.workspace import wrist_bound

GRASP_CLEARANCE = 0.02  # gripper endpoint this far above the part's top face
POS_TOL = 0.01  # metres, IK accepted only within this by forward kinematics
ORN_TOL = 0.10  # radians
IK_ATTEMPTS = 12
IK_GIVE_UP_AFTER = 4  # attempts; if none came within IK_HOPELESS the target is out of reach
IK_HOPELESS = 0.05  # metres
IK_MORE_ATTEMPTS = 24  # more seeds where every accurate solution collided
# Seeds come in batches: the first IK_GIVE_UP_AFTER (home and random ones), the
# rest of IK_ATTEMPTS, and IK_MORE_ATTEMPTS more where every solution so far collided.
BATCH_SIZES = (IK_GIVE_UP_AFTER - 1, IK_ATTEMPTS - IK_GIVE_UP_AFTER, IK_MORE_ATTEMPTS)

Pose = tuple[list[float], list[float]]  # position, quaternion (x, y, z, w)
Answered = tuple[Pose, IkAnswer]


@dataclass(frozen=True)
class Question:
    """Can `arm` grasp `part` top-down (at its work point, or at the site of its
    connection point `point`)?"""

    arm: str
    part: str
    point: str | None = None

    @property
    def name(self) -> str:
        """What the check's random numbers are seeded with."""
        return f"{self.arm}/{self.part if self.point is None else Site(self.part, self.point)}"


@dataclass(frozen=True)
class IkAnswers:
    """The answers of a question's first seed batches, each in the order asked
    (seed by seed, both grasps of a seed): what `World.decide_reach` would find."""

    batches: tuple[tuple[Answered, ...], ...]


class GraspIk:
    """The grasps of one bench's parts and their IK, for one loaded Baxter."""

    def __init__(self, robot: BaxterBody, parts: dict[str, PartBox], seed: int = 0) -> None:
        self.robot = robot
        self.parts = parts
        self.seed = seed
        self.reach_radius = {a: self._arm_length(a) for a in ARMS}
        self.wrist = {a: wrist_bound(robot, a, POS_TOL, ORN_TOL) for a in ARMS}
        self.chains = {a: arm_chain(robot, a) for a in ARMS}

    def grasp_poses(self, box: PartBox, arm: str = "left", point: str | None = None) -> list[Pose]:
        """Top-down grasps over the part's work point (its centre, or the top's connection
        point nearest `arm`) or over the site of its connection point `point`, fingers
        closing across its short side (they close along the gripper's y axis); the two
        yaws are the symmetric grasps."""
        yaw = box.yaw + (0.0 if box.size[0] >= box.size[1] else math.pi / 2)
        x, y = box.work_point(self.shoulder(arm)[:2]) if point is None else box.sites()[point]
        pos = [x, y, box.top_z + GRASP_CLEARANCE]
        return [
            (pos, list(pb.getQuaternionFromEuler([math.pi, 0.0, yaw + k * math.pi])))
            for k in (0, 1)
        ]

    def poses(self, question: Question) -> list[Pose]:
        """The grasps of `question`; none where no IK can meet them (`out_of_reach`)."""
        poses = self.grasp_poses(self.parts[question.part], question.arm, question.point)
        return [] if self.out_of_reach(question.arm, poses) else poses

    def out_of_reach(self, arm: str, poses: Sequence[Pose]) -> bool:
        """Sound tests without IK: farther than the arm stretched straight, or no wrist
        position can serve the grasp (workspace.py)."""
        shoulder = self.shoulder(arm)
        if min(math.dist(shoulder, p) for p, _ in poses) > self.reach_radius[arm]:
            return True
        return all(self.wrist[arm].out_of_reach(p, o) for p, o in poses)

    def seed_batches(self, question: Question) -> Iterator[list[list[float]]]:
        """The seeds of `question`'s batches, drawn from its own random numbers."""
        arm = question.arm
        rng = np.random.default_rng([self.seed, zlib.crc32(question.name.encode())])
        lo, hi = np.array(self.robot.lower[arm]), np.array(self.robot.upper[arm])
        for number, size in enumerate(BATCH_SIZES):
            batch = [list(map(float, rng.uniform(lo, hi))) for _ in range(size)]
            if number == 0:
                batch.insert(0, list(HOME[arm]))
            yield batch

    def search(self, arm: str, asked: Sequence[tuple[Pose, list[float]]]) -> Iterator[IkAnswer]:
        """IK of each (pose, seed), in order (lazily: `ArmChain.search`)."""
        return self.chains[arm].search([p for p, _ in asked], [q for _, q in asked])

    def meets(self, arm: str, q: list[float], pos: list[float], orn: list[float]) -> bool:
        """Whether pybullet's forward kinematics and joint limits accept `q` as a grasp
        at (`pos`, `orn`): the judge of every IK answer (`kinematics` only searches)."""
        self.robot.set_arm(arm, q)
        pos_err, orn_err = self.pose_error(arm, pos, orn)
        return pos_err < POS_TOL and orn_err < ORN_TOL and self.robot.within_limits(arm, q)

    def accurate(self, arm: str, answered: Answered) -> bool:
        (pos, orn), answer = answered
        return answer.solved and self.meets(arm, answer.q, pos, orn)

    def first_batches(
        self, questions: Iterable[Question]
    ) -> Iterator[tuple[Question, IkAnswers | None]]:
        """Each question with the answers of its first seed batches, or None where
        `decide_reach` would say "no IK": out of reach before IK, every answer of
        the first batch hopelessly far, or no answer of either batch accurate. The
        second batch is solved only where `decide_reach` would solve it (nothing
        accurate in the first). The searches of a batch run in one pass per arm,
        and each question comes as soon as its pass decides it: most reachable ones
        after the first pass of their arm."""
        self.robot.go_home()  # where the grasps are measured from
        batches: dict[Question, list[tuple[Answered, ...]]] = {}
        seeds: dict[Question, list[list[list[float]]]] = {}
        poses: dict[Question, list[Pose]] = {}
        unreachable = []
        for question in questions:
            poses[question] = self.poses(question)
            if not poses[question]:
                unreachable.append(question)
                continue
            drawn = self.seed_batches(question)
            seeds[question] = [next(drawn), next(drawn)]
            batches[question] = []
        for question in unreachable:
            yield question, None
        open_ = list(batches)
        for number in (0, 1):
            still = []
            for arm in ARMS:
                mine = [q for q in open_ if q.arm == arm]
                asked = [
                    [(pose, seed) for seed in seeds[q][number] for pose in poses[q]] for q in mine
                ]
                answers = iter(self.search(arm, [a for each in asked for a in each]))
                for q, each in zip(mine, asked, strict=True):
                    batches[q].append(tuple((pose, next(answers)) for pose, _ in each))
                for q in mine:
                    done = batches[q][-1]
                    if any(self.accurate(q.arm, a) for a in done):
                        yield q, IkAnswers(tuple(batches[q]))
                    elif number == 1 or min(a.pos_err for _, a in done) > IK_HOPELESS:
                        yield q, None  # nothing accurate in two batches, or hopelessly far
                    else:
                        still.append(q)
            open_ = still
        self.robot.go_home()

    def shoulder(self, arm: str) -> tuple[float, float, float]:
        s1 = self.robot.arm_joints[arm][1]
        state = pb.getLinkState(self.robot.body, s1, physicsClientId=self.robot.client)
        return (float(state[4][0]), float(state[4][1]), float(state[4][2]))

    def pose_error(self, arm: str, pos: list[float], orn: list[float]) -> tuple[float, float]:
        state = pb.getLinkState(
            self.robot.body,
            self.robot.end_effector[arm],
            computeForwardKinematics=True,
            physicsClientId=self.robot.client,
        )
        dot = abs(sum(a * b for a, b in zip(state[5], orn, strict=True)))
        return math.dist(state[4], pos), 2 * math.acos(min(1.0, dot))

    def _arm_length(self, arm: str) -> float:
        """Shoulder-to-endpoint distance with the arm stretched: nothing farther is reachable."""
        self.robot.set_arm(arm, [0.0] * 7)
        state = pb.getLinkState(
            self.robot.body,
            self.robot.end_effector[arm],
            computeForwardKinematics=True,
            physicsClientId=self.robot.client,
        )
        length = math.dist(self.shoulder(arm), state[4]) + 0.01
        self.robot.go_home()
        return length
