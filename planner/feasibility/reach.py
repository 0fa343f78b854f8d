"""Can an arm reach a part? IK for a top-down grasp, then a collision-free path (OMPL).

One `World` owns one pybullet DIRECT client with Baxter, the bench and the parts;
`check_reach(arm, part)` answers with a reason, so "no" is explainable: the target is
out of the arm's workspace ("no IK"), every way of reaching it hits something ("IK in
collision"), or no path from home was found within the time limit ("no path").
"""

from __future__ import annotations

import math
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Literal

from planner.feasibility._bullet import pb
from planner.feasibility.arms import HOME
from planner.feasibility.grasp_ik import IK_HOPELESS, GraspIk, IkAnswers, Question
from planner.feasibility.path_planner import FoundPath, find_path, finish_path, plan_path, seed_ompl
from planner.feasibility.robot import BaxterBody, load_robot
from planner.feasibility.scene import Scene, Site, build_scene
from planner.scenario.model import Scenario

Reason = Literal["ok", "no IK", "IK in collision", "no path"]
PlannerName = Literal["RRTConnect", "RRTstar"]

GOALS_WANTED = 3  # collision-free IK goals to try paths to


@dataclass
class _IkSearch:
    accurate: bool = False  # some IK solution met the pose, colliding or not
    goals: list[list[float]] = field(default_factory=list)


@dataclass(frozen=True)
class ReachDecision:
    """Whether an arm reaches a part, before its path is simplified; `found` lives
    in the process that decided (OMPL objects do not cross processes)."""

    reachable: bool
    reason: Reason
    seconds: float
    found: FoundPath | None
    simplify_seed: int = 0
    # The IK goal the path goes to: where the arm will stand (`finish_reach` keeps
    # it as the path's last state), known before the path is simplified.
    goal: list[float] | None = None


@dataclass(frozen=True)
class ReachResult:
    reachable: bool
    reason: Reason
    seconds: float
    # Joint configurations from home to the grasp. None: unreachable, or a fixed part's
    # work point whose path was not made (no motion goes there: `answer_only`).
    path: list[list[float]] | None

    @property
    def path_missing(self) -> bool:
        return self.reachable and self.path is None


