"""The simulated bench for camera runs: a world the robot and a simulated human change,
drawn by a simulated camera that perception then watches.

`SimulatedWorld` holds the physical facts (which arm holds which part, what the
human holds, what is attached where, what shape each leg's and foot's face
really has) and places the parts as the dashboard's world model does
(`app.execution.world.place_parts`), moving them in the camera's scene.
`SimulatedHuman` chooses, seeded, what the human does at a sensing node,
consistently with the plan, and does it in the world; it never answers a node:
the camera has to see what it did. It also decides, seeded, what a part whose
shape the scenario leaves open really is, and the camera draws it so: the
camera has to see that too. As an executor listener it applies the robot's
actions and complies with what the human agreed to at a question. It is what a
camera source lets act before it looks (`before_look`, the protocol
app.sources.camera.BeforeLook), alone or, in the dashboard, as a `DirectedHuman`
acting out the clicks.
"""

from __future__ import annotations

import math
import random
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from app.execution.events import REPAIR, ExecutionEvent, Interruptible, OutcomeSource
from app.execution.world import place_parts
from app.sim.hands import HandAction, PacedHands
from perception.layout import BenchLayout
from planner.feasibility.scene import PartBox
from planner.plan.model import Plan, PlanNode
from planner.vocabulary import (
    Action,
    Attach,
    Attached,
    Hands,
    Hold,
    Holding,
    HumanFree,
    HumanHolding,
    HumanHoldingPart,
    SenseHumanAttachingWhere,
    SenseHumanHolding,
    SenseHumanHoldingWhichPart,
    SenseHumanUnholding,
    SenseLengthOf,
    SenseShapeOf,
    Unhold,
    parse_fluent,
)

Vec3 = tuple[float, float, float]


class PartMover(Protocol):
    """What the world moves: a simulated camera's scene."""

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None: ...

    def reshape(self, part_id: str, profile: str) -> None: ...


