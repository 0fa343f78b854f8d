"""The robot and the human as the browser draws them: a tenth of the triangles,
the same places, the same colours."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
import yourdfpy

from app.dashboard.mesh_detail import SMALL_MESH, reduce_detail
from planner.feasibility.robot import baxter_urdf, human_urdf


def meshes(urdf: yourdfpy.URDF) -> dict[str, trimesh.Trimesh]:
    assert urdf.scene is not None
    return {k: m for k, m in urdf.scene.geometry.items() if isinstance(m, trimesh.Trimesh)}


@pytest.mark.parametrize("path", [baxter_urdf, human_urdf], ids=["baxter", "human"])
def test_a_tenth_of_the_triangles_in_the_same_place_and_colour(path: object) -> None:
    full = yourdfpy.URDF.load(str(path()))  # type: ignore[operator]
    light = yourdfpy.URDF.load(str(path()))  # type: ignore[operator]
    before = meshes(full)
    drawn = reduce_detail(light, 0.1)
    after = meshes(light)
    assert after.keys() == before.keys()
    total = sum(len(m.faces) for m in before.values())
    assert drawn == sum(len(m.faces) for m in after.values())
    assert total > 100_000 and drawn < 0.25 * total, (total, drawn)
    for name, mesh in before.items():
        fewer = after[name]
        if len(mesh.faces) <= SMALL_MESH:
            # Small meshes are drawn as they are.
            assert np.array_equal(fewer.faces, mesh.faces), name
            assert np.array_equal(fewer.vertices, mesh.vertices), name
            continue
        assert len(fewer.faces) < len(mesh.faces), name
        # The same place and size: no side of the bounding box moves by 1 cm.
        assert np.abs(fewer.bounds - mesh.bounds).max() < 0.01, name
        colours = np.unique(fewer.visual.face_colors, axis=0)
        assert len(colours) == 1, name
        visual = mesh.visual
        expected = (
            visual.material.main_color
            if isinstance(visual, trimesh.visual.TextureVisuals)
            else visual.main_color
        )
        assert tuple(colours[0]) == tuple(expected), name


def test_detail_one_keeps_the_meshes_and_bad_detail_is_refused() -> None:
    urdf = yourdfpy.URDF.load(str(human_urdf()))
    before = meshes(urdf)
    assert reduce_detail(urdf, 1.0) == sum(len(m.faces) for m in before.values())
    assert all(meshes(urdf)[k] is m for k, m in before.items())
    for bad in (0.0, -0.5, 1.5):
        with pytest.raises(ValueError, match="mesh detail"):
            reduce_detail(urdf, bad)
