"""Pose composition (tf2/btTransform conventions) and camera_move's movement."""
import math

import numpy as np
import pytest

from simvid.camera_move import apply_movement, movement_from_axes
from sim_world.transforms import InvalidPose, Pose, quat_from_rpy, rpy_from_quat


def test_rpy_roundtrip():
    for rpy in [(0.1, -0.2, 0.3), (0, math.pi / 2 - 1e-3, 0), (-1, 0.5, 3.0)]:
        assert rpy_from_quat(quat_from_rpy(*rpy)) == pytest.approx(rpy, abs=1e-9)


def test_composition_and_inverse():
    a = Pose.from_xyz_rpy((1, 2, 3), (0.1, 0.2, 0.3))
    b = Pose.from_xyz_rpy((-1, 0.5, 2), (-0.3, 0.1, 1.0))
    ab = a * b
    assert np.allclose(ab.matrix(), a.matrix().dot(b.matrix()))
    assert (a.inverse() * a).almost_equal(Pose())
    assert ab.relative_to(a).almost_equal(b)
    p = np.array([0.3, -0.2, 1.0])
    assert (a * b).transform_point(p) == pytest.approx(a.transform_point(b.transform_point(p)))


def test_yaw_rotates_x_to_y():
    assert Pose.from_xyz_rpy((0, 0, 0), (0, 0, math.pi / 2)).rotate([1, 0, 0]) == \
        pytest.approx([0, 1, 0])


@pytest.mark.parametrize('q', [(0, 0, 0, 0), (float('nan'), 0, 0, 1), (0, 0, float('inf'), 1)])
def test_bad_quaternion_refused(q):
    with pytest.raises(InvalidPose):
        Pose((0, 0, 0), q)


def test_nan_position_refused():
    with pytest.raises(InvalidPose):
        Pose((0, float('nan'), 0))


def test_movement_is_in_the_models_own_frame():
    # the flycam is yawed by 90 degrees: its forward (+x) is the world's +y
    pose_in = Pose.from_xyz_rpy((1, 1, 1), (0, 0, math.pi / 2))
    mv = movement_from_axes([50, 0, 0, 0, 0, 0], linear_scaler=100.0)
    out = apply_movement(pose_in, mv)
    assert out.p == pytest.approx([1, 1.5, 1])
    # a yaw command turns it further about its own z
    out2 = apply_movement(out, movement_from_axes([0, 0, 0, 0, 0, 100 * math.pi / 2],
                                                  angular_scaler=100.0))
    assert out2.rotate([1, 0, 0]) == pytest.approx([-1, 0, 0], abs=1e-9)


def test_zero_joy_is_no_movement():
    assert movement_from_axes([0.0] * 6) is None
    assert movement_from_axes([]) is None


def test_bad_joy_values():
    with pytest.raises(ValueError):
        movement_from_axes([float('nan'), 0, 0])
    with pytest.raises(ValueError):
        movement_from_axes([1, 0, 0], linear_scaler=0)


def test_batched_matrices_equal_one_by_one():
    from sim_world.transforms import quat_to_matrices, quat_to_matrix
    qs = np.array([quat_from_rpy(r, p, y) for r, p, y in
                   ((0, 0, 0), (0.3, -0.2, 1.0), (math.pi, 0.1, -2.0))])
    got = quat_to_matrices(qs)
    assert got.shape == (3, 3, 3)
    for q, m in zip(qs, got):
        assert np.allclose(m, quat_to_matrix(q))
