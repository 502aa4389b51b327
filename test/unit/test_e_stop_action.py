"""The scenario action ``e_stop`` (a robot's gazebo_ros_control e-stop, std_msgs/Bool on
``<ns>/e_stop`` or the plugin's ``eStopTopic``): the format's checks name the bad field; the
action publishes the message through the run's Hands; delivered to the plugin as its ROS
side would deliver it, it stops and releases the arm. No roscore, well under a second."""
import logging
import math
import os

import pytest

from std_msgs.msg import Bool

from testing_instance.run.actions import EStop, Hands, action_of, e_stop_topic
from testing_instance.scenario.format import ScenarioError, loads

HEAD = 'duration: 5\ntimeline:\n'


def problems(text):
    with pytest.raises(ScenarioError) as e:
        loads(HEAD + text)
    return str(e.value)


def test_e_stop_validates():
    sc = loads(HEAD + '''  - {at: 0.5, action: e_stop, ns: /xarm, active: true}
  - {at: 1, action: e_stop, ns: xarm, active: false, topic: estop}
  - {at: 1.5, action: e_stop, ns: /xarm, active: true, topic: /robot/e_stop}
''')
    assert [(e['action'], e['active']) for e in sc.timeline] == [
        ('e_stop', True), ('e_stop', False), ('e_stop', True)]


@pytest.mark.parametrize('event, where, words', [
    ('{at: 0, action: e_stop, active: true}', 'timeline[0]', "missing 'ns'"),
    ('{at: 0, action: e_stop, ns: /xarm}', 'timeline[0]', "missing 'active'"),
    ('{at: 0, action: e_stop, ns: /xarm, active: yes please}', 'timeline[0].active',
     'true or false'),
    ('{at: 0, action: e_stop, ns: "", active: true}', 'timeline[0].ns', 'a non-empty string'),
    ('{at: 0, action: e_stop, ns: "x arm", active: true}', 'timeline[0].ns', 'a ROS name'),
    ('{at: 0, action: e_stop, ns: /xarm, active: true, topic: "9stop"}', 'timeline[0].topic',
     'a ROS name'),
    ('{at: 0, action: e_stop, ns: /xarm, active: true, topic: [a]}', 'timeline[0].topic',
     'a non-empty string'),
    ('{at: 0, action: e_stop, ns: /xarm, active: true, model: xarm6}', 'timeline[0].model',
     'unknown key'),
])
def test_bad_e_stop_names_the_field(event, where, words):
    text = problems('  - ' + event + '\n')
    line = next(ln for ln in text.splitlines() if where + ':' in ln)
    assert line.startswith('<scenario>:3: ') and words in line, text


def test_a_long_bad_name_is_refused_at_once():
    # (the name check has no nested repetition: a fuzzed name cannot make it backtrack)
    text = problems('  - {at: 0, action: e_stop, ns: "%s!", active: true}\n' % ('a/' * 5000))
    assert 'timeline[0].ns: expected a ROS name' in text


@pytest.mark.parametrize('ev, topic', [
    ({'ns': '/xarm'}, '/xarm/e_stop'),
    ({'ns': 'xarm/'}, '/xarm/e_stop'),
    ({'ns': '/xarm', 'topic': 'estop'}, '/xarm/estop'),
    ({'ns': '/xarm', 'topic': '/robot/e_stop'}, '/robot/e_stop'),
    ({'ns': '/'}, '/e_stop'),
])
def test_the_e_stop_topic(ev, topic):
    assert e_stop_topic(ev) == topic


def test_the_action_publishes_a_bool_on_the_robots_e_stop():
    sent = []
    h = Hands(None, None, None)
    h.publish = lambda topic, msg: sent.append((topic, msg))
    for on in (True, False):
        action_of({'id': 'stop', 'action': 'e_stop', 'ns': '/xarm', 'active': on}).apply(h, 1.0)
    assert [(t, type(m), m.data) for t, m in sent] == [('/xarm/e_stop', Bool, True),
                                                       ('/xarm/e_stop', Bool, False)]
    assert isinstance(action_of({'action': 'e_stop', 'ns': 'a', 'active': True}), EStop)


def test_the_message_stops_and_releases_the_arm(caplog):
    """The published Bool, handed to the plugin as its ROS side does (ros_api subscribes
    ``eStopTopic`` with ``plugin.e_stop(msg.data)``): the moving arm holds, then follows
    its trajectory again."""
    caplog.set_level(logging.ERROR)
    pybullet_data = pytest.importorskip('pybullet_data')
    from sim_world.control.trajectory import Point, Trajectory
    from sim_world.transforms import Pose
    from sim_world.urdf import load_urdf_file
    from sim_world.world import World
    w = World(physics='ode', step_size=0.001, seed=1)
    try:
        w.add_model(load_urdf_file(os.path.join(pybullet_data.getDataPath(), 'xarm',
                                                'xarm6_robot.urdf')), pose=Pose())
        plugin, = [p for p in w.find_plugins('xarm6')
                   if p.spec.filename == 'libgazebo_ros_control.so']
        joints = ['joint%d' % i for i in range(1, 7)]
        ok, msg = plugin.spawn('arm', {'type': 'position_controllers/JointTrajectoryController',
                                       'joints': joints})
        assert ok, msg
        plugin.manager.controllers['arm'].submit_command(
            Trajectory(joints, [Point([0.5] * 6, time_from_start=1.0)]))
        h = Hands(None, None, None)
        h.publish = lambda topic, m: plugin.e_stop(m.data)
        q1 = lambda: w.physics.joint_state('xarm6', 'joint1')[0]  # noqa: E731
        w.step(200)
        moving = q1()
        assert 0.03 < moving < 0.45
        stop = {'id': 'stop', 'action': 'e_stop', 'ns': '/xarm', 'active': True}
        EStop(stop).apply(h, w.sim_time)
        w.step(100)
        assert q1() == pytest.approx(moving, abs=0.002)       # held where it was
        EStop(dict(stop, active=False)).apply(h, w.sim_time)
        w.step(100)
        assert q1() == pytest.approx(moving, abs=0.002)       # restarted: holds there
        plugin.manager.controllers['arm'].submit_command(
            Trajectory(joints, [Point([0.5] * 6, time_from_start=0.1)]))
        w.step(150)
        assert math.isclose(q1(), 0.5, abs_tol=1e-3)          # and follows a new goal
    finally:
        w.shutdown()
