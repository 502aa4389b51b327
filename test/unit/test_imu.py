"""The IMU plugin (thesis 3.3.3, snippet 3.3.2) on the World, without ROS (bad parameters:
test_sensor_contract.py)."""
import math

import numpy as np
import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

import worlds


NO_NOISE = '<accelGaussianNoise>0</accelGaussianNoise><rateGaussianNoise>0</rateGaussianNoise>'


def robot(name, gravity=True, imu='<updateRate>100</updateRate>' + NO_NOISE):
    g = '' if gravity else '<gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>'
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.129"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
      <collision><geometry><box size="0.12 0.06 0.01"/></geometry></collision></link>%s
      <gazebo><plugin name="imu" filename="libgazebo_ros_imu.so">
        <bodyName>base</bodyName><topicName>imu</topicName>%s</plugin></gazebo></robot>'''
                      % (name, g, imu))


world = worlds.world_fixture(seed=None)


def imu_of(world, name):
    return [p for p in world.plugins[name] if p.spec.filename == 'libgazebo_ros_imu.so'][0]


def test_held_phone_reads_gravity_up(world):
    world.add_model(robot('flat', gravity=False), pose=Pose((0, 0, 1)))
    # rolled by 90 degrees: the world's up axis is the link's -y
    world.add_model(robot('rolled', gravity=False), pose=Pose.from_xyz_rpy((1, 0, 1), (math.pi / 2, 0, 0)))
    world.step(100)
    q, gyro, force = imu_of(world, 'flat').last
    assert force == pytest.approx([0, 0, 9.81], abs=1e-3)
    assert gyro == pytest.approx([0, 0, 0], abs=1e-6)
    q, gyro, force = imu_of(world, 'rolled').last
    assert force == pytest.approx([0, 9.81, 0], abs=1e-3)
    assert q == pytest.approx(Pose.from_xyz_rpy((0, 0, 0), (math.pi / 2, 0, 0)).q, abs=1e-6)


def test_free_fall_reads_zero(world):
    world.add_model(robot('drop'), pose=Pose((0, 0, 50)))
    world.step(200)
    force = imu_of(world, 'drop').last[2]
    assert np.linalg.norm(force) < 0.05


def test_gyro_in_link_frame(world):
    world.add_model(robot('spin', gravity=False), pose=Pose.from_xyz_rpy((0, 0, 1), (0, math.pi / 2, 0)))
    world.set_state('spin', world.model_state('spin')[0], ang=[0, 0, 1.0])
    world.step(20)
    gyro = imu_of(world, 'spin').last[1]
    # pitched by +90 degrees the link's +x points down (world -z), so a spin about the
    # world's z axis reads -1 rad/s about the link's x
    assert gyro == pytest.approx([-1.0, 0, 0], abs=1e-3)


def test_rate_and_noise(world):
    """The thesis's single gaussianNoise sets both sigmas; samples come at the rate in sim
    time."""
    world.add_model(robot('noisy', gravity=False, imu='<updateRate>50</updateRate>'
                          '<gaussianNoise>0.2</gaussianNoise>'), pose=Pose((0, 0, 1)))
    p = imu_of(world, 'noisy')
    samples = []
    orig = p.measure

    def record(*a):
        r = orig(*a)
        samples.append((r[1], r[2]))
        return r
    p.measure = record
    world.step(4000)
    assert len(samples) == 4 * 50 + 1
    gyro = np.array([s[0] for s in samples[1:]])
    s = np.array([s[1] for s in samples[1:]])
    assert s.std(axis=0) == pytest.approx([0.2, 0.2, 0.2], rel=0.3)
    assert gyro.std(axis=0) == pytest.approx([0.2, 0.2, 0.2], rel=0.3)
    assert s.mean(axis=0) == pytest.approx([0, 0, 9.81], abs=0.06)


def test_android_cdd_defaults(world):
    """Without noise parameters the IMU has the Android CDD noise: accelerometer sigma
    0.05 m/s^2, gyroscope variance 1e-7 rad^2/s^2 per Hz (at 100 Hz: sigma 3.2 mrad/s); the
    message covariances say so, orientation covariance stays zero (not perturbed)."""
    world.add_model(robot('cdd', gravity=False, imu='<updateRate>100</updateRate>'),
                    pose=Pose((0, 0, 1)))
    p = imu_of(world, 'cdd')
    acc, gyro = [], []
    for _ in range(400):
        world.step(10)
        acc.append(p.last[2])
        gyro.append(p.last[1])
    assert np.std(acc, axis=0) == pytest.approx([0.05] * 3, rel=0.2)
    assert np.std(gyro, axis=0) == pytest.approx([math.sqrt(1e-7 * 100)] * 3, rel=0.2)
    msg = p.to_msg(p.last, world.ros_now())
    assert msg.linear_acceleration_covariance[0] == pytest.approx(0.05 ** 2)
    assert msg.angular_velocity_covariance[4] == pytest.approx(1e-5)
    assert list(msg.orientation_covariance) == [0.0] * 9


def test_hector_names_per_channel(world):
    world.add_model(robot('hector', gravity=False, imu='<updateRate>100</updateRate>'
                          '<accelOffset>0.5 0 0</accelOffset><accelGaussianNoise>0</accelGaussianNoise>'
                          '<rateOffset>0 0 0.1</rateOffset><rateGaussianNoise>0</rateGaussianNoise>'),
                    pose=Pose((0, 0, 1)))
    world.step(50)
    q, gyro, force = imu_of(world, 'hector').last
    assert force == pytest.approx([0.5, 0, 9.81], abs=1e-3)
    assert gyro == pytest.approx([0, 0, 0.1], abs=1e-6)