class World:
    """Baxter, bench and parts of one scenario in a private pybullet client."""

    def __init__(
        self,
        scenario: Scenario,
        *,
        planner: PlannerName = "RRTConnect",
        time_limit: float = 1.0,
        seed: int = 0,
        robot: BaxterBody | None = None,
    ) -> None:
        """`robot`: Baxter already loaded on a client of its own with nothing else on it
        (a forked copy of `robot_only`); the scene is added to that client."""
        seed_ompl(seed)
        self.seed = seed
        self.planner = planner
        self.time_limit = time_limit
        self.client = pb.connect(pb.DIRECT) if robot is None else robot.client
        self.robot: BaxterBody = robot or load_robot(self.client, scenario.robot.base_pose)
        self.scene: Scene = build_scene(self.client, scenario)
        self._body_part = {b: pid for pid, b in self.scene.bodies.items()}
        self.ik = GraspIk(self.robot, self.scene.parts, seed)
        self._moving = self.robot.arm_links["left"] | self.robot.arm_links["right"]
        self._ignore_static_contacts()

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- collision checking -------------------------------------------------

    def _ignore_static_contacts(self) -> None:
        """Turns off contacts `is_valid` ignores anyway: between the bench and parts
        (they rest on it) and between them and robot links that never move. Each
        validity check then computes only contacts that can make a state invalid."""
        static = [self.scene.bench, *self.scene.bodies.values()]
        for i, a in enumerate(static):
            for b in static[i + 1 :]:
                pb.setCollisionFilterPair(a, b, -1, -1, 0, physicsClientId=self.client)
        body = self.robot.body
        fixed = [j for j in self.robot.link.values() if j not in self._moving]
        for other in static:
            for link in fixed:
                pb.setCollisionFilterPair(body, other, link, -1, 0, physicsClientId=self.client)

    def is_valid(
        self, arm: str, q: list[float], target: str | frozenset[str] | None = None
    ) -> bool:
        """`arm` at `q`, the other arm at home: no self-contact, no contact with the
        bench or a part, except the gripper touching `target` (the part or parts it
        grasps or works on)."""
        targets = frozenset([target]) if isinstance(target, str) else target or frozenset()
        self.robot.set_arm(arm, q)
        pb.performCollisionDetection(physicsClientId=self.client)
        body = self.robot.body
        for c in pb.getContactPoints(bodyA=body, physicsClientId=self.client):
            if c[1] == body and c[2] == body:
                return False  # self-collision that survived the filter
            link, other = (c[3], c[2]) if c[1] == body else (c[4], c[1])
            if link not in self._moving:
                continue  # pedestal or torso resting near the bench: not a motion problem
            if self._body_part.get(other) in targets and link in self.robot.gripper_links[arm]:
                continue
            return False
        return True

    # -- the query -----------------------------------------------------------

    def check_reach(self, arm: str, part: str, point: str | None = None) -> ReachResult:
        """From home to the part's work point, or with `point` to that connection
        point's site on the part's own footprint (`Site`)."""
        return self.finish_reach(self.decide_reach(arm, part, point))

    def decide_reach(
        self, arm: str, part: str, point: str | None = None, ik: IkAnswers | None = None
    ) -> ReachDecision:
        """The answer of `check_reach`; its path is made by `finish_reach`, which may
        come after other queries (the simplifier's random numbers are its own). `ik`:
        the answers of the first seed batches, solved beforehand with many other
        checks' (`GraspIk.first_batches`), else solved here."""
        start = time.perf_counter()
        self.robot.go_home()
        question = Question(arm, part, point)
        search = _IkSearch()
        seed_ompl(zlib.crc32(f"{self.seed}/{question.name}".encode()))
        # Goals come one at a time: the first one usually has a path, and IK restarts
        # cost more than a path query.
        for goal in self._ik_goals(question, search, ik):
            found = find_path(
                lambda q: self.is_valid(arm, q, part),
                HOME[arm],
                goal,
                self.robot.lower[arm],
                self.robot.upper[arm],
                planner=self.planner,
                time_limit=self.time_limit,
            )
            if found is not None:
                self.robot.go_home()
                seed = zlib.crc32(f"{self.seed}/{question.name}/simplify".encode())
                return ReachDecision(True, "ok", time.perf_counter() - start, found, seed, goal)
        self.robot.go_home()
        reason: Reason = (
            "no path" if search.goals else "IK in collision" if search.accurate else "no IK"
        )
        return ReachDecision(False, reason, time.perf_counter() - start, None)

    def finish_reach(self, decision: ReachDecision) -> ReachResult:
        """The decided answer with its path (from home to the grasp)."""
        if decision.found is None:
            return ReachResult(decision.reachable, decision.reason, decision.seconds, None)
        start = time.perf_counter()
        self.robot.go_home()  # the world the path was found in
        path = finish_path(decision.found, decision.simplify_seed)
        self.robot.go_home()
        seconds = decision.seconds + time.perf_counter() - start
        return ReachResult(decision.reachable, decision.reason, seconds, path)

    @staticmethod
    def answer_only(decision: ReachDecision) -> ReachResult:
        """The decided answer without its path, which `finish_reach` would make."""
        return ReachResult(decision.reachable, decision.reason, decision.seconds, None)

    def move(
        self, arm: str, start: list[float], goal: list[float], parts: frozenset[str]
    ) -> list[list[float]] | None:
        """A collision-free path between two configurations of `arm` whose gripper may
        touch `parts` (the one it holds, the one it works on), or None."""
        seed_ompl(zlib.crc32(f"{self.seed}/{arm}/{sorted(parts)}".encode()))
        path = plan_path(
            lambda q: self.is_valid(arm, q, parts),
            start,
            goal,
            self.robot.lower[arm],
            self.robot.upper[arm],
            planner=self.planner,
            time_limit=self.time_limit,
        )
        self.robot.go_home()
        return path

    # -- where the gripper is -------------------------------------------------

    def endpoint(self, arm: str, q: list[float]) -> tuple[float, float, float]:
        """The gripper endpoint of `arm` at `q`, by forward kinematics."""
        self.robot.set_arm(arm, q)
        state = pb.getLinkState(
            self.robot.body,
            self.robot.end_effector[arm],
            computeForwardKinematics=True,
            physicsClientId=self.client,
        )
        self.robot.go_home()
        return (float(state[4][0]), float(state[4][1]), float(state[4][2]))

    def site_target(self, site: Site) -> tuple[float, float, float]:
        """Where the gripper endpoint goes to work at `site` (`GraspIk.grasp_poses`)."""
        x, y, z = self.ik.grasp_poses(self.scene.parts[site.part], point=site.point)[0][0]
        return (x, y, z)

    # -- inverse kinematics --------------------------------------------------

    def _ik_goals(
        self, question: Question, search: _IkSearch, given: IkAnswers | None
    ) -> Iterator[list[float]]:
        """Distinct collision-free IK solutions, up to GOALS_WANTED; `search` records
        whether any accurate solution existed (to tell "no IK" from "IK in collision").
        The batches `given` are not solved again."""
        arm = question.arm
        poses = self.ik.poses(question)
        if not poses:
            return  # out of reach before any IK (GraspIk.out_of_reach)
        best = math.inf
        # Batches of seeds, each solved at once; the third only where every solution
        # so far collided (another posture may not).
        for number, seeds in enumerate(self.ik.seed_batches(question)):
            if number == 2 and (search.goals or not search.accurate):
                return
            asked = [(pose, seed) for seed in seeds for pose in poses]
            solved = given.batches[number] if given and number < len(given.batches) else None
            answers = self.ik.search(arm, asked) if solved is None else (a for _, a in solved)
            for (pose, _), answer in zip(asked, answers, strict=True):
                best = min(best, answer.pos_err)
                if not self.ik.accurate(arm, (pose, answer)):
                    continue
                search.accurate = True
                q = answer.q
                if self.is_valid(arm, q, question.part) and not any(
                    max(abs(a - b) for a, b in zip(q, g, strict=True)) < 1e-3 for g in search.goals
                ):
                    search.goals.append(q)
                    yield q
                    if len(search.goals) >= GOALS_WANTED:
                        return
            if not search.accurate and best > IK_HOPELESS:
                return  # every seed ends far from the target: it is out of reach


def robot_only(base_pose: list[float]) -> BaxterBody:
    """Baxter alone on a new client, for `World(robot=...)` in processes forked after it:
    each of them finds the robot loaded (0.08 s) and adds only its scene."""
    return load_robot(pb.connect(pb.DIRECT), base_pose)


__all__ = ["ReachResult", "World", "robot_only", "seed_ompl"]
