"""What a fabric cloth looks like in the renderer: a fine two-sided mesh with wrinkles.

pybullet's mass-spring cloth cannot hold wrinkles: gravity presses them flat within a
tenth of a second (measured: 4-12 mm ridges settle to 0.1 mm RMS for table friction up
to 5 and bending stiffness up to 2.0, and to 0.4 mm with 40x stiffer springs). So the
physics mesh stays the catalogue mesh, and a finer *render* mesh carries the wrinkles:
pybullet skins it to the physics mesh (each render vertex keeps its barycentric place
and its height above the nearest physics triangle), so the wrinkles move with the cloth.

The render mesh has two layers 1 mm apart: the front (texture's left half) on the face
side and the back side (right half, darker and duller) below it, so whichever side faces
the camera shows its own look. Wrinkles are ridges of a few mm to ~1 cm; the fabric they
take up is gathered in from the flat cloth (edge lengths kept), so prints are pulled
together at the folds and the outline shrinks a little, as on a real crumpled cloth. The
gathering is aligned back to the flat cloth (no net shift or turn), so the ground truth,
the Kabsch fit of the physics nodes, is also that of the visible cloth.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robot_app.arrays import FloatArray
from robot_app.sim.cloth_mesh import ClothMesh, build_cloth_mesh

LAYER_GAP = 0.001  # between the front and back render layers [m]
FLAP_LIFT = 0.0025  # a folded flap's render layers above the cloth under it [m]
GATHER_ITERATIONS = 120


@dataclass(frozen=True)
class Ridge:
    """One wrinkle: a ridge of Gaussian cross-section along a line, tapering at its ends.

    Attributes:
        centre: (x, y) of its middle in Σ_M [m].
        angle: direction of the ridge line in Σ_M [rad].
        height: [m].
        width: standard deviation of the cross-section [m].
        length: standard deviation along the line [m].
    """

    centre: tuple[float, float]
    angle: float
    height: float
    width: float
    length: float


@dataclass(frozen=True)
class Fold:
    """A corner folded over onto the cloth along a straight line.

    Attributes:
        angle: direction (in Σ_M) from the cloth's middle to the folded corner [rad].
        share: how far along that direction the fold line lies, as a quantile of the
            nodes' positions (0.8: the outer 20% of the nodes fold over).
    """

    angle: float
    share: float

    def along(self, points_xy: npt.ArrayLike) -> FloatArray:
        """Position of Σ_M points along the fold direction [m]."""
        direction = np.array([np.cos(self.angle), np.sin(self.angle)])
        return np.asarray(points_xy, dtype=float)[:, :2] @ direction

    def line(self, rest_vertices: FloatArray) -> float:
        """Position of the fold line along the direction [m]."""
        return float(np.quantile(self.along(rest_vertices), self.share))


@dataclass(frozen=True)
class ClothLook:
    """How one laid cloth deviates from flat: its wrinkles and an optional folded corner."""

    ridges: tuple[Ridge, ...] = ()
    fold: Fold | None = None

    @classmethod
    def draw(
        cls, rng: np.random.Generator, size: tuple[float, float], amplitude: float, fold_probability: float
    ) -> ClothLook:
        """Random wrinkles (2-4 ridges, heights 35-100% of `amplitude` [m]) and maybe a fold."""
        ridges: list[Ridge] = []
        if amplitude > 0:
            half = np.asarray(size) / 2
            for _ in range(int(rng.integers(2, 5))):
                centre = rng.uniform(-0.7 * half, 0.7 * half)
                ridges.append(
                    Ridge(
                        (float(centre[0]), float(centre[1])),
                        float(rng.uniform(0, np.pi)),
                        float(amplitude * rng.uniform(0.35, 1.0)),
                        float(rng.uniform(0.008, 0.016)),
                        float(rng.uniform(0.03, 0.08)),
                    )
                )
        fold = None
        if fold_probability > 0 and float(rng.random()) < fold_probability:
            fold = Fold(float(rng.uniform(-np.pi, np.pi)), float(rng.uniform(0.75, 0.88)))
        return cls(tuple(ridges), fold)

    def heights(self, points_xy: npt.ArrayLike, rest_vertices: FloatArray) -> FloatArray:
        """(N,) wrinkle height [m] of Σ_M points; none near a fold (the layers would cross)."""
        P = np.asarray(points_xy, dtype=float)[:, :2]
        h = np.zeros(len(P))
        for r in self.ridges:
            d = P - np.asarray(r.centre)
            along = d @ np.array([np.cos(r.angle), np.sin(r.angle)])
            across = d @ np.array([-np.sin(r.angle), np.cos(r.angle)])
            h += r.height * np.exp(-0.5 * (across / r.width) ** 2 - 0.5 * (along / r.length) ** 2)
        if self.fold is not None:  # flat where the flap lies and where it comes from
            s = self.fold.along(P)
            line = self.fold.line(rest_vertices)
            covered_from = 2 * line - float(self.fold.along(rest_vertices).max()) - 0.01
            h *= np.clip((covered_from - s) / 0.02, 0.0, 1.0)
        return np.minimum(h, 1.5 * max((r.height for r in self.ridges), default=0.0))


@dataclass(frozen=True)
class RenderMesh:
    """The two-layer render mesh in Σ_M (z into the table, so the face side is -z).

    Attributes:
        vertices: (2N, 3) front layer then back layer [m].
        uvs: (2N, 2) texture coordinates in the front|back atlas.
        triangles: (2T, 3) vertex indices (back layer wound the other way).
    """

    vertices: FloatArray
    uvs: FloatArray
    triangles: npt.NDArray[np.int64]

    def write_obj(self, path: str | Path) -> Path:
        """Writes a Wavefront .obj with `vt` texture coordinates."""
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in self.vertices]
        lines += [f"vt {u:.6f} {v:.6f}" for u, v in self.uvs]
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in self.triangles + 1]
        file = Path(path)
        file.write_text("\n".join(lines) + "\n")
        return file

    def digest(self) -> str:
        data = self.vertices.tobytes() + self.uvs.tobytes() + self.triangles.tobytes()
        return hashlib.sha1(data).hexdigest()[:12]


def build_render_mesh(physics_mesh: ClothMesh, spacing: float, look: ClothLook | None = None) -> RenderMesh:
    """The cloth's render mesh `spacing` [m] fine, wrinkled as `look` says (flat without)."""
    fine = build_cloth_mesh(physics_mesh.spec, spacing, 0.8 * spacing)
    flat = fine.vertices.copy()
    heights = np.zeros(len(flat)) if look is None else look.heights(flat, physics_mesh.vertices)
    points = flat.copy()
    if np.any(heights > 0):
        points = _gather(flat, heights, fine.edges, fine.rest_edge_lengths)
    points[:, 2] = -heights
    if look is not None and look.fold is not None:
        # pybullet's cloth does not collide with itself: the folded flap's nodes come to
        # lie in the layer below. Its render layers sit FLAP_LIFT on the side that will
        # face up once folded, so the flap is drawn over the cloth it covers.
        flap = look.fold.along(flat) > look.fold.line(physics_mesh.vertices)
        points[flap, 2] += FLAP_LIFT
    half_gap = np.array([0.0, 0.0, LAYER_GAP / 2])
    front, back = points - half_gap, points + half_gap
    n = len(flat)
    uvs = np.vstack([fine.uvs * [0.5, 1.0], fine.uvs * [0.5, 1.0] + [0.5, 0.0]])
    triangles = np.vstack([fine.triangles, fine.triangles[:, ::-1] + n])
    return RenderMesh(np.vstack([front, back]), uvs, triangles)


