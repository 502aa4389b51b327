"""The magnetometer / compass (thesis 3.3.4) on the real phone model and World, both
engines, without ROS: the field in Android's device frame follows yaw and the world's north
offset alpha; hector's parameters override the world's field; hard-iron offset and CDD
noise; both URDF syntaxes; same seed same data (bad parameters: test_sensor_contract.py)."""
import math

import numpy as np
import pytest

from sim_world.transforms import Pose

from simsensors.magnetometer import CDD_SIGMA, Magnetometer

import worlds

TOL = 6 * CDD_SIGMA
world = worlds.world_fixture(seed=2, office='environment', phone=(3, -2, 0.8), static_phone=True)


def mag(world, name='mobile_device'):
    return worlds.plugin_of(world, Magnetometer, name)


def face_up(world, yaw_deg):
    world.set_state('mobile_device', Pose.from_xyz_rpy((3, -2, 0.8), (0, 0, math.radians(yaw_deg))))
    world.step(40)
    return mag(world).last_value


def test_top_at_north_reads_along_plus_y_turned_by_declination(world):
    env = world.environment
    f, inc, dec = env.magnetic_elements()
    assert 45e-6 < f < 52e-6 and 60 < inc < 68 and 2 < dec < 6      # Munich, WMM
    h, v = f * math.cos(math.radians(inc)), f * math.sin(math.radians(inc))
    b = face_up(world, 338.5)                      # yaw = alpha: the top points north
    d = math.radians(dec)
    # device frame: y = top = north, x = right = east, z out of the screen (up)
    assert b == pytest.approx([h * math.sin(d), h * math.cos(d), -v], abs=TOL)
    msg = mag(world).last_msg
    assert msg.header.frame_id == 'mobile_device_frame'
    assert msg.magnetic_field_covariance[0] == pytest.approx(CDD_SIGMA ** 2)


def test_yaw_plus_90_turns_the_field_by_minus_90(world):
    b0 = np.mean([face_up(world, 338.5) for _ in range(20)], axis=0)
    b1 = np.mean([face_up(world, 338.5 + 90) for _ in range(20)], axis=0)
    # the phone turned left by 90 deg: the field turns right by 90 deg in its frame
    assert b1[:2] == pytest.approx([b0[1], -b0[0]], abs=TOL / 3)
    assert b1[2] == pytest.approx(b0[2], abs=TOL / 3)
    heading = math.degrees(math.atan2(b0[0], b0[1]))
    assert heading == pytest.approx(world.environment.get('magnetic_declination'), abs=1.0)


def test_follows_alpha(world):
    env = world.environment
    env.set('north_alpha', 90.0)               # north along world +y now
    b = face_up(world, 90.0)
    f, inc, dec = env.magnetic_elements()
    h = f * math.cos(math.radians(inc))
    assert b[1] == pytest.approx(h * math.cos(math.radians(dec)), abs=TOL)
    b = face_up(world, 338.5)                  # the old north is now 111.5 deg to the left
    assert math.degrees(math.atan2(b[0], b[1])) == pytest.approx(
        dec - (90.0 - 338.5 + 360.0), abs=2.0)


def robot(params, name='r'):
    return worlds.sensor_robot('libhector_gazebo_ros_magnetic.so', params, name, plugin='m')


def test_hector_field_parameters_and_hard_iron_offset():
    with worlds.opened('ode', 2, office='environment') as w:
        w.add_model(robot('<magnitude>5e-5</magnitude><inclination>0</inclination>'
                          '<declination>0</declination><referenceHeading>0</referenceHeading>'
                          '<offset>1e-6 -2e-6 3e-6</offset><gaussianNoise>0</gaussianNoise>'),
                    pose=Pose((0, 0, 1)))
        w.step(100)
        # heading 0: the world x axis points north; body frame = world frame
        assert mag(w, 'r').last_value == pytest.approx([5e-5 + 1e-6, -2e-6, 3e-6], abs=1e-12)


def test_2011_syntax():
    with worlds.opened('bullet', 2, office='environment') as w:
        w.add_model(worlds.sensor_robot(
            'libgazebo_ros_magnetic.so', '<updateRate>25</updateRate>'
            '<robotNamespace>/phone</robotNamespace>', syntax='2011', plugin='m'),
            pose=Pose((0, 0, 1)))
        m = mag(w, 'r')
        assert m.timer.rate == 25 and m.topic == '/phone/magnetic'
        w.step(100)
        assert np.linalg.norm(m.last_value) == pytest.approx(
            w.environment.magnetic_elements()[0], abs=TOL)


def test_same_seed_same_data():
    def run(seed):
        with worlds.opened('ode', seed, office='environment') as w:
            w.add_model(robot(''), pose=Pose((0, 0, 1)))
            return worlds.sample(w, 20, 10, lambda: tuple(mag(w, 'r').last_value))
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
    assert np.std(np.array(a)[:, 0]) > 0.1 * CDD_SIGMA
