"""The barometer (thesis 3.3.5, 3.3.11) on the real World, both engines, without ROS:
about -11 Pa per metre at the office's 519 m, the weather's offset at run time, the
thesis's step noise capped by its maximum, Gaussian noise, altitude, both URDF syntaxes,
same seed same data (bad parameters: test_sensor_contract.py)."""
import numpy as np
import pytest

from sim_world.transforms import Pose

from simsensors.barometer import Barometer, altitude_from_pressure

import worlds

EXACT = '<gaussianNoise>0</gaussianNoise>'
world = worlds.world_fixture(seed=2, office='environment')


def robot(params=EXACT, name='r', fn='libgazebo_ros_air_pressure.so', syntax='classic'):
    return worlds.sensor_robot(fn, params, name, syntax, plugin='baro')


def baro(world, name='r'):
    return worlds.plugin_of(world, Barometer, name)


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
    with worlds.opened('ode', 2, office='environment') as w:
        w.add_model(robot(EXACT, fn='libhector_gazebo_ros_baro.so'), pose=Pose((0, 0, 2)))
        w.add_model(robot('<updateRate>5</updateRate><gaussianNoise>0</gaussianNoise>', 'old',
                          syntax='2011'), pose=Pose((0, 0, 2)))
        w.step(400)
        assert baro(w, 'old').timer.rate == 5
        assert baro(w, 'old').last_value == pytest.approx(baro(w, 'r').last_value)


@pytest.mark.parametrize('noise', ['gaussian', 'step'])
def test_same_seed_same_data(noise):
    def run(seed):
        with worlds.opened('ode', seed, office='environment') as w:
            w.add_model(robot('<noiseModel>%s</noiseModel>' % noise), pose=Pose((0, 0, 1)))
            return worlds.sample(w, 100, 30, lambda: baro(w).last_value)
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
