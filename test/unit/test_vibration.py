"""Vibration motor (simsensors.vibration) and the thesis's force controller
(simsensors.force) on the phone, both physics engines: the force pattern (zero mean, no
drift), the phone's own IMU sees it (accelerometer variance up while it runs, down after),
VibrationEffect waveforms, bad input. No roscore."""
import logging
import os

import numpy as np
import pytest

from simsensors.force import ForceController
from simsensors.vibration import Vibration, Waveform, square_impulse, step_forces
from simsensors.imu import ImuPlugin
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


@pytest.fixture(params=['ode', 'bullet'])
def phone(request):
    w = World(physics=request.param, seed=5, gravity=(0, 0, -9.81))
    w.add_model(load_urdf_file(PHONE), pose=Pose((0, 0, 1)))        # floats: gravity off
    ps = w.plugins['mobile_device']
    vib = next(p for p in ps if isinstance(p, Vibration))
    imu = next(p for p in ps if isinstance(p, ImuPlugin))
    yield w, vib, imu
    w.shutdown()


def test_square_wave_zero_mean_and_exact_impulses():
    one = lambda u: 1.0
    T = 0.007
    # quarter +, half -, quarter +: zero over every half period
    for k in range(6):
        assert square_impulse(k * T / 2, (k + 1) * T / 2, T, one) == pytest.approx(0, abs=1e-15)
    assert square_impulse(0, T / 4, T, one) == pytest.approx(T / 4)
    assert square_impulse(T / 4, T / 2, T, one) == pytest.approx(-T / 4)
    rows = step_forces(0.0, 70, 0.001, T, one)          # 70 steps = 10 periods
    assert abs(rows.sum()) < 1e-9 and np.abs(rows).max() == pytest.approx(1.0)
    # velocity (running sum) never drifts: it returns to 0 at every half period
    v = np.cumsum(rows) * 0.001
    assert np.abs(v).max() <= T / 4 + 1e-12 and abs(v[-1]) < 1e-12
    # a 10 ms window (the IMU's) does not cancel the 7 ms wave, a 5 ms one would
    win = np.convolve(step_forces(0.0, 200, 0.001, T, one), np.ones(10) / 10, 'valid')
    win5 = np.convolve(step_forces(0.0, 200, 0.001, 0.005, one), np.ones(10) / 10, 'valid')
    assert win.std() > 0.1 and win5.std() < 1e-9


def test_waveform_one_shot_repeat_and_bad_input():
    w = Waveform([0.2], [0.5])
    assert w.amplitude(0.1) == 0.5 and w.amplitude(0.25) == 0.0 and w.finished(0.25)
    r = Waveform([0.1, 0.2, 0.1], [0.0, 1.0, 0.3], repeat=1)
    assert [r.amplitude(t) for t in (0.05, 0.15, 0.35, 0.45, 0.65)] == [0.0, 1.0, 0.3, 1.0, 0.3]
    assert not r.finished(100)
    for args, text in ((([0.1, 0.2], [1.0]), 'same length'), (([-0.1], [1.0]), '>= 0 s'),
                       (([0.1], [1.5]), '0..1'), (([0.1], [float('nan')]), '0..1'),
                       (([0.1], [1.0], 3), 'repeat')):
        with pytest.raises(ValueError, match=text):
            Waveform(*args)


def _accel_var(w, imu, seconds):
    samples = []
    n = int(round(seconds / w.step_size))
    for _ in range(n // 10):
        w.step(10)
        samples.append(imu.last_value[2])
    return np.var(np.array(samples), axis=0).sum()


def test_imu_variance_rises_while_vibrating_and_falls_after(phone):
    w, vib, imu = phone
    state = vib.outputs['state']
    assert state.topic.endswith('/vibration/state') and state.last.data == 0.0
    w.step(100)
    quiet = _accel_var(w, imu, 1.0)
    assert quiet < 4 * 3 * 0.05 ** 2                       # the CDD noise alone
    assert vib.one_shot(1.0, 1.0)
    w.step(10)
    p0 = w.link_pose('mobile_device', 'mobile_base_link').p
    busy = _accel_var(w, imu, 0.9)
    assert vib.amplitude_now == 1.0 and state.last.data == 1.0    # runs now
    n = state.count
    assert w.power.draws('mobile_device')['vibration'] == pytest.approx(0.1)
    assert busy > 20 * quiet, (busy, quiet)
    w.step(200)                                            # the one-shot is over
    assert vib.amplitude_now == 0.0 and w.power.draws('mobile_device')['vibration'] == 0.0
    assert state.last.data == 0.0 and state.count == n + 1     # on change only: one message
    after = _accel_var(w, imu, 1.0)
    assert after < 4 * 3 * 0.05 ** 2 and after < busy / 20
    # zero mean: the phone did not wander off (a one-sided force would move it metres)
    p1 = w.link_pose('mobile_device', 'mobile_base_link').p
    assert np.linalg.norm(p1 - p0) < 1e-3
    lin, _ = w.model_state('mobile_device')[1:], None
    assert np.linalg.norm(w.model_state('mobile_device')[1]) < 1e-3


def test_half_amplitude_gives_half_the_force_and_bad_commands_keep_state(phone, caplog):
    w, vib, imu = phone
    vib.vibrate([0.5], [0.5], -1)
    w.step(20)
    rows = vib.queued
    assert np.abs(rows).max() == pytest.approx(0.25 / np.sqrt(2), rel=1e-6)   # 0.5 N x 0.5
    assert np.linalg.norm(rows.sum(axis=0)) < 0.25        # about zero over the queue
    with caplog.at_level(logging.ERROR):
        assert not vib.vibrate([0.1, 0.2], [1.0], -1)
        assert not vib.vibrate([0.1], [2.0], -1)
    w.step(20)
    assert vib.amplitude_now == 0.5                        # still the last good effect
    lines = [r.getMessage() for r in caplog.records]
    assert any('same length' in l and 'libgazebo_ros_vibration.so' in l for l in lines)
    assert any('0..1' in l for l in lines)
    vib.cancel()
    w.step(20)
    assert vib.amplitude_now == 0.0 and vib.queued is None


def test_force_controller_applies_until_the_next_message(phone):
    w, vib, imu = phone
    fc = next(p for p in w.plugins['mobile_device'] if isinstance(p, ForceController))
    assert fc.topic == '/force'        # the description names no namespace (a spawn's gives one)
    m = w.models['mobile_device']
    mass = sum(l.inertial.mass for l in m.links.values() if l.inertial is not None)
    w.step(5)
    fc.set_wrench((0.1, 0, 0))
    w.step(5)                                            # taken at the 100 Hz tick t=0.01
    w.step(1000)
    v = w.model_state('mobile_device')[1]
    assert v[0] == pytest.approx(0.1 / mass * 1.0, rel=0.01)
    assert not fc.set_wrench((float('nan'), 0, 0))       # refused, the last one stays
    w.step(100)
    assert w.model_state('mobile_device')[1][0] == pytest.approx(0.1 / mass * 1.1, rel=0.01)
    fc.set_wrench((0, 0, 0))
    w.step(10)
    v1 = w.model_state('mobile_device')[1][0]
    w.step(100)
    assert w.model_state('mobile_device')[1][0] == pytest.approx(v1, abs=1e-9)
