"""The testing instance's joint actions and joint expectations (issue 48 part 6), without a
roscore: the format's checks name the bad key; each action acts on a real World through the
world's own service handlers (JointRosApi, LinkAttacher), routed as the runner's proxies
would route them; ``field: position[joint2]`` reads a JointState by joint name.
"""
import logging
import math
from types import SimpleNamespace

import numpy as np
import pytest

from sensor_msgs.msg import JointState

from sim_world.attacher import LinkAttacher
from sim_world.joint_api import JointRosApi
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from testing_instance.run.actions import Hands, action_of
from testing_instance.scenario.expect import Expectation, FieldError, get_field
from testing_instance.scenario.format import loads, ScenarioError
from testing_instance.scenario.results import RunError

import worlds
from test_link_attacher import PHONE, xarm6

HEAD = 'duration: 5\ntimeline:\n'


def problems(text):
    with pytest.raises(ScenarioError) as e:
        loads(HEAD + text)
    return str(e.value)


def test_the_joint_actions_validate():
    sc = loads(HEAD + '''  - {at: 0, action: set_joints, model: xarm6,
     positions: {joint1: 0.5, joint2: -0.3}}
  - {at: 0, action: joint_effort, joint: "east_door::hinge", effort: -20, duration: 2}
  - {at: 0, action: door, open: false}
  - {at: 0, action: attach, holder: "xarm6::link6", held: mobile_device}
  - {at: 1, action: detach, holder: "xarm6::link6", held: mobile_device}
  - at: 1
    action: trajectory
    controller: /arm_controller
    joints: [joint1, joint2]
    points:
      - {positions: [0.1, 0.2], time_from_start: 1.0}
      - {positions: [0.3, 0.4], velocities: [0, 0], time_from_start: 2.5}
''')
    assert [e['action'] for e in sc.timeline] == ['set_joints', 'joint_effort', 'door',
                                                  'attach', 'detach', 'trajectory']


@pytest.mark.parametrize('event, where, words', [
    ('{at: 0, action: set_joints, model: a, positions: {joint1: x}}',
     'timeline[0].positions', 'a number for joint joint1'),
    ('{at: 0, action: set_joints, model: a, positions: [1, 2]}',
     'timeline[0].positions', 'a mapping of joint names to positions'),
    ('{at: 0, action: set_joints, model: a}', 'timeline[0]', "missing 'positions'"),
    ('{at: 0, action: joint_effort, joint: j, effort: .nan}', 'timeline[0].effort',
     'a number'),
    ('{at: 0, action: door, open: maybe}', 'timeline[0].open', 'true or false'),
    ('{at: 0, action: attach, holder: "a::b"}', 'timeline[0]', "missing 'held'"),
    ('{at: 0, action: trajectory, controller: c, joints: [a, b], points: '
     '[{positions: [1], time_from_start: 1}]}', 'timeline[0].points[0].positions',
     'expected 2 values'),
    ('{at: 0, action: trajectory, controller: c, joints: [a], points: '
     '[{positions: [1], time_from_start: 2}, {positions: [2], time_from_start: 1}]}',
     'timeline[0].points[1].time_from_start', 'after the point before'),
    ('{at: 0, action: trajectory, controller: c, joints: [a], points: [{positions: [1]}]}',
     'timeline[0].points[0]', "missing 'time_from_start'"),
    ('{at: 0, action: trajectory, controller: c, joints: [a], points: '
     '[{positions: [1], time_from_start: 1, speed: 2}]}', 'timeline[0].points[0].speed',
     'unknown key'),
    ('{at: 0, action: trajectory, controller: c, joints: [], points: []}',
     'timeline[0].joints', 'a list of names'),
])
def test_bad_joint_actions_name_the_key(event, where, words):
    text = problems('  - ' + event + '\n')
    line = next(ln for ln in text.splitlines() if where + ':' in ln)
    assert words in line, text


def test_joint_states_by_joint_name():
    m = JointState(name=['joint1', 'joint2'], position=[0.1, 0.2], velocity=[1.0, 2.0])
    assert get_field(m, 'position[joint2]') == 0.2
    assert get_field(m, 'velocity[joint1]') == 1.0
    assert get_field(m, 'position[1]') == 0.2
    with pytest.raises(FieldError, match="no 'joint9' in name \\(joint1, joint2\\)"):
        get_field(m, 'position[joint9]')
    with pytest.raises(FieldError, match='no element'):
        get_field(m, 'effort[joint1]')               # an empty array
    # the order of the names may change from message to message: looked up in each
    e = Expectation({'name': 'j2', 'topic': '/joint_states', 'field': 'position[joint2]',
                     'always': {'near': 0.2, 'tol': 0.01}}, duration=5.0)
    e.begin(0.0)
    e.feed(0.1, m)
    e.feed(0.2, JointState(name=['joint2', 'joint1'], position=[0.205, 9.0]))
    assert e.finish(5.0).passed
    e = Expectation({'name': 'j9', 'topic': '/joint_states', 'field': 'position[joint9]',
                     'eventually': {'gt': 0}}, duration=5.0)
    e.begin(0.0)
    e.feed(0.1, m)
    assert e.verdict.error and 'joint9' in e.verdict.actual
    # gazebo's model_states by model name
    ms = SimpleNamespace(__slots__=('name', 'pose'), name=['a', 'phone'],
                         pose=[None, SimpleNamespace(__slots__=('z',), z=0.8)])
    assert get_field(ms, 'pose[phone].z') == 0.8


