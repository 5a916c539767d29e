"""The tracking window's reachable image regions: every pixel a model in the window can
cover at any pose the tracking search scores lies in them, they lie inside the boxes of
the 64 points (a box of the model's radius in x-y and its reach in depth around each
window corner), and the hull around the model's disk cuts those boxes' corners."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_app.geometry import make_transform, rotation_from_rpy
from robot_app.vision.camera import PinholeCamera, StereoRig
from robot_app.vision.cloth_model import ClothModel
from robot_app.vision.ga import LEVELS, GASettings, GeneticAlgorithm, SearchBoundsSettings, encode
from robot_app.vision.recognizer import RecognitionSettings, Recognizer
from robot_app.vision.tracking_window import off_plane, reach_in_depth, reachable_regions, search_tilt_sine

CAMERA = PinholeCamera.from_fov((320, 240), np.deg2rad(48))
RIG = StereoRig(CAMERA, CAMERA, make_transform(np.eye(3), [-0.1, 0.0, 0.0]))


def _model(rng: np.random.Generator, relief: float = 0.0) -> ClothModel:
    """A square model, flat (z = 0) or with points up to `relief` off its plane [m]."""
    inside = np.column_stack([rng.uniform(-0.06, 0.06, (80, 2)), rng.uniform(-relief, relief, 80)])
    outside = np.column_stack([rng.uniform(-0.09, 0.09, (40, 2)), rng.uniform(-relief, relief, 40)])
    return ClothModel("m", inside, np.full(80, 20, np.uint16), outside, 85.0, np.zeros(3), (0.12, 0.12))


def _window(rng: np.random.Generator) -> SearchBoundsSettings:
    x, y, z = rng.uniform(-0.2, 0.2), rng.uniform(-0.15, 0.15), rng.uniform(0.03, 0.7)
    half, depth = rng.uniform(0.005, 0.04), rng.uniform(0.005, 0.05)
    z_range = (max(z - depth, 1e-3), z + depth)
    tilt = float(rng.choice([5.0, 10.0, 20.0, 35.0, 60.0, 90.0]))
    return SearchBoundsSettings(x=(x - half, x + half), y=(y - half, y + half), z=z_range, max_tilt_deg=tilt)


def _search_poses(window: SearchBoundsSettings, rng: np.random.Generator, count: int) -> np.ndarray:
    """Poses the tracking GA can score in `window`: random genes, half of them with the
    tilt genes at their extremes (the largest tilt, on the diagonals), decoded as the GA does."""
    ranges = window.gene_ranges()
    parameters = rng.uniform(ranges[:, 0], ranges[:, 1], (count, 6))
    corners = rng.choice([0, 1], (count // 2, 2))
    parameters[: count // 2, 3:5] = ranges[3:5, 0] + corners * (ranges[3:5, 1] - ranges[3:5, 0])
    genes = encode(parameters, window)
    genes[0, 3:5] = 0  # both tilt genes at their lowest level ...
    genes[1, 3:5] = LEVELS ^ (LEVELS >> 1)  # ... and highest (Gray-coded)
    return GeneticAlgorithm(window, GASettings(population=count, islands=1, elite=2), rng).transforms(genes)


def _boxes_of_64_points(
    window: SearchBoundsSettings, model: ClothModel, rig: StereoRig
) -> list[npt.NDArray[np.int64]]:
    """The projection as numpy: a box of the model's radius in x-y and its reach in depth
    around each of the window's 8 corners."""
    radius = float(np.max(np.linalg.norm(np.vstack([model.points_in, model.points_out]), axis=1)))
    depth = reach_in_depth(radius, off_plane(model), search_tilt_sine(window.max_tilt_deg))
    corners = np.array(np.meshgrid(window.x, window.y, window.z, indexing="ij")).reshape(3, -1).T
    cube = (
        np.array(np.meshgrid((-radius, radius), (-radius, radius), (-depth, depth), indexing="ij"))
        .reshape(3, -1)
        .T
    )
    points = (corners[:, None, :] + cube[None, :, :]).reshape(-1, 3)
    width, height = rig.image_size
    boxes = []
    for camera, to_camera in ((rig.left, rig.transform_right_to_left), (rig.right, np.eye(4))):
        X = points @ to_camera[:3, :3].T + to_camera[:3, 3]
        if np.any(X[:, 2] <= 1e-3):
            boxes.append(np.array([0, 0, width - 1, height - 1], dtype=np.int64))
            continue
        uv = X[:, :2] / X[:, 2:] @ camera.camera_matrix[:2, :2].T + camera.camera_matrix[:2, 2]
        box = np.array([uv[:, 0].min() - 3, uv[:, 1].min() - 3, uv[:, 0].max() + 4, uv[:, 1].max() + 4])
        boxes.append(np.clip(np.floor(box), 0, [width - 1, height - 1] * 2).astype(np.int64))
    return boxes