def render_obj_path(mesh: RenderMesh, folder: str | Path, keep: bool) -> Path:
    """Writes the render mesh into `folder`; a kept file is named by its content and reused.

    Wrinkled meshes differ in every scene: they are written under a unique name for the
    caller to delete once pybullet has loaded them (`keep=False`).
    """
    folder = Path(folder)
    if keep:
        path = folder / f"render_{mesh.digest()}.obj"
        if not path.is_file():
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            mesh.write_obj(tmp)
            tmp.replace(path)
        return path
    path = folder / f"render_{os.getpid()}_{np.random.default_rng().integers(1 << 40):x}.obj"
    return mesh.write_obj(path)


def _gather(
    flat: FloatArray, heights: FloatArray, edges: npt.NDArray[np.int64], rest: FloatArray
) -> FloatArray:
    """Moves the flat points in the plane so that, lifted by `heights`, edges keep their length.

    Position-based projection of the edge lengths with z held at the heights, then the
    rigid 2D fit of the result to the flat points is undone.
    """
    P = flat.copy()
    P[:, 2] = heights
    a, b = edges[:, 0], edges[:, 1]
    count = np.bincount(np.concatenate([a, b]), minlength=len(P)).astype(float)[:, None]
    for _ in range(GATHER_ITERATIONS):
        d = P[b] - P[a]
        length = np.linalg.norm(d, axis=1)
        correction = ((length - rest) / np.maximum(length, 1e-12))[:, None] * d * 0.5
        delta = np.zeros_like(P)
        np.add.at(delta, a, correction)
        np.add.at(delta, b, -correction)
        P[:, :2] += delta[:, :2] / count
    # undo the net shift and turn: the visible cloth keeps the flat cloth's pose
    src, dst = P[:, :2] - P[:, :2].mean(axis=0), flat[:, :2] - flat[:, :2].mean(axis=0)
    u, _, vt = np.linalg.svd(src.T @ dst)
    R = (u @ vt).T
    if np.linalg.det(R) < 0:
        vt[-1] *= -1
        R = (u @ vt).T
    P[:, :2] = src @ R.T + flat[:, :2].mean(axis=0)
    return P


__all__ = [
    "FLAP_LIFT",
    "LAYER_GAP",
    "ClothLook",
    "Fold",
    "RenderMesh",
    "Ridge",
    "build_render_mesh",
    "render_obj_path",
]
