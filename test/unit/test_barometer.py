"""The barometer (thesis 3.3.5, 3.3.11) on the real World, both engines, without ROS:
about -11 Pa per metre at the office's 519 m, the weather's offset at run time, the
thesis's step noise capped by its maximum, Gaussian noise, altitude, both URDF syntaxes,
bad parameters, same seed same data."""
import logging
import os

import numpy as np
import pytest

from sim_world.sdf import load_world_file
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

from simsensors.barometer import Barometer, altitude_from_pressure

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
EXACT = '<gaussianNoise>0</gaussianNoise>'


def make_world(engine, seed=2):
    w = World(physics=engine, seed=seed)
    w.environment = load_world_file(OFFICE).environment
    return w


def robot(params=EXACT, name='r', fn='libgazebo_ros_air_pressure.so'):
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="baro" filename="%s">
        <bodyName>base</bodyName>%s</plugin></gazebo></robot>''' % (name, fn, params))


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = make_world(request.param)
    yield w
    w.shutdown()


def baro(world, name='r'):
    return [p for p in world.plugins[name] if isinstance(p, Barometer)][0]


def test_pressure_falls_11_pa_per_metre(world):
    world.add_model(robot(), pose=Pose((1, 1, 1)))
    b = baro(world)
    world.step(200)
    p1 = b.last_value
    # ICAO at 520 m: 101325 (1 - 0.0065*520/288.15)^5.2559 = 95 232 Pa
    assert p1 == pytest.approx(95232, abs=1)
    world.set_state('r', Pose((1, 1, 11)))
    world.step(200)
    p11 = b.last_value
    assert (p11 - p1) / 10 == pytest.approx(-11.2, abs=0.4)
    assert b.last_msg.fluid_pressure == pytest.approx(p11)
    assert b.last_altitude == pytest.approx(519 + 11, abs=0.01)
    # a weather front at run time: 3 hPa lower; the altimeter reads ~27 m higher
    world.environment.set('pressure_offset', -300)
    world.step(200)
    assert b.last_value == pytest.approx(p11 - 300, abs=1e-6)
    assert b.last_altitude - 530 == pytest.approx(27, abs=1.5)


def test_rate_and_gaussian_default(world):
    world.add_model(robot(''), pose=Pose((1, 1, 1)))
    b = baro(world)
    vals = []
    for _ in range(300):
        world.step(100)                 # 10 Hz: one sample per 100 steps of 1 ms
        vals.append(b.last_value)
    assert b.pub.count == 301
    assert np.std(vals) == pytest.approx(1.0, rel=0.2)
    assert b.last_msg.variance == pytest.approx(1.0)


def test_thesis_step_noise_capped(world):
    world.add_model(robot('<noiseModel>step</noiseModel><stepMaximum>5</stepMaximum>'
                          '<stepInterval>1</stepInterval>'), pose=Pose((1, 1, 1)))
    b = baro(world)
    truth = world.environment.pressure_at(1.0)
    err = []
    for _ in range(600):
        world.step(100)
        err.append(b.last_value - truth)
    err = np.array(err)
    assert np.all(np.abs(err) <= 5 + 1e-9) and np.abs(err).max() > 3
    changes = np.count_nonzero(np.diff(err))
    assert 30 < changes < 100                   # ~1 jump per second over 60 s
    runs = np.diff(np.flatnonzero(np.diff(err)))
    assert runs.max() >= 20                     # held for seconds at a time: steps
    assert b.last_msg.variance == pytest.approx(25 / 3.0)


def test_altitude_inverse():
    assert altitude_from_pressure(101325.0) == pytest.approx(0, abs=1e-9)
    assert altitude_from_pressure(95232.1) == pytest.approx(520, abs=0.1)


def test_hector_name_and_2011_syntax():
    w = make_world('ode')
    try:
        w.add_model(robot(EXACT, fn='libhector_gazebo_ros_baro.so'), pose=Pose((0, 0, 2)))
        w.add_model(parse_urdf('''<robot name="old"
            xmlns:controller="http://playerstage.sourceforge.net/gazebo/xmlschema/#controller">
          <link name="base"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
          <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
          <gazebo><controller:gazebo_ros_air_pressure name="b" plugin="libgazebo_ros_air_pressure.so">
          <updateRate>5</updateRate><gaussianNoise>0</gaussianNoise>
          </controller:gazebo_ros_air_pressure></gazebo></robot>'''), pose=Pose((0, 0, 2)))
        w.step(400)
        assert baro(w, 'old').timer.rate == 5
        assert baro(w, 'old').last_value == pytest.approx(baro(w, 'r').last_value)
    finally:
        w.shutdown()


@pytest.mark.parametrize('params, words', [
    ('<noiseModel>pink</noiseModel>', 'noiseModel must be'),
    ('<stepMaximum>-1</stepMaximum>', 'stepMaximum must be'),
])
def test_bad_parameters_one_line_and_loads(params, words, caplog):
    w = make_world('ode')
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(robot(params), pose=Pose((0, 0, 1)))
        lines = [r.getMessage() for r in caplog.records if words in r.getMessage()]
        assert len(lines) == 1 and 'libgazebo_ros_air_pressure.so' in lines[0] \
            and 'model r' in lines[0]
        w.step(300)
        assert 95000 < baro(w).last_value < 95400
    finally:
        w.shutdown()


@pytest.mark.parametrize('noise', ['gaussian', 'step'])
def test_same_seed_same_data(noise):
    def run(seed):
        w = make_world('ode', seed)
        try:
            w.add_model(robot('<noiseModel>%s</noiseModel>' % noise), pose=Pose((0, 0, 1)))
            out = []
            for _ in range(30):
                w.step(100)
                out.append(baro(w).last_value)
            return out
        finally:
            w.shutdown()
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
