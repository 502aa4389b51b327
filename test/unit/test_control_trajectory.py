"""ros_controllers' JointTrajectoryController in the simulator (issue 48 part 4), no roscore:
pybullet_data's xarm6 (its own <transmission>s: PositionJointInterface, kinematic as
DefaultRobotHWSim without PID) follows a 3-point goal over 4 s through the action's handler
(sim_world.control.ros_api with a stand-in for actionlib's goal handle) and through the
command topic's handler, on ODE and Bullet; both engines give the same trajectory; the arm
holds its home pose; bad trajectories are refused with ros_controllers' error codes; the
controller_manager services answer as controller_manager does."""
import logging
import math
import os

import numpy as np
import pytest

from sim_world.control.ros_api import ControllerManagerRos
from sim_world.control.trajectory import (GOAL_TOLERANCE_VIOLATED, INVALID_GOAL,
                                          INVALID_JOINTS, PATH_TOLERANCE_VIOLATED, SUCCESSFUL)
from sim_world.physics import ENGINES
from sim_world.world import World

pybullet_data = pytest.importorskip('pybullet_data')

XARM = os.path.join(pybullet_data.getDataPath(), 'xarm', 'xarm6_robot.urdf')
JOINTS = ['joint%d' % i for i in range(1, 7)]
GOAL = [(1.0, [0.3, -0.2, -0.3, 0.2, 0.3, 0.1]),
        (2.5, [0.6, -0.4, -0.6, 0.4, 0.6, 0.2]),
        (4.0, [0.0, 0.1, -0.2, 0.0, 0.2, 0.0])]
ARM = {'type': 'position_controllers/JointTrajectoryController', 'joints': JOINTS,
       'constraints': {'goal_time': 0.5, 'stopped_velocity_tolerance': 0.01,
                       'joint1': {'trajectory': 0.05, 'goal': 0.005}}}


def xarm_world(physics, step=0.001, params=None):
    from sim_world.urdf import load_urdf_file
    w = World(physics=physics, step_size=step, seed=1)
    w.add_model(load_urdf_file(XARM))
    plugin = [p for p in w.find_plugins('xarm6')
              if p.spec.filename == 'libgazebo_ros_control.so'][0]
    store = {'/xarm/arm': dict(params or ARM),
             '/xarm/joint_state_controller': {
                 'type': 'joint_state_controller/JointStateController', 'publish_rate': 50}}
    api = ControllerManagerRos(plugin, serve=False, get_param=store.get)
    return w, plugin, api


class Req(object):
    def __init__(self, **kw):
        self.__dict__.update(kw)


def load_and_start(api, *names):
    from mobile_device_sim.srv import SwitchControllerRequest
    for n in names:
        assert api.load_controller(Req(name=n)).ok, n
    assert api.switch_controller(Req(start_controllers=list(names), stop_controllers=[],
                                     strictness=SwitchControllerRequest.STRICT)).ok


class FakeGoalHandle(object):
    """actionlib's ServerGoalHandle as the controller uses it."""
    seq = 0

    def __init__(self, goal):
        FakeGoalHandle.seq += 1
        self.goal, self.id, self.events, self.feedbacks = goal, str(FakeGoalHandle.seq), [], 0

    def get_goal(self):
        return self.goal

    def get_goal_id(self):
        return Req(id=self.id)

    def set_accepted(self, text=''):
        self.events.append('accepted')

    def set_rejected(self, result=None, text=''):
        self.events.append(('rejected', result.error_code, result.error_string))

    def set_succeeded(self, result=None, text=''):
        self.events.append(('succeeded', result.error_code))

    def set_aborted(self, result=None, text=''):
        self.events.append(('aborted', result.error_code, result.error_string))

    def set_canceled(self, result=None, text=''):
        self.events.append('canceled')

    def publish_feedback(self, fb):
        self.feedbacks += 1
        assert len(fb.actual.positions) == len(fb.joint_names) == len(fb.desired.positions)


