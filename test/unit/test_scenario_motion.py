"""Trajectory and ramp maths of the scenario actions (pure, no ROS)."""
import math

import numpy as np
import pytest

from testing_instance.scenario import motion


def test_path_at_constant_speed_ends_on_the_last_waypoint():
    pts = motion.path_points([0, 0, 1], [[1, 0, 1], [1, 2, 1]], speed=0.5, interval=0.1)
    t_end, p_end, v_end = pts[-1]
    assert t_end == pytest.approx(6.0)            # 3 m at 0.5 m/s
    assert np.allclose(p_end, [1, 2, 1]) and not np.any(v_end)
    t, p, v = pts[9]                               # t = 1.0 s: 0.5 m along x
    assert t == pytest.approx(1.0) and np.allclose(p, [0.5, 0, 1]) and np.allclose(v, [0.5, 0, 0])
    t, p, v = pts[29]                              # t = 3.0 s: 1.5 m: past the corner
    assert np.allclose(p, [1, 0.5, 1]) and np.allclose(v, [0, 0.5, 0])
    steps = np.diff([x[0] for x in pts])
    assert np.allclose(steps, 0.1)


def test_walk_bounces_at_the_step_frequency_and_faces_the_walk():
    pts = motion.walk_points([0, 0, 1.2], [[4, 0, 1.2]], speed=1.0, step_frequency=2.0,
                             bounce=0.03, interval=0.01)
    z = np.array([p[2] for _t, p, _v, _y in pts[:-1]])
    assert z.min() >= 1.2 - 1e-9 and z.max() == pytest.approx(1.23, abs=1e-3)
    # |sin(pi f t)| peaks f times per second: 2 steps/s over 4 s = 8 peaks
    peaks = np.sum((z[1:-1] > z[:-2]) & (z[1:-1] > z[2:]))
    assert peaks == 8
    assert all(y == pytest.approx(0.0) for _t, _p, _v, y in pts[:-1])
    assert pts[-1][1][2] == pytest.approx(1.2)


def test_rotate_slerps_to_the_target():
    q0 = motion.quat_from_rpy(0, 0, 0)
    pts = motion.rotate_points(q0, [0, 0, math.pi / 2], 1.0, interval=0.25)
    assert [t for t, _q in pts] == pytest.approx([0.25, 0.5, 0.75, 1.0])
    assert motion.rpy_from_quat(pts[1][1])[2] == pytest.approx(math.pi / 4)
    assert motion.rpy_from_quat(pts[-1][1])[2] == pytest.approx(math.pi / 2)
    assert np.allclose(motion.rpy_from_quat(motion.quat_from_rpy(0.1, -0.2, 0.3)),
                       [0.1, -0.2, 0.3])


def test_ramp_and_series():
    pts = motion.ramp_points({'temperature': 20.0}, {'temperature': 30.0}, 2.0, interval=0.5)
    assert [t for t, _v in pts] == pytest.approx([0.5, 1.0, 1.5, 2.0])
    assert [v['temperature'] for _t, v in pts] == pytest.approx([22.5, 25, 27.5, 30])
    assert motion.ramp_points({}, {'humidity': 40}, 0) == [(0.0, {'humidity': 40})]
    assert motion.series_points([[2, 1], [0, 5]]) == [(0.0, 5.0), (2.0, 1.0)]