class LocalWorld(object):
    """The runner's WorldSide for these tests: its proxies call the world's handlers."""

    def __init__(self, world):
        api = SimpleNamespace(world=world)
        joints = JointRosApi(api, serve=False)
        self.lines = []
        att = LinkAttacher(api, serve=False, log=self.lines.append)
        self.routes = {'/gazebo/set_model_configuration': joints.set_model_configuration,
                       '/gazebo/apply_joint_effort': joints.apply_joint_effort,
                       '/gazebo/get_model_properties': joints.get_model_properties,
                       '/gazebo/attach': att.attach, '/gazebo/detach': att.detach}
        self.srv_types = {}

    def proxy(self, name, typ):
        handler = self.routes[name]
        return lambda *args: handler(typ._request_class(*args))

    def log_tail(self):
        return list(self.lines)


def act(h, ev, t=0.0):
    ev.setdefault('id', ev['action'])
    action_of(ev).apply(h, t)


def test_joint_actions_act_on_the_world(caplog):
    caplog.set_level(logging.ERROR)
    with worlds.opened('ode', office='world') as w:
        w.add_model(xarm6())
        h = Hands(SimpleNamespace(phones=[{'ns': 'mobile_device'}]), LocalWorld(w),
                  lambda t, fn, what: None)
        # the office door: open by default, closed and opened by the door action
        hinge = lambda: w.physics.joint_state('east_door', 'hinge')[0]  # noqa: E731
        assert hinge() == pytest.approx(1.5)
        act(h, {'action': 'door', 'open': False})
        assert hinge() == 0.0
        act(h, {'action': 'door', 'open': True})
        assert hinge() == 1.5
        # an effort for 0.3 s swings it towards closed; its friction and damping stop it
        act(h, {'action': 'joint_effort', 'joint': 'east_door::hinge', 'effort': -30.0,
                'duration': 0.3})
        w.step(300)
        assert w.physics.joint_state('east_door', 'hinge')[1] < -0.5
        w.step(2000)
        assert -0.01 <= hinge() < 1.4
        assert abs(w.physics.joint_state('east_door', 'hinge')[1]) < 1e-2
        # set_joints: the arm's joints where they are told, at rest
        act(h, {'action': 'set_joints', 'model': 'xarm6',
                'positions': {'joint1': 0.7, 'joint2': -0.3}})
        st = w.physics.joint_states('xarm6')
        assert (st['joint1'][0], st['joint2'][0]) == (pytest.approx(0.7), pytest.approx(-0.3))
        # attach / detach: a model alone means its root link
        w.add_model(parse_urdf(PHONE), pose=w.link_pose('xarm6', 'link6') * Pose([0, 0, 0.05]))
        act(h, {'action': 'attach', 'holder': 'xarm6::link6', 'held': 'phone'})
        assert w.physics.attachments() == [('xarm6', 'link6', 'phone', 'body')]
        act(h, {'action': 'set_joints', 'model': 'xarm6', 'positions': {'joint1': 0.0}})
        rel = w.link_pose('xarm6', 'link6').inverse() * w.link_pose('phone', 'body')
        assert rel.p == pytest.approx([0, 0, 0.05], abs=1e-6)
        act(h, {'action': 'detach', 'holder': 'xarm6::link6', 'held': 'phone'})
        assert w.physics.attachments() == []
        # refusals are the run's errors naming the action
        with pytest.raises(RunError, match=r'^let_go \(detach\): /gazebo/detach refused it'):
            act(h, {'id': 'let_go', 'action': 'detach', 'holder': 'xarm6::link6',
                    'held': 'phone'})
        with pytest.raises(RunError, match="no movable joint 'nope'"):
            act(h, {'action': 'set_joints', 'model': 'xarm6', 'positions': {'nope': 1}})
        with pytest.raises(RunError, match="no joint named 'nope'"):
            act(h, {'action': 'joint_effort', 'joint': 'nope', 'effort': 1.0})


def test_the_trajectory_action_sends_a_joint_trajectory():
    sent = []
    h = Hands(None, None, None)
    h.publish = lambda topic, msg: sent.append((topic, msg))
    act(h, {'action': 'trajectory', 'controller': 'arm_controller/', 'joints': ['j1', 'j2'],
            'points': [{'positions': [0.1, 0.2], 'time_from_start': 1.0},
                       {'positions': [0.3, 0.4], 'velocities': [0.0, 0.0],
                        'time_from_start': 2.5}]})
    (topic, msg), = sent
    assert topic == '/arm_controller/command'
    assert msg._type.endswith('/JointTrajectory')
    assert msg._md5sum == '65b4f94a94d1ed67169da35a02f33d3f'   # trajectory_msgs'
    assert msg.joint_names == ['j1', 'j2'] and msg.header.stamp.to_sec() == 0.0
    assert [list(p.positions) for p in msg.points] == [[0.1, 0.2], [0.3, 0.4]]
    assert [p.time_from_start.to_sec() for p in msg.points] == [1.0, 2.5]
    assert list(msg.points[1].velocities) == [0.0, 0.0] and not msg.points[0].velocities
    assert math.isclose(msg.points[1].time_from_start.to_sec(), 2.5)
    assert np.all(np.isfinite(msg.points[0].positions))


def test_the_xarm6_example_parses():
    import os
    from testing_instance.scenario.format import load
    folder = os.path.join(worlds.ROOT, 'testing_instance', 'examples', 'robots')
    sc = load(os.path.join(folder, 'xarm6_qr.yaml'))
    assert [e['action'] for e in sc.timeline] == ['set_model_state', 'attach', 'trajectory']
    assert sc.timeline[2]['when']['field'] == 'position[joint1]'
    assert os.path.isfile(sc.resolve(sc.world['launch']))
    assert os.path.isfile(sc.resolve(sc.apps[0]['script']))
    assert os.access(os.path.join(folder, 'xarm6_description'), os.X_OK)
    assert [e['field'] for e in sc.expect if 'field' in e] == [
        'position[joint1]', 'pose[mobile_device].position', 'data']