def trajectory_msg(points=GOAL, names=JOINTS):
    import rospy
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    msg = JointTrajectory(joint_names=list(names))
    for t, q in points:
        msg.points.append(JointTrajectoryPoint(positions=list(q),
                                               time_from_start=rospy.Duration.from_sec(t)))
    return msg


def goal_msg(traj, **kw):
    from mobile_device_sim.msg import FollowJointTrajectoryGoal
    return FollowJointTrajectoryGoal(trajectory=traj, **kw)


def reference(t):
    """The linear interpolation of GOAL from the home pose (0) at the goal's start."""
    ts = [0.0] + [p[0] for p in GOAL]
    qs = np.array([[0.0] * 6] + [p[1] for p in GOAL])
    return np.array([np.interp(t, ts, qs[:, i]) for i in range(6)])


def follow(w, plugin, api, via, seconds=4.6):
    """Send GOAL (via 'action' or 'topic') and step; the actual joint positions after each
    step against the reference, and the goal handle."""
    gh = None
    if via == 'action':
        gh = FakeGoalHandle(goal_msg(trajectory_msg()))
        api.goal_cb('arm', gh)
    else:
        api.trajectory_cb('arm', trajectory_msg())
    w.step(1)                          # applied at this step's update, which starts it
    t0 = w.sim_time
    actual, ref = [], []
    for _ in range(int(round(seconds / w.step_size / 10))):
        w.step(10)                     # every step runs the controller; read every 10 ms
        st = w.joint_states('xarm6')
        actual.append([st[j][0] for j in JOINTS])
        ref.append(reference(w.sim_time - t0))
    return np.array(actual), np.array(ref), gh


def check_tracking(actual, ref):
    err = actual - ref
    rms = float(np.sqrt(np.mean(err ** 2)))
    assert rms < 0.01 and np.abs(err[-1]).max() < 0.005, (rms, err[-1])


def test_xarm6_follows_a_3_point_goal_by_action_alike_on_both_engines():
    traces = {}
    for physics in ENGINES:
        w, plugin, api = xarm_world(physics)
        try:
            load_and_start(api, 'arm', 'joint_state_controller')
            actual, ref, gh = follow(w, plugin, api, 'action')
            check_tracking(actual, ref)
            assert gh.events == ['accepted', ('succeeded', SUCCESSFUL)], physics
            assert 80 <= gh.feedbacks <= 100              # action_monitor_rate 20 Hz, 4.6 s
            js = plugin.manager.controllers['joint_state_controller']
            assert js.last[1] == sorted(JOINTS) and js.samples == pytest.approx(230, abs=2)
            traces[physics] = actual
        finally:
            w.shutdown()
    a, b = traces.values()
    assert float(np.sqrt(np.mean((a - b) ** 2))) < 0.01


def test_xarm6_follows_the_goal_sent_on_the_command_topic():
    # the topic's handler; the physics of the tracking is the action test's, on both engines
    w, plugin, api = xarm_world('bullet')
    try:
        load_and_start(api, 'arm')
        actual, ref, _ = follow(w, plugin, api, 'topic')
        check_tracking(actual, ref)
        c = plugin.manager.controllers['arm']
        assert c.goal is None and c.last_state['desired'][0] == pytest.approx(GOAL[-1][1])
    finally:
        w.shutdown()


@pytest.mark.parametrize('physics,seconds', [('ode', 60.0), ('bullet', 10.0)])
def test_xarm6_holds_its_home_pose_for_60_s(physics, seconds):
    # 60 s of sim time in 20 ms steps (3000 steps) on ODE, whose motors alone do not hold
    # the arm (10 s on Bullet, whose do): the hold is the controller's, not the step's; the
    # joints are read every 40 ms
    w, plugin, api = xarm_world(physics, step=0.02)
    try:
        load_and_start(api, 'arm')
        worst_v, worst_q = 0.0, 0.0
        for _ in range(int(round(seconds / 0.04))):
            w.step(2)
            for q, v in w.joint_states('xarm6').values():
                worst_q, worst_v = max(worst_q, abs(q)), max(worst_v, abs(v))
        c = plugin.manager.controllers['arm']
        assert worst_v < 1e-3 and worst_q < 2e-6, (worst_v, worst_q)
        assert max(abs(v) for v in c.last_state['actual'][1]) < 1e-3
        assert w.sim_time == pytest.approx(seconds)
    finally:
        w.shutdown()


