"""Baxter's arms by name: joints and the home pose, without loading the physics.

Plain data, so the dashboard's world model, the audit and the plan motions
read them without importing pybullet or OMPL.
"""

from __future__ import annotations

ARMS = ("left", "right")
JOINT_SUFFIXES = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
# A common "untucked" Baxter pose: forearms down in front of the body, clear of the
# bench and of each other, so every query starts from a collision-free configuration.
HOME = {
    "left": [0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0],
    "right": [0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0],
}


def joint_names(arm: str) -> list[str]:
    """The arm's seven joints as the URDF names them (`left_s0`, ...)."""
    return [f"{arm}_{s}" for s in JOINT_SUFFIXES]