def _outside(points: np.ndarray, poses: np.ndarray, regions: tuple[np.ndarray, np.ndarray]) -> int:
    """How many of the points, at the poses, land in an image where a pixel the kernels
    read for them (the nearest, or the four around for the bilinear score) is outside its
    region's row spans."""
    width, height = RIG.image_size
    count = 0
    for pose in poses:
        in_right = points @ pose[:3, :3].T + pose[:3, 3]
        for camera, to_camera, spans in (
            (RIG.left, RIG.transform_right_to_left, regions[0]),
            (RIG.right, np.eye(4), regions[1]),
        ):
            X = in_right @ to_camera[:3, :3].T + to_camera[:3, 3]
            X = X[X[:, 2] > 1e-3]
            uv = X[:, :2] / X[:, 2:] @ camera.camera_matrix[:2, :2].T + camera.camera_matrix[:2, 2]
            seen = (uv[:, 0] >= 0) & (uv[:, 0] <= width - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= height - 1)
            u, v = np.floor(uv[seen]).astype(int).T
            for du in (0, 1):
                for dv in (0, 1):
                    pu, pv = u + du, v + dv
                    on = (pu <= width - 1) & (pv <= height - 1)
                    pu, pv = pu[on], pv[on]
                    count += int(np.sum((pu < spans[pv, 0]) | (pu > spans[pv, 1])))
    return count


def _box_pixels(spans: np.ndarray) -> int:
    return int(np.maximum(spans[:, 1] - spans[:, 0] + 1, 0).sum())


def test_the_model_in_the_window_stays_in_the_regions_at_any_pose_the_search_scores() -> None:
    """Any yaw, the GA's largest tilts (its diagonals, ~1.4x max_tilt), flat and raised models."""
    rng = np.random.default_rng(3)
    width, height = RIG.image_size
    whole = 0
    for trial in range(80):
        model, window = _model(rng, relief=0.0 if trial % 2 else 0.01), _window(rng)
        regions = reachable_regions(window, model, RIG)
        whole += all(_box_pixels(spans) == width * height for spans in regions)
        points = np.vstack([model.points_in, model.points_out])
        assert _outside(points, _search_poses(window, rng, 24), regions) == 0
    assert 0 < whole < 80  # some windows so close that a camera could see a model from behind


def test_the_depth_reach_is_that_of_the_largest_tilt_the_search_gives() -> None:
    """A flat model at the GA's largest tilt reaches `reach_in_depth` in depth (to 5 %) and
    never more; the reach is below the radius (fewer pixels to code), the radius at 90°."""
    rng = np.random.default_rng(6)
    model = _model(rng)
    window = SearchBoundsSettings(x=(-0.01, 0.01), y=(-0.01, 0.01), z=(0.6, 0.62), max_tilt_deg=20.0)
    poses = _search_poses(window, rng, 400)
    points = np.vstack([model.points_in, model.points_out])
    depths = np.abs(np.einsum("pj,nj->pn", poses[:, 2, :3], points))
    reach = reach_in_depth(model.radius, off_plane(model), search_tilt_sine(20.0))
    assert depths.max() <= reach + 1e-12 and depths.max() > 0.95 * reach
    assert reach < 0.5 * model.radius
    assert reach_in_depth(model.radius, 0.0, search_tilt_sine(90.0)) == model.radius
    assert reach_in_depth(model.radius, 0.01, 0.1) == 0.1 * model.radius + 0.01