BAD_GOALS = [
    ('unknown joint', dict(names=JOINTS[:5] + ['elbow']), INVALID_JOINTS, "'elbow'"),
    ('missing joint', dict(names=JOINTS[:5], points=[(1.0, [0.1] * 5)]), INVALID_JOINTS,
     "don't match"),
    ('times not increasing', dict(points=[(1.0, [0.1] * 6), (1.0, [0.2] * 6)]), INVALID_GOAL,
     'not strictly increasing'),
    ('wrong size', dict(points=[(1.0, [0.1] * 5)]), INVALID_GOAL, '5 positions for 6 joints'),
]


def test_bad_goals_are_rejected_with_ros_controllers_error_codes(caplog):
    w, plugin, api = xarm_world('bullet')
    try:
        load_and_start(api, 'arm')
        for what, kw, code, text in BAD_GOALS:
            caplog.clear()
            gh = FakeGoalHandle(goal_msg(trajectory_msg(**kw)))
            with caplog.at_level(logging.ERROR):
                api.goal_cb('arm', gh)
                w.step(2)
            assert len(gh.events) == 1 and gh.events[0][:2] == ('rejected', code), \
                (what, gh.events)
            assert text in gh.events[0][2], what
            errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
            assert len(errors) == 1 and text in errors[0].getMessage(), what
        # the controller still holds and still takes a good goal
        ok = FakeGoalHandle(goal_msg(trajectory_msg([(0.2, [0.1] * 6)])))
        api.goal_cb('arm', ok)
        w.step(400)
        assert ok.events == ['accepted', ('succeeded', SUCCESSFUL)]
    finally:
        w.shutdown()


def pendulum_api(physics, iface, store):
    """test_control's pendulum with a transmission on its hinge; (world, api) over ``store``."""
    from test_control import pendulum, with_control
    w = World(physics=physics, seed=1)
    w.add_model(with_control(pendulum(), iface, 'hinge'))
    plugin = [p for p in w.find_plugins('pend')
              if p.spec.filename == 'libgazebo_ros_control.so'][0]
    return w, ControllerManagerRos(plugin, serve=False, get_param=store.get)


def test_path_and_goal_tolerances_abort_as_ros_controllers_does():
    """An effort trajectory controller on a pendulum too weak to follow: the goal's
    path_tolerance aborts it (PATH_TOLERANCE_VIOLATED); with no path tolerance, the goal
    tolerance after goal_time does (GOAL_TOLERANCE_VIOLATED)."""
    from mobile_device_sim.msg import JointTolerance
    w, api = pendulum_api('ode', 'EffortJointInterface', {'/weak': {
        'type': 'effort_controllers/JointTrajectoryController', 'joints': ['hinge'],
        'gains': {'hinge': {'p': 2.0, 'd': 0.1}},
        'constraints': {'goal_time': 0.3, 'hinge': {'goal': 0.01}}}})
    try:
        load_and_start(api, 'weak')
        gh = FakeGoalHandle(goal_msg(trajectory_msg([(1.0, [1.0])], ['hinge']),
                                     path_tolerance=[JointTolerance(name='hinge',
                                                                    position=0.05)]))
        api.goal_cb('weak', gh)
        w.step(1500)
        assert gh.events[0] == 'accepted' and gh.events[1][:2] == ('aborted',
                                                                   PATH_TOLERANCE_VIOLATED)
        assert 'hinge path error' in gh.events[1][2]
        gh = FakeGoalHandle(goal_msg(trajectory_msg([(0.5, [1.0])], ['hinge'])))
        api.goal_cb('weak', gh)
        w.step(600)                       # ends at 0.5 s, tolerance 0.3 s
        assert gh.events == ['accepted'], gh.events
        w.step(400)
        assert gh.events[1][:2] == ('aborted', GOAL_TOLERANCE_VIOLATED)
    finally:
        w.shutdown()


