"""The executor's slots: where the plan's connection points are in the world, and what follows.

Slots follow the world (planner.feasibility.slot_map): outcomes speak the plan's
names, and `Slots` keeps this execution's map from those names to the world's
points (`world`). When the human attaches at another free slot than the branch
names (an outcome with a `slot`), or the robot's arm cannot reach the one its
attach names, the execution keeps to the branch and updates the map; a motion
whose node assumes another map (`PlanNode.slots`) goes to `retarget` (the motion
planner), so the event carries the motion the robot really makes, and its evidence
keeps it. Where the plan put parts by points (`points = "each"`), the human's
attach at another point is a surprise to plan again from instead.

The walker asks `at` once per node; a click source asks `slot_choices` and
`slot_label` (app.sources.outcomes.SlotChoices) what to offer.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from app.execution.events import Outcome, OutcomeError
from app.execution.evidence import Evidence, Retargeted, SlotFollowed
from app.execution.surprises import HumanAttached, Surprise
from planner.feasibility.scene import Site
from planner.feasibility.slot_map import SlotError, SlotMap, robot_choice
from planner.plan.model import Motion, Plan, PlanNode, RobotSlot
from planner.vocabulary import Action, Hands, SenseHumanAttachingWhere

# Why a motion assumed other slots than the world's and was played all the same.
NO_PLANNER = "no motion planner"


class Retarget(Protocol):
    """The motion planner behind re-targeting (app.execution.retargeting.MotionRetargeter)."""

    def motion(
        self, action: Action, state: list[str], real: Action, real_state: list[str]
    ) -> Motion | None:
        """The motion of `real` in `real_state` (the branch's `action` in `state`, at the
        world's slots); None when the branch's stored motion goes there already."""
        ...

    def reaches(self, arm: str, site: Site) -> bool:
        """Can `arm` work at `site`?"""
        ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class SlotStep:
    """What the world's slots make of one node.

    `motion`: at a node without outcomes, the motion to emit (the stored one, or
    re-targeted to the world's slots). `evidence`: what changed (the slot the human
    really used, or the re-targeting), for the event. `surprise`: the human used a
    point the plan counted on; plan again instead of following the outcome.
    """

    motion: Motion | None = None
    evidence: Evidence | None = None
    surprise: Surprise | None = None


class Slots:
    """The world's slots during one execution of `plan` (and of the plans that repair it).

    `retarget`, when given, plans the motions the world's slots move and answers
    which points the robot's arms reach; without it the plan's own slot choices are
    taken. `replans`: this execution can plan again, so a human at another point
    of a part placed by points is a surprise.
    """

    def __init__(self, plan: Plan, retarget: Retarget | None, *, replans: bool) -> None:
        self.plan = plan
        self.retarget = retarget
        self.replans = replans
        self.world = SlotMap(plan.facts)

    def switch_plan(self, plan: Plan) -> None:
        """Goes on with a repaired plan. The world's map stays: the repair planned in the
        plan's names, which the new plan keeps."""
        self.plan = plan

    def close(self) -> None:
        """Closes the motion planner (its check cache), in the thread that used it."""
        if self.retarget is not None:
            self.retarget.close()

    def at(self, node_id: str, node: PlanNode, outcome: Outcome | None) -> SlotStep:
        """The slots at `node`: `outcome` None at a node without outcomes (its motion),
        else the outcome a source chose (the slot it names is followed, or surprises).
        `OutcomeError` when the outcome names a slot the node cannot have."""
        if outcome is None:
            motion, evidence = self._motion(node)
            return SlotStep(motion=motion, evidence=evidence)
        surprise = self._point_surprise(node, outcome)
        if surprise is not None:
            return SlotStep(surprise=surprise)
        if outcome.surprise is not None:
            return SlotStep()  # the source's own surprise: nothing to follow
        return SlotStep(evidence=self._follow(node_id, node, outcome))

    # -- what a click offers (app.sources.outcomes.SlotChoices)

    def slot_choices(self, node: PlanNode) -> list[str]:
        """Where the human can attach at a humanAttachingWhere node: the free points, in
        the plan's names."""
        action = node.action
        if not isinstance(action, SenseHumanAttachingWhere):
            return []
        taken = {point for onto, point in Hands.of(node.state).attached.values()
                 if onto == action.onto}  # fmt: skip
        return [p for p in self.world.points.get(action.onto, []) if p not in taken]

    def slot_label(self, node: PlanNode, options: Sequence[str], point: str) -> str:
        """The outcome label for attaching at `point`: the point itself if the node has
        that outcome, else its first (and `at` follows `point`)."""
        return point if point in options else options[0]

    # -- the human's slot

    def _follow(self, node_id: str, node: PlanNode, outcome: Outcome) -> Evidence | None:
        """Maps the branch's point onto the one the human used (both in the plan's names:
        the map says where that is in the world), if they differ."""
        if outcome.slot is None or outcome.slot == outcome.label:
            return None
        action = node.action
        if not isinstance(action, SenseHumanAttachingWhere):
            raise OutcomeError(f"{node.action} at {node_id} has no slot to observe")
        if outcome.slot not in self.slot_choices(node):
            raise OutcomeError(
                f"{node.action} at {node_id}: {action.onto} has no free point {outcome.slot} "
                f"(free: {', '.join(self.slot_choices(node))})"
            )
        real = self.world.real(action.onto, outcome.slot)
        try:
            self.world.follow(action.onto, outcome.label, real, node.state)
        except SlotError as err:
            raise OutcomeError(f"{node.action} at {node_id}: {err}") from None
        slots = self.world.to_json()
        return Evidence(slot=SlotFollowed(action.onto, outcome.label, outcome.slot, real, slots))

    def _point_surprise(self, node: PlanNode, outcome: Outcome) -> Surprise | None:
        """Where the plan puts parts by points (`points = "each"`, facts
        `pointsChecked`), its later motions and arms count on the point the branch
        names: the human's attach at another one is a surprise to plan again from,
        not a name to map (only when this execution can plan again)."""
        action = node.action
        if (
            not self.replans
            or outcome.slot is None
            or outcome.slot == outcome.label
            or not isinstance(action, SenseHumanAttachingWhere)
            or f"pointsChecked({action.onto})" not in self.plan.facts
            or outcome.slot not in self.slot_choices(node)  # refused by `_follow`
        ):
            return None
        real = self.world.real(action.onto, outcome.slot)
        return HumanAttached(action.part, action.onto, real)

    # -- the robot's motion

    def _motion(self, node: PlanNode) -> tuple[Motion | None, Evidence | None]:
        """The node's stored motion where the world's slots are those it assumes; else
        re-targeted to the world's, with evidence saying so and keeping the new motion."""
        if node.motion is None or node.action is None:
            return node.motion, None
        chosen = None
        if self.retarget is not None:
            chosen = robot_choice(self.world, node.action, node.state, self.retarget.reaches)
        elif node.robot_slot is not None:
            self._take_plans_choice(node.robot_slot, node.state)  # none to ask: the plan's
        planned = SlotMap(self.plan.facts, node.slots)
        if planned == self.world:
            return node.motion, None
        assumed = planned.action(node.action), planned.state(node.state)
        real = self.world.action(node.action), self.world.state(node.state)
        if assumed[0] == real[0] and sorted(assumed[1]) == sorted(real[1]):
            return node.motion, None
        retargeted = Retargeted(
            real_action=str(real[0]),
            slots=self.world.to_json(),
            robot_slot=None if chosen is None else chosen.model_dump(exclude_none=True),
        )
        if self.retarget is None:
            return node.motion, Evidence(retargeted=replace(retargeted, reason=NO_PLANNER))
        motion = self.retarget.motion(*assumed, *real)
        if motion is None:
            return node.motion, None
        return motion, Evidence(retargeted=replace(retargeted, motion=motion))

    def _take_plans_choice(self, choice: RobotSlot, state: list[str]) -> None:
        """The robot's slot choice the plan made here, where the world lets it."""
        onto, real = choice.onto, choice.real
        if real in self.world.free(onto, state) and real in self.world.points.get(onto, []):
            self.world.follow(onto, choice.branch, real, state)
