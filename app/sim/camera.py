"""The simulated camera as a live frame source: renders only when the bench changed.

Its frames go where a real camera's do (a `LiveCamera`, or a headless camera
source's feed); its scene is the one the simulated world moves (`PartMover`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from perception.frames import Frame, Image

if TYPE_CHECKING:  # the camera's owner creates it; importing pybullet is its cost
    from perception.sim import SimulatedCamera

Vec3 = tuple[float, float, float]


class StillSimulatedCamera:
    """A clean `SimulatedCamera` that renders only when the world has changed.

    Without degradation the renderer draws the same image for the same world, so
    frames between moves repeat the last render (a new index and time each):
    the chain still decodes every frame, at a fraction of the rendering time.
    """

    def __init__(self, camera: SimulatedCamera) -> None:
        self.camera = camera
        self._image: Image | None = None
        self._index = 0
        self.renders = 0

    @property
    def size(self) -> tuple[int, int]:
        return self.camera.size

    @property
    def fps(self) -> float:
        return self.camera.fps

    def move(self, part_id: str, position: Vec3, yaw: float | None = None) -> None:
        self.camera.move(part_id, position, yaw)
        self._image = None

    def reshape(self, part_id: str, profile: str) -> None:
        self.camera.reshape(part_id, profile)
        self._image = None

    def read(self) -> Frame:
        if self._image is None:
            self._image = self.camera.render()
            self.renders += 1
        frame = Frame(self._image.copy(), self._index / self.fps, self._index)
        self._index += 1
        return frame

    def close(self) -> None:
        self.camera.close()