def test_effort_trajectory_controller_tracks_with_its_gains():
    w, api = pendulum_api('bullet', 'EffortJointInterface', {'/arm': {
        'type': 'effort_controllers/JointTrajectoryController', 'joints': ['hinge'],
        'gains': {'hinge': {'p': 200.0, 'i': 50.0, 'd': 20.0, 'i_clamp': 5.0}},
        'constraints': {'goal_time': 1.0, 'hinge': {'goal': 0.01}}}})
    try:
        load_and_start(api, 'arm')
        gh = FakeGoalHandle(goal_msg(trajectory_msg([(1.0, [0.5]), (2.0, [0.8])], ['hinge'])))
        api.goal_cb('arm', gh)
        w.step(3000)
        assert gh.events == ['accepted', ('succeeded', SUCCESSFUL)]
        assert abs(w.joint_states('pend')['hinge'][0] - 0.8) < 0.02
    finally:
        w.shutdown()


def test_cubic_and_quintic_interpolation_as_ros_controllers():
    """Velocities make the segment cubic, accelerations quintic; their ends are met."""
    from sim_world.control.trajectory import Segment, State
    s = Segment(0.0, State(0.0, 0.0), 2.0, State(1.0, 0.5))
    assert s.sample(2.0)[:2] == pytest.approx((1.0, 0.5))
    assert s.sample(1.0)[0] == pytest.approx(0.5 - 0.5 * 0.25 / 2 * 0.5, abs=0.2)
    q = Segment(0.0, State(0.0, 0.0, 0.0), 1.0, State(1.0, 0.0, 0.0))
    assert q.sample(0.5) == pytest.approx((0.5, 1.875, 0.0))      # 10t^3-15t^4+6t^5
    lin = Segment(0.0, State(0.0), 2.0, State(1.0))
    assert lin.sample(0.5) == pytest.approx((0.25, 0.5, 0.0))
    assert lin.sample(3.0) == (1.0, 0.0, 0.0) and lin.sample(-1.0) == (0.0, 0.0, 0.0)


def test_controller_manager_services_answer_as_controller_manager(caplog):
    from mobile_device_sim.srv import SwitchControllerRequest
    w, plugin, api = xarm_world('bullet', params={'type': 'position_controllers/'
                                                  'JointTrajectoryController',
                                                  'joints': JOINTS + ['nope']})
    try:
        with caplog.at_level(logging.ERROR):
            assert not api.load_controller(Req(name='arm')).ok
            assert not api.load_controller(Req(name='missing')).ok
        errs = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
        assert len(errs) == 2 and "arm/joints: 'nope' has no transmission" in errs[0]
        assert 'missing' in errs[1]
        assert api.load_controller(Req(name='joint_state_controller')).ok
        lst = api.list_controllers().controller
        assert [(c.name, c.state, c.type) for c in lst] == [
            ('joint_state_controller', 'initialized',
             'joint_state_controller/JointStateController')]
        assert lst[0].claimed_resources[0].hardware_interface == \
            'hardware_interface::JointStateInterface'
        assert not api.switch_controller(Req(start_controllers=['arm'], stop_controllers=[],
                                             strictness=SwitchControllerRequest.STRICT)).ok
        assert api.switch_controller(Req(start_controllers=['arm', 'joint_state_controller'],
                                         stop_controllers=[], strictness=0)).ok
        assert api.list_controllers().controller[0].state == 'running'
        types = api.list_controller_types()
        assert 'position_controllers/JointTrajectoryController' in types.types
        assert 'effort_controllers/JointGroupPositionController' in types.types
        assert set(types.base_classes) == {'controller_interface::ControllerBase'}
        assert not api.unload_controller(Req(name='joint_state_controller')).ok   # running
        assert not api.reload_controller_libraries(Req(force_kill=False)).ok
        assert api.reload_controller_libraries(Req(force_kill=True)).ok
        assert api.list_controllers().controller == []
    finally:
        w.shutdown()


