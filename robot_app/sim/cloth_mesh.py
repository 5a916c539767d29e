"""Triangle meshes of catalogue cloths in Σ_M, with texture coordinates, as .obj files.

The rest mesh lies in the plane z = 0 of Σ_M: origin at the area centroid of the outline
(the centroid of S_in as the photo model sees the whole cloth), x along the texture's
image x, y along its image y. Nodes are the outline resampled every `boundary_spacing`
plus a lattice of equilateral triangles of side `spacing` inside, Delaunay-triangulated
and clipped to the outline.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from matplotlib.path import Path as PolygonPath
from scipy.spatial import Delaunay

from robot_app.arrays import FloatArray
from robot_app.errors import InputError
from robot_app.sim.cloths import ClothSpec, outline_polygon, polygon_centroid

IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class ClothMesh:
    """A cloth's rest mesh.

    Attributes:
        spec: the catalogue cloth.
        vertices: (N, 3) rest nodes in Σ_M [m] (z = 0).
        uvs: (N, 2) texture coordinates (u right, v down, 0-1 over the bounding box).
        triangles: (T, 3) vertex indices.
        edges: (E, 2) unique triangle edges (the structural springs).
        outline: (K, 2) outline polygon in Σ_M x/y [m].
        offset: (2,) position of Σ_M's origin in the texture frame [m].
    """

    spec: ClothSpec
    vertices: FloatArray
    uvs: FloatArray
    triangles: IntArray
    edges: IntArray
    outline: FloatArray
    offset: FloatArray

    @property
    def rest_edge_lengths(self) -> FloatArray:
        """(E,) rest lengths of `edges` [m]."""
        a, b = self.vertices[self.edges[:, 0]], self.vertices[self.edges[:, 1]]
        return np.linalg.norm(a - b, axis=1)

    def write_obj(self, path: str | Path) -> Path:
        """Writes the mesh as a Wavefront .obj with `vt` texture coordinates."""
        lines = [f"# robot_app cloth No.{self.spec.number}: Σ_M coordinates [m]"]
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in self.vertices]
        lines += [f"vt {u:.6f} {v:.6f}" for u, v in self.uvs]
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in self.triangles + 1]
        file = Path(path)
        file.write_text("\n".join(lines) + "\n")
        return file


def build_cloth_mesh(spec: ClothSpec, spacing: float = 0.035, boundary_spacing: float = 0.03) -> ClothMesh:
    """Triangulates the cloth's outline.

    Args:
        spec: catalogue cloth.
        spacing: side of the interior lattice's triangles [m].
        boundary_spacing: outline node spacing [m].
    """
    if not (0.003 <= boundary_spacing <= spacing <= 0.1):
        raise InputError(
            f"need 0.003 <= boundary_spacing ({boundary_spacing}) <= spacing ({spacing}) <= 0.1 m"
        )
    polygon = outline_polygon(spec)
    boundary = _resample_closed(polygon, boundary_spacing)
    w, h = spec.size
    grid = _triangular_lattice(w, h, spacing)
    outline_path = PolygonPath(polygon)
    inside = outline_path.contains_points(grid)
    far = _distance_to_polyline(grid, boundary) > 0.55 * spacing
    points = np.vstack([boundary, grid[inside & far]])
    triangles = Delaunay(points).simplices.astype(np.int64)
    centroids = points[triangles].mean(axis=1)
    triangles = triangles[outline_path.contains_points(centroids)]
    used = np.unique(triangles)
    remap = -np.ones(len(points), np.int64)
    remap[used] = np.arange(len(used))
    points, triangles = points[used], remap[triangles]
    offset = polygon_centroid(polygon)
    vertices = np.column_stack([points - offset, np.zeros(len(points))])
    uvs = points / np.array([w, h])
    edges = np.unique(
        np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1),
        axis=0,
    )
    for array in (vertices, uvs, triangles, edges):
        array.setflags(write=False)
    outline = polygon - offset
    outline.setflags(write=False)
    return ClothMesh(spec, vertices, uvs, triangles, edges, outline, offset)


def cache_dir() -> Path:
    """Per-user folder for generated meshes and textures (ROBOT_APP_CACHE overrides)."""
    root = os.environ.get("ROBOT_APP_CACHE")
    if root:
        folder = Path(root)
    else:
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        folder = Path(base) / "robot_app" / "sim"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        folder = Path(tempfile.gettempdir()) / f"robot_app_sim_{os.getuid()}"
        folder.mkdir(parents=True, exist_ok=True)
    return folder


def mesh_obj_path(mesh: ClothMesh, folder: str | Path) -> Path:
    """Writes (once) the mesh .obj under `folder`, named by its content, and returns it."""
    digest = hashlib.sha1(mesh.vertices.tobytes() + mesh.triangles.tobytes() + mesh.uvs.tobytes())
    path = Path(folder) / f"cloth_{mesh.spec.number:02d}_{digest.hexdigest()[:10]}.obj"
    if not path.is_file():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        mesh.write_obj(tmp)
        tmp.replace(path)
    return path


def _triangular_lattice(width: float, height: float, spacing: float) -> FloatArray:
    """(P, 2) points of a lattice of equilateral triangles of side `spacing`, centred in the box.

    Rows run along x, every other one shifted by half a side: a cloth on this lattice folds
    along three directions, not only along the two axes of a square grid.
    """
    row = spacing * np.sqrt(3) / 2
    ys = np.arange(row / 2, height, row)
    ys += (height - ys[-1] - ys[0]) / 2
    xs = np.arange(spacing / 2, width, spacing)
    xs += (width - xs[-1] - xs[0]) / 2
    shifts = np.where(np.arange(len(ys)) % 2 == 0, -spacing / 4, spacing / 4)
    return np.concatenate(
        [np.column_stack([xs + dx, np.full(len(xs), y)]) for y, dx in zip(ys, shifts, strict=True)]
    )


def _resample_closed(polygon: FloatArray, step: float) -> FloatArray:
    points: list[FloatArray] = []
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        points.extend(a + (b - a) * t for t in np.arange(n) / n)
    return np.asarray(points)


def _distance_to_polyline(points: FloatArray, vertices: FloatArray) -> FloatArray:
    a = vertices
    b = np.roll(vertices, -1, axis=0)
    ab = b - a
    t = np.einsum("pkj,kj->pk", points[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-18)
    closest = a[None] + np.clip(t, 0, 1)[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2).min(axis=1)


__all__ = ["ClothMesh", "build_cloth_mesh", "cache_dir", "mesh_obj_path"]