class SimulatedWorld:
    """Where every part is: resting where the scenario puts it, lifted by an arm,
    in the human's hands, or attached at a slot of another part. With `hands`, what
    the human does moves the parts in the camera's scene over a person's time (the
    robot's changes are drawn at once); without, at once too."""

    def __init__(
        self,
        boxes: dict[str, PartBox],
        layout: BenchLayout,
        camera: PartMover | None = None,
        hands: PacedHands | None = None,
    ) -> None:
        self.boxes = boxes
        self.layout = layout
        self.camera = camera
        self.hands = hands
        self._drawing = threading.RLock()  # the shown poses: the hands' thread draws too
        # Parts the hands are moving or will move (how many moves each), and where
        # each will be once they are done.
        self._in_hands: dict[str, int] = {}
        self._planned: dict[str, tuple[Vec3, float]] = {}
        self.robot: dict[str, str] = {}  # arm -> part
        self.human: list[str] = []  # parts in the human's hands, in the order taken
        self.attached: dict[str, tuple[str, str]] = {}  # part -> (onto, slot)
        # What each leg's and foot's face really is: the first option until decided,
        # as the camera's scene draws it.
        self.outlines = {
            pid: shape.outlines[0] for pid, shape in layout.parts.items() if shape.outlines
        }
        self._shown: dict[str, tuple[Vec3, float]] = {}
        if camera is not None:  # a camera used before may still show a decided shape
            for pid, outline in self.outlines.items():
                camera.reshape(pid, outline)
        self.sync()

    # --- facts -----------------------------------------------------------------
    def state(self) -> list[str]:
        """The world as fluent texts, the form the dashboard's world model reads."""
        facts = [str(Holding(arm, part)) for arm, part in self.robot.items()]
        facts += [str(Attached(p, onto, slot)) for p, (onto, slot) in self.attached.items()]
        facts += [str(HumanHoldingPart(p)) for p in self.human]
        facts.append(str(HumanHolding()) if self.human else str(HumanFree()))
        return facts

    def free_parts(self) -> list[str]:
        """Movable parts resting on the bench, nobody holding them, nothing attached."""
        held = set(self.robot.values()) | set(self.human)
        return [
            pid
            for pid, box in self.boxes.items()
            if box.movable and pid not in held and pid not in self.attached
        ]

    def occupied(self, onto: str) -> set[str]:
        return {slot for o, slot in self.attached.values() if o == onto}

    # --- changes -----------------------------------------------------------------
    def robot_hold(self, arm: str, part: str) -> None:
        self.robot[arm] = part
        self.sync()

    def robot_attach(self, arm: str, onto: str, slot: str) -> None:
        part = self.robot.get(arm)
        if part is not None:
            self.attached[part] = (onto, slot)
            self.sync()

    def robot_unhold(self, arm: str) -> None:
        self.robot.pop(arm, None)  # an unattached part goes back where it was taken
        self.sync()

    def reshape(self, part: str, outline: str) -> None:
        """The part turns out to be `outline` (the world decides what it really is)."""
        self.outlines[part] = outline
        if self.camera is not None:
            self.camera.reshape(part, outline)

    def decide_outlines(self, rng: random.Random) -> None:
        """Each part whose shape is open becomes one of its options, at random."""
        for pid, shape in sorted(self.layout.parts.items()):
            if shape.outline_unknown:
                self.reshape(pid, rng.choice(shape.outlines))

    def human_take(self, part: str) -> None:
        if part not in self.human:
            self.human.append(part)
        self.attached.pop(part, None)
        self._handled("take", part)

    def human_put_down(self, part: str) -> None:
        if part in self.human:
            self.human.remove(part)
        self._handled("putdown", part)

    def human_attach(self, part: str, onto: str, slot: str) -> None:
        if part in self.human:
            self.human.remove(part)
        self.attached[part] = (onto, slot)
        self._handled("attach", part)

    def settle(self) -> None:
        """Until the human's hands have finished what they were doing."""
        if self.hands is not None:
            self.hands.wait()

    # --- drawing -----------------------------------------------------------------
    def poses(self) -> dict[str, tuple[Vec3, float]]:
        """Each part's box centre and yaw, as the dashboard places them."""
        placed = place_parts(self.boxes, self.state(), human_edge_x=self.layout.human_side_x)
        return {
            pid: ((p.x, p.y, p.z), self._yaw(pid, (p.x, p.y))) for pid, p in placed.items()
        }

    def _yaw(self, part: str, at: tuple[float, float]) -> float:
        """The part's own yaw, or half round from it to turn its code to where a
        person shows it: on a part in the human's hands, towards the bench (-x),
        not out past the hands where the camera's view of the bench ends; on an
        attached part, away from what it stands on. Only parts whose slots are all
        at their centre turn, so the slots' offsets (in the bench's axes) stay right."""
        box = self.boxes[part]
        shape = self.layout.parts.get(part)
        if shape is None or shape.code_offset == (0.0, 0.0):
            return box.yaw
        if any(abs(dx) > 1e-9 or abs(dy) > 1e-9 for dx, dy in shape.slots.values()):
            return box.yaw
        dx, dy = shape.code_offset
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        code = (c * dx - s * dy, s * dx + c * dy)  # the code's offset in the bench's axes
        if part in self.human:
            return box.yaw if code[0] <= 0 else box.yaw + math.pi
        if part not in self.attached:
            return box.yaw
        onto = self.boxes[self.attached[part][0]]
        outwards = (at[0] - onto.x) * code[0] + (at[1] - onto.y) * code[1]
        return box.yaw if outwards >= 0 else box.yaw + math.pi

    def sync(self) -> None:
        """Moves the parts whose pose changed in the camera's scene (not those the
        human's hands are moving: they arrive where the world then has them)."""
        if self.camera is None:
            return
        with self._drawing:
            for pid, pose in self.poses().items():
                if pid not in self._in_hands and self._shown.get(pid) != pose:
                    self.camera.move(pid, pose[0], pose[1])
                    self._shown[pid] = pose

    def _handled(self, action: HandAction, part: str) -> None:
        """The human moved `part` (and what is attached to it): drawn over the hands'
        time when they take it, else at once."""
        if self.hands is None or self.camera is None:
            self.sync()
            return
        with self._drawing:
            paths = {}
            for pid, pose in self.poses().items():
                was = self._planned.get(pid, self._shown.get(pid))
                if was is not None and was != pose:
                    paths[pid] = (was, pose)  # from where the moves before leave it
                    self._planned[pid] = pose
                    self._in_hands[pid] = self._in_hands.get(pid, 0) + 1
            if paths:
                self.hands.submit(action, part, paths, self._arrived)

    def _arrived(self, shown: Mapping[str, tuple[Vec3, float]]) -> None:
        with self._drawing:
            self._shown.update(shown)
            for pid in shown:
                self._in_hands[pid] -= 1
                if not self._in_hands[pid]:
                    del self._in_hands[pid], self._planned[pid]
        self.sync()  # the world may have changed on the way (the robot went on)