def test_group_controllers_take_float64multiarray_commands(caplog):
    from std_msgs.msg import Float64MultiArray
    w, api = pendulum_api('ode', 'PositionJointInterface', {'/g': {
        'type': 'position_controllers/JointGroupPositionController', 'joints': ['hinge']}})
    try:
        load_and_start(api, 'g')
        api.command_cb('g', Float64MultiArray(data=[0.7]))
        w.step(10)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.7, abs=1e-6)
        with caplog.at_level(logging.ERROR):
            api.command_cb('g', Float64MultiArray(data=[0.1, 0.2]))
        assert 'dimension of command (2) does not match number of joints (1)' in caplog.text
        w.step(10)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.7, abs=1e-6)
    finally:
        w.shutdown()


def test_query_state_samples_the_trajectory():
    import rospy
    w, plugin, api = xarm_world('bullet')
    try:
        load_and_start(api, 'arm')
        api.trajectory_cb('arm', trajectory_msg())
        w.step(1)
        t0 = w.sim_time
        r = api.query_state('arm', Req(time=rospy.Time.from_sec(t0 + 2.5)))
        assert list(r.name) == JOINTS and list(r.position) == pytest.approx(GOAL[1][1])
        w.step(1)
    finally:
        w.shutdown()


def test_spawner_loads_starts_and_on_shutdown_stops_and_unloads():
    from sim_world.control.spawner import Spawner, parse_args, service_names
    calls = []

    class Log(object):
        def info(self, m):
            calls.append(('info', m))
        error = warn = info

    sp = Spawner(lambda n: calls.append(('load', n)) or n != 'bad',
                 lambda start, stop: calls.append(('switch', start, stop)) or True,
                 lambda n: calls.append(('unload', n)) or True, Log())
    assert sp.start(['a', 'bad', 'b'])
    sp.stop()
    ops = [c for c in calls if c[0] != 'info']
    assert ops == [('load', 'a'), ('load', 'bad'), ('load', 'b'), ('switch', ['a', 'b'], []),
                   ('switch', [], ['a', 'b']), ('unload', 'b'), ('unload', 'a')]
    assert ('info', 'Failed to load bad') in calls
    a = parse_args(['--stopped', '--namespace', '/xarm', '--shutdown-timeout', '5', 'arm'])
    assert a.stopped and a.shutdown_timeout == 5.0 and a.controllers == ['arm']
    assert service_names('/xarm/')['load'] == '/xarm/controller_manager/load_controller'
    assert service_names()['switch'] == 'controller_manager/switch_controller'
    assert math.isfinite(parse_args(['x']).timeout)


def test_spawner_takes_yaml_files_of_controllers(tmp_path):
    from sim_world.control.spawner import expand
    f = tmp_path / 'arm.yaml'
    f.write_text('arm:\n  type: position_controllers/JointTrajectoryController\n'
                 '  joints: [joint1]\njsc:\n  type: joint_state_controller/JointStateController\n'
                 '  publish_rate: 50\n')
    put = []
    assert expand([str(f), 'other'], put.append) == ['arm', 'jsc', 'other']
    assert put == [f.read_text()]
    (tmp_path / 'bad.yaml').write_text('- a list\n')
    with pytest.raises(ValueError, match='bad.yaml: not a YAML mapping'):
        expand([str(tmp_path / 'bad.yaml')])


def test_same_goal_same_joint_states_bit_for_bit():
    """Goals are applied in the world's step and nothing reads the wall clock: two runs give
    identical joint states (Bullet, 0.6 s)."""
    runs = []
    for _ in range(2):
        w, plugin, api = xarm_world('bullet')
        try:
            load_and_start(api, 'arm')
            api.goal_cb('arm', FakeGoalHandle(goal_msg(trajectory_msg([(0.2, [0.2] * 6),
                                                                       (0.5, [0.0] * 6)]))))
            out = []
            for _ in range(60):
                w.step(10)
                out.append(sorted(w.joint_states('xarm6').items()))
            runs.append(out)
        finally:
            w.shutdown()
    assert runs[0] == runs[1]
