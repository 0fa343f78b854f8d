"""A simulated camera over the bench: pybullet renders parts (boxes, cylinders or
triangular prisms, after their outline) with QR codes on their top faces and
reference codes on the bench, from a settable camera pose.

Codes are one-quad OBJ meshes with UVs 0..1 (a texture on a box face comes out
cropped); the quad includes the quiet zone, so it may overhang a narrow part like a
label. The camera is a `FrameSource`; `move` and `cover` change the world between
frames, and `Degradation` adds pose jitter, blur, noise and lighting changes.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import pybullet as pb

from perception.codes_image import printed_side, qr_image
from perception.frames import Frame, Image
from perception.intrinsics import CameraIntrinsics
from perception.markers import DEFAULT_MARKER_SIZE_M, ReferenceMarker, encode_reference
from perception.pose import CameraPose

Vec3 = tuple[float, float, float]
_QUAD_OBJ = """v -0.5 -0.5 0
v 0.5 -0.5 0
v 0.5 0.5 0
v -0.5 0.5 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
"""
_CIRCLE_SIDES = 48
_LIFT_CODE = 0.0008  # the code floats this far over its face, against z-fighting


@dataclass(frozen=True)
class SimPart:
    """A part in its box: centre position, yaw about z, size (x, y, z), and the payload
    of the code on its top face (None: no code). `profile` is its top face's outline
    in that box: "square" fills it, "circle" a cylinder across its narrower side,
    "triangle" an equilateral prism (`triangle_corners`); any other word a box."""

    part_id: str
    size: Vec3
    position: Vec3
    payload: str | None = None
    yaw: float = 0.0
    colour: tuple[float, float, float] = (0.85, 0.8, 0.7)
    code_offset: tuple[float, float] = (0.0, 0.0)  # on the top face, in the part's axes
    profile: str = "square"


def triangle_corners(width: float, depth: float) -> tuple[tuple[float, float], ...]:
    """An equilateral triangle as large as fits a width x depth footprint, centred
    on it: its base along -y, its apex towards +y (the part's own axes)."""
    side = min(width, depth * 2 / math.sqrt(3))
    height = side * math.sqrt(3) / 2
    return ((-side / 2, -height / 2), (side / 2, -height / 2), (0.0, height / 2))


def prism_obj(corners: tuple[tuple[float, float], ...], height: float) -> str:
    """A closed prism over a convex polygon (counter-clockwise), as OBJ text with one
    normal per face so that the renderer shades its faces flat."""
    lines: list[str] = []
    n = len(corners)
    faces: list[tuple[list[tuple[float, float, float]], tuple[float, float, float]]] = []
    top = [(x, y, height / 2) for x, y in corners]
    bottom = [(x, y, -height / 2) for x, y in reversed(corners)]
    faces += [(top, (0.0, 0.0, 1.0)), (bottom, (0.0, 0.0, -1.0))]
    for i in range(n):
        (x0, y0), (x1, y1) = corners[i], corners[(i + 1) % n]
        length = math.hypot(x1 - x0, y1 - y0)
        normal = ((y1 - y0) / length, -(x1 - x0) / length, 0.0)
        quad = [(x0, y0, -height / 2), (x1, y1, -height / 2),
                (x1, y1, height / 2), (x0, y0, height / 2)]
        faces.append((quad, normal))
    index = 1
    for k, (vertices, normal) in enumerate(faces, start=1):
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
        lines.append(f"vn {normal[0]:.6f} {normal[1]:.6f} {normal[2]:.6f}")
        for j in range(1, len(vertices) - 1):
            a, b, c = index, index + j, index + j + 1
            lines.append(f"f {a}//{k} {b}//{k} {c}//{k}")
        index += len(vertices)
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class SimScene:
    parts: tuple[SimPart, ...]
    references: tuple[ReferenceMarker, ...]
    bench_top_z: float = -0.05
    bench_x: tuple[float, float] = (0.30, 1.40)
    bench_y: tuple[float, float] = (-0.70, 0.70)
    marker_size_m: float = DEFAULT_MARKER_SIZE_M
    light_direction: Vec3 = (0.3, 0.2, 1.0)
    hands_x: float | None = None  # where the human holds parts; None: just past the bench


@dataclass(frozen=True)
class CameraPlacement:
    eye: Vec3
    target: Vec3
    up: Vec3 = (1.0, 0.0, 0.0)

    def pose(self) -> CameraPose:
        """The camera (OpenCV axes: x right, y down, z forward) in the bench frame."""
        eye = np.array(self.eye, dtype=np.float64)
        forward = np.array(self.target, dtype=np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.array(self.up, dtype=np.float64))
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        return CameraPose(np.column_stack([right, down, forward]), eye)


@dataclass(frozen=True)
class Degradation:
    """Random per-frame disturbances; zeros mean a clean render."""

    jitter_m: float = 0.0  # std of the eye and target positions
    blur_px: float = 0.0  # up to this Gaussian sigma
    noise: float = 0.0  # std of additive noise, in 0..255 grey levels
    gain: tuple[float, float] = (1.0, 1.0)  # brightness factor range
    light_jitter: float = 0.0  # std of the light direction's components
    seed: int = 0


# The simulated camera looks straight down over the middle of the bench and the
# human's hands, OVERHEAD_HEIGHT above the bench top unless the bench or a code held
# in the hands would then be out of view: 60 deg across a square image. Over the
# paper's bench (x 0.30..1.40, hands at 1.55) it is at x 0.975, 1.45 m up: the whole
# bench and the hands are in view and a 10 cm code spans ~62 px at 1024 px (~38 at
# 640, near the limit). Measured with jitter, blur, noise and gain: 99 % of the codes
# decode at 1024 px, 76 % at 896, 28 % at 768; a frame renders in ~0.15 s.
# perception.bench maps distance and tilt.
OVERHEAD_HEIGHT = 1.45
HANDS_PAST_EDGE = 0.15  # where the human holds parts, when the scene does not say
HELD_CODE_ABOVE = 0.30  # how high over the bench top a held part's code may be
_VIEW_PAST_HANDS = 0.10  # the middle of the view is that of the bench and this much more
_VIEW_USED = 0.97  # of the half-view: a code at the very edge of the frame may not read
DEFAULT_SIZE = (1024, 1024)
DEFAULT_HFOV_DEG = 60.0


def overhead(
    scene: SimScene, hfov_deg: float = DEFAULT_HFOV_DEG, size: tuple[int, int] = DEFAULT_SIZE
) -> CameraPlacement:
    """Straight down over `scene`'s bench and hands, as low as keeps them in view.

    The camera's up is +x, so the bench's length runs down the image and its width
    across. It stays `OVERHEAD_HEIGHT` up unless the bench top (its corners carry
    the reference codes) or a code held at the hands' x, `HELD_CODE_ABOVE` the
    bench, would leave the view; then it rises just enough for all of them.
    """
    (x0, x1), (y0, y1) = scene.bench_x, scene.bench_y
    hands = scene.hands_x if scene.hands_x is not None else x1 + HANDS_PAST_EDGE
    middle = (x0 + max(x1, hands + _VIEW_PAST_HANDS)) / 2
    tan_across = _VIEW_USED * math.tan(math.radians(hfov_deg) / 2)
    tan_along = tan_across * size[1] / size[0]
    sides = [printed_side(p.payload, scene.marker_size_m) for p in scene.parts if p.payload]
    half_code = max(sides, default=scene.marker_size_m) / 2
    height = max(
        OVERHEAD_HEIGHT,
        (middle - x0) / tan_along,
        (x1 - middle) / tan_along,
        (hands + half_code - middle) / tan_along + HELD_CODE_ABOVE,
        (y1 - y0) / 2 / tan_across,
    )
    y = (y0 + y1) / 2
    top = scene.bench_top_z
    return CameraPlacement(eye=(middle, y, top + height), target=(middle, y, top))


class SimulatedCamera:
    """Renders `scene` (a `FrameSource`) from `placement`, by default `overhead` of
    its bench; world changes apply to the next frame."""

    def __init__(
        self,
        scene: SimScene,
        placement: CameraPlacement | None = None,
        size: tuple[int, int] = DEFAULT_SIZE,
        hfov_deg: float = DEFAULT_HFOV_DEG,
        degradation: Degradation | None = None,
        fps: float = 30.0,
    ) -> None:
        self.scene = scene
        self.placement = placement or overhead(scene, hfov_deg, size)
        self.degradation = degradation or Degradation()
        self._size = size
        self._hfov = hfov_deg
        self._fps = fps
        self._rng = np.random.default_rng(self.degradation.seed)
        self._index = 0
        self._dir = Path(tempfile.mkdtemp(prefix="tandem-sim-"))
        self._client = pb.connect(pb.DIRECT)
        self._quad = self._dir / "quad.obj"
        self._quad.write_text(_QUAD_OBJ)
        self._bodies: dict[str, tuple[int, int | None]] = {}  # part -> (box, code)
        self._parts: dict[str, SimPart] = {}
        self._covers: dict[str, int] = {}
        self.last_pose: CameraPose = self.placement.pose()
        self._build()

    # --- the world ---------------------------------------------------------------
    def _code_body(self, payload: str, key: str) -> tuple[int, float]:
        """A textured quad for `payload`; returns the body and its side (with margin)."""
        side = printed_side(payload, self.scene.marker_size_m)
        png = self._dir / f"{key}.png"
        qr_image(payload, module_px=8).save(png)
        shape = pb.createVisualShape(
            pb.GEOM_MESH, fileName=str(self._quad), meshScale=[side, side, 1.0],
            physicsClientId=self._client,
        )
        body = pb.createMultiBody(baseVisualShapeIndex=shape, physicsClientId=self._client)
        texture = pb.loadTexture(str(png), physicsClientId=self._client)
        pb.changeVisualShape(body, -1, textureUniqueId=texture, rgbaColor=[1, 1, 1, 1],
                             physicsClientId=self._client)
        return body, side

    def _box(self, size: Vec3, colour: tuple[float, float, float, float]) -> int:
        shape = pb.createVisualShape(
            pb.GEOM_BOX, halfExtents=[s / 2 for s in size], rgbaColor=list(colour),
            physicsClientId=self._client,
        )
        return int(pb.createMultiBody(baseVisualShapeIndex=shape, physicsClientId=self._client))

    def _solid(self, part: SimPart) -> int:
        """The part's body after its outline (see `SimPart`)."""
        colour = [*part.colour, 1.0]
        w, d, h = part.size
        if part.profile == "circle":
            # A many-sided prism, not GEOM_CYLINDER: the renderer shades that one's
            # flat top like a dome.
            corners = tuple(
                (min(w, d) / 2 * math.cos(a), min(w, d) / 2 * math.sin(a))
                for a in np.linspace(0, 2 * math.pi, _CIRCLE_SIDES, endpoint=False)
            )
        elif part.profile == "triangle":
            corners = triangle_corners(w, d)
        else:
            return self._box(part.size, (*part.colour, 1.0))
        mesh = self._dir / f"{part.profile}-{w:.4f}-{d:.4f}-{h:.4f}.obj"
        mesh.write_text(prism_obj(corners, h))
        shape = pb.createVisualShape(
            pb.GEOM_MESH, fileName=str(mesh), rgbaColor=colour, physicsClientId=self._client,
        )
        return int(pb.createMultiBody(baseVisualShapeIndex=shape, physicsClientId=self._client))

    def _build(self) -> None:
        s = self.scene
        (x0, x1), (y0, y1) = s.bench_x, s.bench_y
        thickness = 0.04
        bench = self._box((x1 - x0, y1 - y0, thickness), (0.45, 0.36, 0.28, 1.0))
        pb.resetBasePositionAndOrientation(
            bench, [(x0 + x1) / 2, (y0 + y1) / 2, s.bench_top_z - thickness / 2], [0, 0, 0, 1],
            physicsClientId=self._client,
        )
        for ref in s.references:
            body, _ = self._code_body(encode_reference(ref.name), f"ref-{ref.name}")
            pb.resetBasePositionAndOrientation(
                body, [ref.x, ref.y, s.bench_top_z + _LIFT_CODE], [0, 0, 0, 1],
                physicsClientId=self._client,
            )
        for part in s.parts:
            box = self._solid(part)
            code = None
            if part.payload:
                code = self._code_body(part.payload, f"part-{part.part_id}")[0]
            self._bodies[part.part_id] = (box, code)
            self._parts[part.part_id] = part
            self._place(part)

    def _place(self, part: SimPart) -> None:
        box, code = self._bodies[part.part_id]
        quat = pb.getQuaternionFromEuler([0, 0, part.yaw])
        pb.resetBasePositionAndOrientation(box, list(part.position), quat,
                                           physicsClientId=self._client)
        if code is not None:
            x, y, z = part.position
            c, s = math.cos(part.yaw), math.sin(part.yaw)
            dx, dy = part.code_offset
            x, y = x + c * dx - s * dy, y + s * dx + c * dy
            pb.resetBasePositionAndOrientation(
                code, [x, y, z + part.size[2] / 2 + _LIFT_CODE], quat,
                physicsClientId=self._client,
            )
        if part.part_id in self._covers:
            self._place_cover(part)

    def _place_cover(self, part: SimPart) -> None:
        x, y, z = part.position
        x, y = x + part.code_offset[0], y + part.code_offset[1]
        pb.resetBasePositionAndOrientation(
            self._covers[part.part_id], [x, y, z + part.size[2] / 2 + 0.08], [0, 0, 0, 1],
            physicsClientId=self._client,
        )

    def reshape(self, part_id: str, profile: str) -> None:
        """Give a part another outline (the simulated world decides what an unknown
        part really is), where it stands now."""
        old = self._parts[part_id]
        if old.profile == profile:
            return
        new = replace(old, profile=profile)
        box, code = self._bodies[part_id]
        pb.removeBody(box, physicsClientId=self._client)
        self._bodies[part_id] = (self._solid(new), code)
        self._parts[part_id] = new
        self._place(new)

    def part(self, part_id: str) -> SimPart:
        return self._parts[part_id]

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None:
        """Put a part's box centre at `position` (bench frame), e.g. into a hand."""
        old = self._parts[part_id]
        new = replace(old, position=position, yaw=old.yaw if yaw is None else yaw)
        self._parts[part_id] = new
        self._place(new)

    def cover(self, part_id: str, covered: bool = True) -> None:
        """Hide a part's code under a board (a hand, another part) or uncover it."""
        if covered and part_id not in self._covers:
            side = self.scene.marker_size_m * 2.2
            self._covers[part_id] = self._box((side, side, 0.01), (0.2, 0.25, 0.3, 1.0))
            self._place_cover(self._parts[part_id])
        elif not covered and part_id in self._covers:
            pb.removeBody(self._covers.pop(part_id), physicsClientId=self._client)

    # --- the camera --------------------------------------------------------------
    @property
    def size(self) -> tuple[int, int]:
        return self._size

    @property
    def fps(self) -> float:
        return self._fps

    @property
    def intrinsics(self) -> CameraIntrinsics:
        """Exactly the renderer's projection (no distortion)."""
        return CameraIntrinsics.from_fov(self._size[0], self._size[1], self._hfov)

    def _jittered(self) -> CameraPlacement:
        j = self.degradation.jitter_m
        if j <= 0:
            return self.placement
        eye = np.array(self.placement.eye) + self._rng.normal(0, j, 3)
        target = np.array(self.placement.target) + self._rng.normal(0, j * 3, 3)
        return CameraPlacement(
            (float(eye[0]), float(eye[1]), float(eye[2])),
            (float(target[0]), float(target[1]), float(target[2])),
            self.placement.up,
        )

    def render(self, placement: CameraPlacement | None = None) -> Image:
        """One clean frame from `placement` (default: the camera's own), BGR."""
        placement = placement or self.placement
        w, h = self._size
        vfov = math.degrees(2 * math.atan(math.tan(math.radians(self._hfov) / 2) * h / w))
        view = pb.computeViewMatrix(placement.eye, placement.target, placement.up)
        projection = pb.computeProjectionMatrixFOV(vfov, w / h, 0.05, 10.0)
        light = np.array(self.scene.light_direction, dtype=np.float64)
        if self.degradation.light_jitter > 0:
            light = light + self._rng.normal(0, self.degradation.light_jitter, 3)
        _, _, rgba, _, _ = pb.getCameraImage(
            w, h, view, projection, lightDirection=light.tolist(), shadow=0,
            renderer=pb.ER_TINY_RENDERER, physicsClientId=self._client,
        )
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)[:, :, :3]
        return np.ascontiguousarray(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))

    def _degrade(self, image: Image) -> Image:
        d = self.degradation
        out: npt.NDArray[np.float32] = image.astype(np.float32)
        if d.blur_px > 0:
            sigma = float(self._rng.uniform(0, d.blur_px))
            if sigma > 0.05:
                out = np.asarray(cv2.GaussianBlur(out, (0, 0), sigma), dtype=np.float32)
        if d.gain != (1.0, 1.0):
            out *= float(self._rng.uniform(*d.gain))
        if d.noise > 0:
            out += self._rng.normal(0, d.noise, out.shape).astype(np.float32)
        return np.clip(out, 0, 255).astype(np.uint8)

    def read(self) -> Frame:
        placement = self._jittered()
        self.last_pose = placement.pose()
        image = self._degrade(self.render(placement))
        frame = Frame(image, self._index / self._fps, self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        if self._client >= 0 and pb.isConnected(self._client):
            pb.disconnect(self._client)
        self._client = -1
        shutil.rmtree(self._dir, ignore_errors=True)

    def __enter__(self) -> SimulatedCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def write_video(frames: Iterable[Frame], path: str | Path, fps: float = 30.0) -> int:
    """Write frames to a video file (lossless FFV1 in .avi/.mkv, else mp4v); returns
    how many were written. Lossless keeps a replay decoding like the live frames."""
    path = Path(path)
    writer: cv2.VideoWriter | None = None
    count = 0
    try:
        for frame in frames:
            if writer is None:
                h, w = frame.image.shape[:2]
                codec = "FFV1" if path.suffix.lower() in (".avi", ".mkv") else "mp4v"
                fourcc = cv2.VideoWriter.fourcc(*codec)
                writer = cv2.VideoWriter(str(path), fourcc, fps, (w, h))
                if not writer.isOpened():
                    raise OSError(f"cannot write video {path} with codec {codec}")
            writer.write(frame.image)
            count += 1
    finally:
        if writer is not None:
            writer.release()
    return count

