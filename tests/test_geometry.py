import numpy as np
import pytest

from robot_app import geometry as g


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return g.matrix_from_quaternion_xyzw(q)


def test_quaternion_round_trip_and_convention() -> None:
    rng = np.random.default_rng(0)
    for _ in range(50):
        R = random_rotation(rng)
        q = g.quaternion_xyzw_from_matrix(R)
        assert q[3] >= 0
        np.testing.assert_allclose(g.matrix_from_quaternion_xyzw(q), R, atol=1e-12)
    # 90 degrees about z is (0, 0, sin45, cos45) in xyzw
    q = g.quaternion_xyzw_from_matrix(g.rotation_about_z(np.pi / 2))
    np.testing.assert_allclose(q, [0, 0, np.sqrt(0.5), np.sqrt(0.5)], atol=1e-12)


def test_invert_transform_and_is_rotation() -> None:
    rng = np.random.default_rng(1)
    T = g.make_transform(random_rotation(rng), rng.normal(size=3))
    np.testing.assert_allclose(T @ g.invert_transform(T), np.eye(4), atol=1e-12)
    assert g.is_rotation(T[:3, :3])
    assert not g.is_rotation(np.diag([1.0, 1.0, -1.0]))
    assert not g.is_rotation(2 * np.eye(3))


def test_yaw_and_wrap() -> None:
    assert g.yaw_of(g.rotation_about_z(0.7)) == pytest.approx(0.7)
    assert g.wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)
    np.testing.assert_allclose(g.wrap_angle(np.array([0.1, 2 * np.pi + 0.1])), [0.1, 0.1])


def test_kabsch_recovers_transform() -> None:
    rng = np.random.default_rng(2)
    T = g.make_transform(random_rotation(rng), rng.normal(size=3))
    P = rng.normal(size=(30, 3))
    np.testing.assert_allclose(g.kabsch(P, g.transform_points(T, P)), T, atol=1e-10)
    with pytest.raises(ValueError):
        g.kabsch(P[:2], P[:2])


def test_zero_quaternion_is_an_error() -> None:
    with pytest.raises(ValueError):
        g.matrix_from_quaternion_xyzw([0, 0, 0, 0])


def test_yaw_error_takes_the_nearest_symmetric_yaw_not_the_first() -> None:
    quarter_turns = (np.pi / 2, np.pi, 3 * np.pi / 2)
    # -90.4° from the truth is -0.4° from the 90°-symmetric shape's next copy; reducing by
    # 180° first would leave 89.6°.
    assert g.yaw_error(np.deg2rad(-90.4), quarter_turns) == pytest.approx(np.deg2rad(-0.4))
    assert g.yaw_error(np.deg2rad(179.0), (np.pi,)) == pytest.approx(np.deg2rad(-1.0))
    assert g.yaw_error(np.deg2rad(179.0)) == pytest.approx(np.deg2rad(179.0))