@dataclass(frozen=True)
class HumanAct:
    """What the human really did at a sensing node: the outcome it makes true."""

    node_id: str
    action: Action | None
    label: str


class SimulatedHuman:
    """A seeded human acting out the plan's branches in a `SimulatedWorld`.

    `act(node_id, node, options)` at a sensing node picks one of the outcomes the
    world allows and makes it true (e.g. "yes" at `sense(humanHolding)` takes a
    part, one of the outcomes of the `sense(humanHoldingWhichPart)` that follows);
    `did[node_id]` keeps the label. It first decides (seeded) what each part whose
    shape is open really is; a look at the part is then answered by that truth.
    Pass `on_event` to the executor's listeners.
    """

    def __init__(self, plan: Plan, world: SimulatedWorld, seed: int | None = None) -> None:
        self.plan = plan
        self.world = world
        self.seed = seed
        self._rng = random.Random(seed)
        self.did: dict[str, str] = {}
        self.acts: list[HumanAct] = []
        self._intended: dict[str, str] = {}  # node -> label decided at an earlier node
        self._wanted: str | None = None  # the outcome clicked for the node being acted
        world.decide_outlines(self._rng)

    def _pick(self, choices: Sequence[str]) -> str:
        # A clicked outcome is taken whenever the world allows it; else a seeded choice.
        if self._wanted is not None and self._wanted in choices:
            return self._wanted
        return self._rng.choice(list(choices))

    def act(
        self, node_id: str, node: PlanNode, options: Sequence[str], wanted: str | None = None
    ) -> str | None:
        """Does what the human does at a sensing node; None at any other node.

        `wanted` (a click in the dashboard) says which outcome the human acts out;
        when the world does not allow it (hands already full), it does what it can.
        """
        if node_id in self.did:
            return self.did[node_id]  # asked again (a retry): it already happened
        self._wanted = wanted
        try:
            label = self._decide(node_id, node, options)
        finally:
            self._wanted = None
        if label is None:
            return None
        self.did[node_id] = label
        self.acts.append(HumanAct(node_id, node.action, label))
        return label

    # --- before the camera looks (app.sources.camera.BeforeLook) --------------------
    def before_look(self, node_id: str, node: PlanNode, options: Sequence[str]) -> bool:
        """Acts out a seeded outcome at a sensing node; the camera then has to see it,
        once the hands are done."""
        self.act(node_id, node, options)
        self.world.settle()
        return True

    def truth(self, node_id: str) -> str | None:
        """What the human really did at `node_id`, if it acted there."""
        return self.did.get(node_id)

    def _decide(self, node_id: str, node: PlanNode, options: Sequence[str]) -> str | None:
        w = self.world
        match node.action:
            case SenseHumanHolding():
                if w.human:
                    return "yes" if "yes" in options else None
                takeable = self._takeable(node)
                choices = [o for o in options if o == "no" or (o == "yes" and takeable)]
                if not choices:
                    return None  # asked to take a part, and none can be taken
                label = self._pick(choices)
                if label == "yes":
                    part = self._pick(takeable)
                    w.human_take(part)
                    after = node.child("yes")
                    if after is not None:
                        self._intended[after] = part
                return label
            case SenseHumanHoldingWhichPart():
                held = [p for p in w.human if p in options]
                if held:
                    return held[0]
                intended = self._intended.get(node_id)
                if intended is None or intended not in options:
                    free = [o for o in options if o in w.free_parts()]
                    intended = self._pick(free or list(options))
                w.human_take(intended)
                return intended
            case SenseHumanUnholding(part):
                if part not in w.human:
                    return "yes" if "yes" in options else None
                answers = [o for o in options if o in ("yes", "no")]
                if not answers:
                    return None
                label = self._pick(answers)
                if label == "yes":
                    w.human_put_down(part)
                return label
            case SenseHumanAttachingWhere(part, onto):
                free = [o for o in options if o not in w.occupied(onto)]
                slot = self._pick(free or list(options))
                w.human_attach(part, onto, slot)
                return slot
            case SenseShapeOf(part):
                # What the part is: the world decided it; a click for another
                # option says the bench really holds that (the part is swapped).
                truth = w.outlines.get(part)
                if self._wanted is not None and self._wanted in options:
                    if self._wanted != truth:
                        w.reshape(part, self._wanted)
                    return self._wanted
                return truth if truth in options else self._pick(list(options))
            case SenseLengthOf():
                # The human does nothing; a click (or the seed) decides what it is.
                return self._pick(list(options))
        return None

    def _takeable(self, node: PlanNode) -> list[str]:
        """Parts the plan lets the human be holding after "yes"."""
        free = self.world.free_parts()
        after_id = node.child("yes")
        after = None if after_id is None else self.plan.nodes.get(after_id)
        if after is None:
            return free
        if isinstance(after.action, SenseHumanHoldingWhichPart):
            return [o for o in after.outcomes if o in free]
        named = sorted(Hands.of(after.state).human)
        if named:
            return [p for p in named if p in free]
        return free

    # --- listening to the execution ------------------------------------------------
    def on_event(self, event: ExecutionEvent) -> None:
        """The robot's actions move parts; after a question or a request the human
        does what the plan now takes for granted (takes the part it agreed to
        attach, puts down what it was asked to)."""
        if event.kind == REPAIR and event.plan is not None:
            # The execution goes on with a new plan, whose node ids start afresh.
            self.plan = event.plan
            self.did.clear()
            self._intended.clear()
            return
        if event.action is None or event.kind == "sensing":
            return
        match event.action:
            case Hold(arm, part):
                self.world.robot_hold(arm, part)
            case Attach(arm, onto, slot):
                self.world.robot_attach(arm, onto, slot)
            case Unhold(arm):
                self.world.robot_unhold(arm)
        node = self.plan.nodes.get(event.node)
        if node is None:
            return
        after_id: str | None = node.child(event.outcome) if event.outcome is not None else None
        if event.outcome is None and node.children:
            after_id = node.children[0].node
        after = None if after_id is None else self.plan.nodes.get(after_id)
        if after is not None:
            self._comply(after.state)

    def _comply(self, state: Sequence[str]) -> None:
        facts = [parse_fluent(text) for text in state]
        if any(isinstance(f, HumanFree) for f in facts):
            for part in list(self.world.human):
                self.world.human_put_down(part)
            return
        for f in facts:
            if isinstance(f, HumanHoldingPart) and f.part not in self.world.human:
                self.world.human_take(f.part)

    def agreement(self, events: Sequence[ExecutionEvent]) -> tuple[int, int]:
        """(answers equal to what the human did, sensing answers) over `events`."""
        sensing = [e for e in events if e.kind == "sensing" and e.node in self.did]
        return sum(1 for e in sensing if e.outcome == self.did[e.node]), len(sensing)


class DirectedHuman:
    """A simulated human who acts out what another source chooses (the dashboard's
    clicks): at a sensing node `intent` picks the outcome, `human` makes it true in
    its world, and the camera has to see it (an app.sources.camera.BeforeLook)."""

    def __init__(self, human: SimulatedHuman, intent: OutcomeSource) -> None:
        self.human = human
        self.intent = intent

    def before_look(self, node_id: str, node: PlanNode, options: Sequence[str]) -> bool:
        wanted = self.intent.choose(node_id, node, options)
        if wanted is None:
            return False  # no click (an abort): nothing happened to look at
        self.human.act(node_id, node, options, wanted.label)
        self.human.world.settle()
        return True

    def truth(self, node_id: str) -> str | None:
        return self.human.truth(node_id)

    def interrupt(self) -> None:
        """Stops waiting for the intent (a click), as an abort does."""
        if isinstance(self.intent, Interruptible):
            self.intent.interrupt()
