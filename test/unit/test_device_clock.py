"""The device clock (thesis 3.3.9) on the real World, both engines, without ROS: sim time
x (1 + drift) + offset, set from outside, refused bad times, TimeReference message, 2011
syntax, same seed same data (bad parameters: test_sensor_contract.py)."""
import logging

import pytest

from sim_world.transforms import Pose

from simsensors.device_clock import DeviceClock

import worlds

world = worlds.world_fixture(seed=1)


def robot(params='', name='r', syntax='classic', plugin='device_clock'):
    return worlds.sensor_robot('libgazebo_ros_device_clock.so', params, name, syntax, plugin)


def clock(world, name='r'):
    return worlds.plugin_of(world, DeviceClock, name)


def test_drift_and_offset(world):
    world.add_model(robot('<driftPpm>50</driftPpm><offset>1317427200</offset>'), pose=Pose((0, 0, 1)))
    c = clock(world)
    world.step(10000)                                     # 10 s of sim time
    assert world.sim_time == pytest.approx(10.0)
    assert c.last_value == pytest.approx(1317427200 + 10 * (1 + 50e-6), abs=1e-6)
    m = c.last_msg
    assert m.header.stamp.to_sec() == pytest.approx(10.0)
    assert m.time_ref.to_sec() - 1317427200 == pytest.approx(10.0005, abs=1e-6)
    assert m.source == 'device_clock'
    assert c.pub.count == 11                              # 1 Hz: t = 0..10
    # 1000 s later the clock is 50 ms ahead
    assert c.device_time(1010.0) - 1317427200 - 1010.0 == pytest.approx(0.0505, abs=1e-6)


def test_set_from_outside(world):
    world.add_model(robot('<driftPpm>-100</driftPpm>'), pose=Pose((0, 0, 1)))
    c = clock(world)
    world.step(2000)
    ok, msg = c.set_device_time(1700000000.25)
    assert ok and 'device time set' in msg
    t_set = world.sim_time
    world.step(3000)
    assert c.last_value == pytest.approx(1700000000.25 + (world.sim_time - t_set) * (1 - 100e-6),
                                         abs=1e-6)
    assert c.last_msg.time_ref.secs == 1700000003 and \
        abs(c.last_msg.time_ref.nsecs - 249700000) < 2000


@pytest.mark.parametrize('bad', [-5, float('nan'), 'noon'])
def test_bad_device_time_refused(world, bad, caplog):
    world.add_model(robot('<offset>100</offset>'), pose=Pose((0, 0, 1)))
    c = clock(world)
    with caplog.at_level(logging.ERROR):
        ok, msg = c.set_device_time(bad)
    assert not ok and 'device_time must be' in msg and 'model r' in msg
    world.step(1000)
    assert c.last_value == pytest.approx(101.0)          # unchanged, still running


def test_2011_syntax():
    with worlds.opened('ode', 1) as w:
        w.add_model(robot('<updateRate>4</updateRate><driftPpm>1000</driftPpm>'
                          '<robotNamespace>/phone</robotNamespace>', 'old', '2011', 'clk'),
                    pose=Pose((0, 0, 1)))
        c = clock(w, 'old')
        assert c.topic == '/phone/time_reference' and c.timer.rate == 4
        w.step(2000)
        assert c.pub.count == 9 and c.last_value == pytest.approx(2.002)
        assert c.last_msg.source == 'clk'


def test_same_seed_same_data():
    def run(seed):
        with worlds.opened('ode', seed) as w:
            w.add_model(robot('<driftPpm>20</driftPpm>'), pose=Pose((0, 0, 1)))
            return worlds.sample(w, 1000, 5, lambda: clock(w).last_msg.time_ref.to_nsec())
    # no noise in a clock: any seed gives the same times (nothing random leaks in)
    assert run(1) == run(1) == run(2)
