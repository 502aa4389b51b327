"""Ambient temperature and humidity (thesis 3.3.11) on the real World, both engines,
without ROS: indoor and outdoor temperature, run-time changes of the environment,
RelativeHumidity as a fraction, on-change mode, 2011 syntax, bad parameters, seed."""
import logging
import os

import numpy as np
import pytest

from sim_world.sdf import load_world_file
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

from simsensors.ambient import Ambient

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
EXACT = ('<temperatureGaussianNoise>0</temperatureGaussianNoise>'
         '<humidityGaussianNoise>0</humidityGaussianNoise>')


def make_world(engine, seed=2):
    w = World(physics=engine, seed=seed)
    w.environment = load_world_file(OFFICE).environment
    return w


def robot(params=EXACT, name='r'):
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="ambient" filename="libgazebo_ros_ambient.so">
        <bodyName>base</bodyName>%s</plugin></gazebo></robot>''' % (name, params))


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = make_world(request.param)
    yield w
    w.shutdown()


def amb(world, name='r'):
    return [p for p in world.plugins[name] if isinstance(p, Ambient)][0]


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
    w = make_world('ode')
    try:
        w.add_model(parse_urdf('''<robot name="old"
            xmlns:controller="http://playerstage.sourceforge.net/gazebo/xmlschema/#controller">
          <link name="base"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
          <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
          <gazebo><controller:gazebo_ros_ambient name="a" plugin="libgazebo_ros_ambient.so">
          <updateRate>2</updateRate><robotNamespace>/phone</robotNamespace>
          </controller:gazebo_ros_ambient></gazebo></robot>'''), pose=Pose((30, 0, 2)))
        a = amb(w, 'old')
        assert a.topic == '/phone/temperature' and a.hum_pub.topic == '/phone/humidity'
        w.step(2000)
        assert a.pub.count == 5 and abs(a.last_value[0] - 15) < 1
    finally:
        w.shutdown()


@pytest.mark.parametrize('params, words', [
    ('<temperatureGaussianNoise>-1</temperatureGaussianNoise>', 'temperatureGaussianNoise must be'),
    ('<onChangeOnly>maybe</onChangeOnly>', 'onChangeOnly must be'),
])
def test_bad_parameters_one_line_and_loads(params, words, caplog):
    w = make_world('ode')
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(robot(params), pose=Pose((3, -2, 1)))
        lines = [r.getMessage() for r in caplog.records if words in r.getMessage()]
        assert len(lines) == 1 and 'libgazebo_ros_ambient.so' in lines[0] and 'model r' in lines[0]
        w.step(1500)
        assert abs(amb(w).last_value[0] - 21) < 1
    finally:
        w.shutdown()


def test_same_seed_same_data():
    def run(seed):
        w = make_world('bullet', seed)
        try:
            w.add_model(robot(''), pose=Pose((3, -2, 1)))
            out = []
            for _ in range(20):
                w.step(1000)
                out.append(amb(w).last_value)
            return out
        finally:
            w.shutdown()
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
