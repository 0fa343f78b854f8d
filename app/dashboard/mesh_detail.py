"""Fewer triangles for the robot and the human as the browser draws them.

Baxter's Collada meshes have ~410,000 triangles and the human's ~110,000. A
browser without a GPU draws them in software, about half a second a frame on two
cores, and the page's clicks wait behind the frames. At a tenth of the triangles
the shapes and colours stay recognisable and a frame is several times cheaper.
Only the drawing changes: the motion planner's collision models are its own.
"""

from __future__ import annotations

import hashlib

import fast_simplification
import numpy as np
import trimesh
import yourdfpy

DEFAULT_DETAIL = 0.1  # the share of each large mesh's triangles that is drawn
SMALL_MESH = 1000  # triangles: no mesh is cut below this (small ones lose their shape)


def _colour(mesh: trimesh.Trimesh) -> np.ndarray:
    """The mesh's one colour (RGBA, 0-255): its material's or its main colour."""
    visual = mesh.visual
    if isinstance(visual, trimesh.visual.TextureVisuals) and visual.material is not None:
        return np.asarray(visual.material.main_color, dtype=np.uint8)
    if isinstance(visual, trimesh.visual.ColorVisuals):
        return np.asarray(visual.main_color, dtype=np.uint8)
    return np.array([128, 128, 128, 255], dtype=np.uint8)  # no colour given: grey


def _simplified(
    corners: np.ndarray, triangles: np.ndarray, keep: int
) -> tuple[np.ndarray, np.ndarray]:
    """About `keep` triangles of the surface, by quadric decimation."""
    # Collada gives each triangle its own corners; joined at shared corners the
    # surface can lose triangles without tearing apart.
    joined = trimesh.Trimesh(corners, triangles, process=True)
    # The simplifier wants plain C arrays of these exact types.
    vertices, faces = fast_simplification.simplify(
        np.array(joined.vertices, dtype=np.float64),
        np.array(joined.faces, dtype=np.int64),
        target_count=keep,
    )
    return vertices, faces


def reduce_detail(urdf: yourdfpy.URDF, detail: float = DEFAULT_DETAIL) -> int:
    """Replace each visual mesh of `urdf` with one of `detail` of its triangles but
    at least SMALL_MESH (quadric decimation), in its own colour; returns the
    triangles drawn in all.

    `detail` 1 keeps the meshes as they are."""
    if not 0.0 < detail <= 1.0:
        raise ValueError(f"mesh detail must be in (0, 1], not {detail}")
    scene = urdf.scene
    if scene is None:
        return 0
    # The left and right arms load the same files: each shape is reduced once
    # (Baxter: 150,000 of its 410,000 triangles are such copies).
    reduced: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, mesh in list(scene.geometry.items()):
        if not isinstance(mesh, trimesh.Trimesh):
            continue
        keep = max(SMALL_MESH, round(detail * len(mesh.faces)))
        if keep >= len(mesh.faces):
            continue
        corners = np.array(mesh.vertices, dtype=np.float64)
        triangles = np.array(mesh.faces, dtype=np.int64)
        shape = hashlib.blake2b(corners.tobytes() + triangles.tobytes()).hexdigest()
        if shape not in reduced:
            reduced[shape] = _simplified(corners, triangles, keep)
        vertices, faces = reduced[shape]
        colour = _colour(mesh)
        fewer = trimesh.Trimesh(vertices, faces, process=False)
        fewer.visual = trimesh.visual.ColorVisuals(
            fewer, face_colors=np.tile(colour, (len(faces), 1))
        )
        scene.geometry[name] = fewer
    return sum(len(m.faces) for m in scene.geometry.values() if isinstance(m, trimesh.Trimesh))