def test_the_regions_lie_in_the_boxes_of_all_64_points() -> None:
    """Each row's span lies inside the box of the 64 points (a box of the model's radius in
    x-y and its reach in depth around each window corner: the region before the hull)."""
    rng = np.random.default_rng(4)
    for _ in range(300):
        model, window = _model(rng), _window(rng)
        regions = reachable_regions(window, model, RIG)
        for spans, box in zip(regions, _boxes_of_64_points(window, model, RIG), strict=True):
            rows = np.flatnonzero(spans[:, 1] >= spans[:, 0])
            assert rows.size == 0 or (rows.min() >= box[1] and rows.max() <= box[3])
            assert np.all(spans[rows, 0] >= box[0]) and np.all(spans[rows, 1] <= box[2])


def test_the_hull_around_the_models_disk_cuts_the_boxes_corners() -> None:
    """A tracking window as the bench's (±20 mm, ±30 mm in depth, 20° tilt, 0.58 m away, in
    the middle of the right image): its spans code about an eighth fewer pixels than the box
    (13.5 % for the bench's tracking cloth at 640 x 480)."""
    model = _model(np.random.default_rng(8))
    window = SearchBoundsSettings(x=(-0.02, 0.02), y=(-0.02, 0.02), z=(0.55, 0.61), max_tilt_deg=20.0)
    spans = reachable_regions(window, model, RIG)[1]
    box = _boxes_of_64_points(window, model, RIG)[1]
    assert box[0] > 0 and box[1] > 0 and box[2] < RIG.image_size[0] - 1 and box[3] < RIG.image_size[1] - 1
    assert 0.8 < _box_pixels(spans) / ((box[2] - box[0] + 1) * (box[3] - box[1] + 1)) < 0.9


def test_the_model_radius_is_its_farthest_point() -> None:
    model = _model(np.random.default_rng(5))
    distances = np.linalg.norm(np.vstack([model.points_in, model.points_out]), axis=1)
    assert model.radius == distances.max() and model.radius == model.radius  # cached: the same value


def test_the_regions_also_cover_the_moved_best_pose_at_its_own_tilt() -> None:
    """The moved best pose is scored unclipped when no GA pose is in the yaw window
    (`Proposer.track`): a camera motion that tilts it past the search's tilt widens the
    regions enough to hold it, and a pose within the search's tilt leaves them as they were."""
    rng = np.random.default_rng(7)
    model = _model(rng)
    settings = RecognitionSettings()
    recognizer = Recognizer(model, RIG, settings)
    proposer = recognizer.proposer
    flat = make_transform(np.eye(3), [0.01, -0.01, 0.45])
    proposer.keep(flat, np.repeat(flat[None], 3, axis=0))
    plain = proposer.tracking_regions(None)
    window = proposer.tracking_window(None)
    assert all(
        np.array_equal(a, b) for a, b in zip(plain, reachable_regions(window, model, RIG), strict=True)
    )
    steep = make_transform(rotation_from_rpy(np.deg2rad(75.0), 0.0, 0.0), [0.01, -0.01, 0.45])
    proposer.keep(steep, np.repeat(steep[None], 3, axis=0))
    regions = proposer.tracking_regions(None)
    points = np.vstack([model.points_in, model.points_out])
    assert _outside(points, steep[None], regions) == 0
    assert any(np.any(a != b) for a, b in zip(regions, plain, strict=True))  # wider than the search's own
