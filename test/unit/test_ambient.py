"""Ambient temperature and humidity (thesis 3.3.11) on the real World, both engines,
without ROS: indoor and outdoor temperature, run-time changes of the environment,
RelativeHumidity as a fraction, on-change mode, 2011 syntax, seed
(bad parameters: test_sensor_contract.py)."""
import numpy as np
import pytest

from sim_world.transforms import Pose

from simsensors.ambient import Ambient

import worlds

LIB = 'libgazebo_ros_ambient.so'
EXACT = ('<temperatureGaussianNoise>0</temperatureGaussianNoise>'
         '<humidityGaussianNoise>0</humidityGaussianNoise>')
world = worlds.world_fixture(seed=2, office='environment')


def robot(params=EXACT, name='r'):
    return worlds.sensor_robot(LIB, params, name, plugin='ambient')


def amb(world, name='r'):
    return worlds.plugin_of(world, Ambient, name)


def test_indoor_outdoor_and_run_time_changes(world):
    world.add_model(robot(), pose=Pose((3, -2, 1)))          # in the office
    a = amb(world)
    world.step(1000)
    assert a.last_value == pytest.approx((21.0, 45.0))
    assert a.last_msg.temperature == pytest.approx(21.0)
    assert a.hum_pub.last.relative_humidity == pytest.approx(0.45)
    world.set_state('r', Pose((10, -3, 1)))                  # outdoors
    world.step(1000)
    assert a.last_value[0] == pytest.approx(15.0)
    # the testing instance changes the weather (what /gazebo/set_environment does)
    world.environment.set_many([('temperature', -4.5), ('humidity', 80)])
    world.step(1000)
    assert a.last_msg.temperature == pytest.approx(-4.5)
    assert a.hum_pub.last.relative_humidity == pytest.approx(0.80)
    # 1 Hz of sim time: 3 s give 3 samples after the first
    assert a.pub.count == a.hum_pub.count == 4


def test_noise_defaults_and_clamp(world):
    world.add_model(robot(''), pose=Pose((3, -2, 1)))
    a = amb(world)
    world.environment.set('humidity', 100)
    t, h = [], []
    for _ in range(200):
        world.step(1000)
        t.append(a.last_value[0])
        h.append(a.last_value[1])
    assert np.std(t) == pytest.approx(0.1, rel=0.35) and np.mean(t) == pytest.approx(21, abs=0.05)
    assert max(h) == 100.0 and min(h) >= 98.0            # clamped to 100 %, 1 % resolution
    assert a.last_msg.variance == pytest.approx(0.01)


def test_on_change_only(world):
    world.add_model(robot(EXACT + '<onChangeOnly>true</onChangeOnly>'
                          '<repeatPeriod>10</repeatPeriod>'), pose=Pose((3, -2, 1)))
    a = amb(world)
    world.step(4500)
    assert a.pub.count == 1                      # unchanged: once
    world.environment.set('indoor_temperature', 23)
    world.step(1000)
    assert a.pub.count == 2 and a.last_msg.temperature == pytest.approx(23)
    assert a.hum_pub.count == 1
    world.step(10000)                            # the slow repeat
    assert a.pub.count == 3 and a.hum_pub.count == 2


def test_2011_syntax():
    with worlds.opened('ode', 2, office='environment') as w:
        w.add_model(worlds.sensor_robot(
            LIB, '<updateRate>2</updateRate><robotNamespace>/phone</robotNamespace>', 'old',
            '2011', plugin='a'), pose=Pose((30, 0, 2)))
        a = amb(w, 'old')
        assert a.topic == '/phone/temperature' and a.hum_pub.topic == '/phone/humidity'
        w.step(2000)
        assert a.pub.count == 5 and abs(a.last_value[0] - 15) < 1


def test_same_seed_same_data():
    def run(seed):
        with worlds.opened('bullet', seed, office='environment') as w:
            w.add_model(robot(''), pose=Pose((3, -2, 1)))
            return worlds.sample(w, 1000, 20, lambda: amb(w).last_value)
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
