"""The device clock (thesis 3.3.9) on the real World, both engines, without ROS: sim time
x (1 + drift) + offset, set from outside, refused bad times, TimeReference message, 2011
syntax, bad parameters, same seed same data."""
import logging

import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

from simsensors.device_clock import DeviceClock


def robot(params='', name='r'):
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="device_clock" filename="libgazebo_ros_device_clock.so">
        <bodyName>base</bodyName>%s</plugin></gazebo></robot>''' % (name, params))


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = World(physics=request.param, seed=1)
    yield w
    w.shutdown()


def clock(world, name='r'):
    return [p for p in world.plugins[name] if isinstance(p, DeviceClock)][0]


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
    w = World(physics='ode', seed=1)
    try:
        w.add_model(parse_urdf('''<robot name="old"
            xmlns:controller="http://playerstage.sourceforge.net/gazebo/xmlschema/#controller">
          <link name="base"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
          <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
          <gazebo><controller:gazebo_ros_device_clock name="clk" plugin="libgazebo_ros_device_clock.so">
          <updateRate>4</updateRate><driftPpm>1000</driftPpm><robotNamespace>/phone</robotNamespace>
          </controller:gazebo_ros_device_clock></gazebo></robot>'''), pose=Pose((0, 0, 1)))
        c = clock(w, 'old')
        assert c.topic == '/phone/time_reference' and c.timer.rate == 4
        w.step(2000)
        assert c.pub.count == 9 and c.last_value == pytest.approx(2.002)
        assert c.last_msg.source == 'clk'
    finally:
        w.shutdown()


@pytest.mark.parametrize('params, words', [
    ('<driftPpm>fast</driftPpm>', 'driftPpm must be'),
    ('<offset>-3</offset>', 'offset must be'),
])
def test_bad_parameters_one_line_and_loads(params, words, caplog):
    w = World(physics='ode', seed=1)
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(robot(params), pose=Pose((0, 0, 1)))
        lines = [r.getMessage() for r in caplog.records if words in r.getMessage()]
        assert len(lines) == 1 and 'libgazebo_ros_device_clock.so' in lines[0] \
            and 'model r' in lines[0]
        w.step(3000)
        assert clock(w).last_value == pytest.approx(3.0)
    finally:
        w.shutdown()


def test_same_seed_same_data():
    def run(seed):
        w = World(physics='ode', seed=seed)
        try:
            w.add_model(robot('<driftPpm>20</driftPpm>'), pose=Pose((0, 0, 1)))
            out = []
            for _ in range(5):
                w.step(1000)
                out.append(clock(w).last_msg.time_ref.to_nsec())
            return out
        finally:
            w.shutdown()
    # no noise in a clock: any seed gives the same times (nothing random leaks in)
    assert run(1) == run(1) == run(2)
