"""ros_control in the simulator (issue 48 part 4): libgazebo_ros_control.so reads the URDF's
transmissions, its controller manager (sim_world.control.controllers) runs the
ros_controllers types every physics step in sim time, on both engines. No roscore."""
import logging
import math

import pytest

from sim_world.control.controllers import ControllerManager, Pid
from sim_world.physics import ENGINES
from sim_world.urdf import parse_urdf
from sim_world.world import World

from test_joints import pendulum, rotor

PLUGIN = '<gazebo><plugin name="ros_control" filename="libgazebo_ros_control.so"/></gazebo>'


def transmission(joint, iface):
    return ('<transmission name="t_%s"><type>transmission_interface/SimpleTransmission</type>'
            '<joint name="%s"><hardwareInterface>hardware_interface/%s</hardwareInterface></joint>'
            '<actuator name="m_%s"><mechanicalReduction>50</mechanicalReduction></actuator>'
            '</transmission>' % (joint, joint, iface, joint))


def with_control(model, iface, joint):
    return parse_urdf(model.source_xml.replace(
        '</robot>', transmission(joint, iface) + PLUGIN + '</robot>'))


def control_plugin(w, name):
    return [p for p in w.find_plugins(name)
            if p.spec.filename == 'libgazebo_ros_control.so'][0]


@pytest.fixture(params=ENGINES)
def physics(request):
    return request.param


def run(physics, model, seconds, *spawns):
    w = World(physics=physics, seed=1)
    w.add_model(model)
    plugin = control_plugin(w, model.name)
    for name, params in spawns:
        ok, msg = plugin.spawn(name, params)
        assert ok, msg
    return w, plugin


def test_pid_position_controller_brings_the_pendulum_to_the_setpoint(physics):
    w, plugin = run(physics, with_control(pendulum(), 'EffortJointInterface', 'hinge'), 0,
                    ('arm', {'type': 'effort_controllers/JointPositionController',
                             'joint': 'hinge', 'pid': {'p': 60.0, 'i': 20.0, 'd': 6.0,
                                                       'i_clamp': 10.0}}),
                    ('state', {'type': 'joint_state_controller/JointStateController',
                               'publish_rate': 50}))
    try:
        assert plugin.manager.set_command('arm', 0.8)[0]
        w.step(4000)                          # 4 s of sim time
        q, v = w.joint_states('pend')['hinge']
        # gravity pulls at m g L sin(0.8) = 3.5 N m: the integral holds it without offset
        assert abs(q - 0.8) < 0.01 and abs(v) < 0.05
        js = plugin.manager.controllers['state']
        assert js.samples == pytest.approx(200, abs=1)
        t, names, pos, vel, eff = js.last
        assert names == ['hinge'] and abs(pos[0] - q) < 0.01
        # the effort it holds with is the gravity torque
        assert eff[0] == pytest.approx(1.0 * 9.81 * 0.5 * math.sin(0.8), rel=0.05)
    finally:
        w.shutdown()


def test_pid_without_integral_leaves_the_gravity_offset(physics):
    w, plugin = run(physics, with_control(pendulum(), 'EffortJointInterface', 'hinge'), 0,
                    ('arm', {'type': 'effort_controllers/JointPositionController',
                             'joint': 'hinge', 'pid': {'p': 60.0, 'd': 6.0}}))
    try:
        plugin.manager.set_command('arm', 0.8)
        w.step(3000)
        q = w.joint_states('pend')['hinge'][0]
        # p e = m g L sin q: the steady-state error of a P(D) controller
        assert 0.02 < 0.8 - q < 0.1
        assert 60.0 * (0.8 - q) == pytest.approx(9.81 * 0.5 * math.sin(q), rel=0.05)
    finally:
        w.shutdown()


def test_velocity_controller_holds_a_speed(physics):
    w, plugin = run(physics, with_control(pendulum(), 'VelocityJointInterface', 'hinge'), 0,
                    ('spin', {'type': 'velocity_controllers/JointVelocityController',
                              'joint': 'hinge'}))
    try:
        plugin.manager.set_command('spin', 2.0)
        q0 = w.joint_states('pend')['hinge'][0]
        w.step(1000)
        q, v = w.joint_states('pend')['hinge']
        assert abs(v - 2.0) < 0.05
        assert (q - q0) == pytest.approx(2.0, abs=0.05)   # against gravity all the way round
    finally:
        w.shutdown()


def test_position_controller_without_pid_is_kinematic(physics):
    w, plugin = run(physics, with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    ('pos', {'type': 'position_controllers/JointPositionController',
                             'joint': 'hinge'}))
    try:
        plugin.manager.set_command('pos', 1.2)
        w.step(200)
        q, v = w.joint_states('pend')['hinge']
        assert abs(q - 1.2) < 0.01
    finally:
        w.shutdown()


def test_effort_is_clamped_to_the_joint_limit(physics):
    # wheel: 0.5 kg m^2 about z, no gravity torque; limit 5 N m -> 10 rad/s^2 at most
    w, plugin = run(physics, with_control(rotor(effort=5.0), 'EffortJointInterface', 'spin'), 0,
                    ('push', {'type': 'effort_controllers/JointEffortController', 'joint': 'spin'}))
    try:
        plugin.manager.set_command('push', 1000.0)
        w.step(500)
        v = w.joint_states('rotor')['spin'][1]
        assert v == pytest.approx(10.0 * 0.5, rel=0.05)
        assert plugin.hw.state('spin')[2] == 5.0
    finally:
        w.shutdown()


BAD = [
    ({'joint': 'hinge'}, 'arm/type is missing'),
    ({'type': 'effort_controllers/Nope', 'joint': 'hinge'}, "arm/type 'effort_controllers/Nope'"),
    ({'type': 'effort_controllers/JointPositionController'}, 'arm/joint is missing'),
    ({'type': 'effort_controllers/JointPositionController', 'joint': 'elbow', 'pid': {'p': 1}},
     "arm/joint: 'elbow' has no transmission"),
    ({'type': 'effort_controllers/JointPositionController', 'joint': 'hinge'}, 'arm/pid is missing'),
    ({'type': 'effort_controllers/JointPositionController', 'joint': 'hinge',
      'pid': {'p': 'x'}}, 'arm/pid/p must be a number'),
    ({'type': 'effort_controllers/JointPositionController', 'joint': 'hinge',
      'pid': {'p': 1, 'i_clamp': -1}}, 'arm/pid/i_clamp must be >= 0'),
    ({'type': 'velocity_controllers/JointVelocityController', 'joint': 'hinge'},
     "arm/joint: joint 'hinge' has no VelocityJointInterface"),
    ({'type': 'joint_state_controller/JointStateController'}, 'arm/publish_rate is missing'),
]


@pytest.mark.parametrize('params,text', BAD)
def test_bad_parameters_are_one_error_naming_them_and_the_others_keep_running(params, text,
                                                                               caplog):
    w, plugin = run('ode', with_control(pendulum(), 'EffortJointInterface', 'hinge'), 0,
                    ('hold', {'type': 'effort_controllers/JointPositionController',
                              'joint': 'hinge', 'pid': {'p': 60.0, 'i': 20, 'd': 6.0,
                                                        'i_clamp': 10}}))
    try:
        plugin.manager.set_command('hold', 0.5)
        with caplog.at_level(logging.ERROR):
            ok, msg = plugin.spawn('arm', params)
        assert not ok and text in msg
        errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
        assert len(errors) == 1 and text in errors[0].getMessage()
        assert 'arm' not in plugin.manager.controllers
        w.step(3000)
        assert abs(w.joint_states('pend')['hinge'][0] - 0.5) < 0.01
    finally:
        w.shutdown()


def test_two_controllers_on_one_joint_are_refused_and_a_switch_frees_it():
    w, plugin = run('ode', with_control(pendulum(), 'EffortJointInterface', 'hinge'), 0,
                    ('a', {'type': 'effort_controllers/JointEffortController', 'joint': 'hinge'}))
    try:
        m = plugin.manager
        assert m.load_controller('b', {'type': 'effort_controllers/JointPositionController',
                                       'joint': 'hinge', 'pid': {'p': 30, 'd': 3}})[0]
        ok, msg = m.switch_controller(start=['b'])
        assert not ok and "'hinge'" in msg
        assert m.switch_controller(start=['b'], stop=['a'])[0]
        assert [(n, s) for n, _, s, _ in m.list_controllers()] == [('a', 'stopped'), ('b', 'running')]
        assert not m.unload_controller('b')[0] and m.unload_controller('a')[0]
    finally:
        w.shutdown()


def test_no_transmission_is_a_warning_and_a_bad_one_an_error_the_model_stays(caplog):
    w = World(physics='ode', seed=1)
    try:
        with caplog.at_level(logging.WARNING):
            w.add_model(parse_urdf(pendulum().source_xml.replace('</robot>', PLUGIN + '</robot>')))
        assert 'pend' in w.models and 'no <transmission>' in caplog.text
        ok, msg = control_plugin(w, 'pend').spawn(
            'c', {'type': 'effort_controllers/JointEffortController', 'joint': 'hinge'})
        assert not ok and "'hinge' has no transmission (joints with one: none)" in msg
        caplog.clear()
        bad = transmission('hinge', 'TorqueInterface')
        with caplog.at_level(logging.ERROR):
            w.add_model(parse_urdf(rotor().source_xml.replace('</robot>', bad + PLUGIN + '</robot>')))
        assert 'rotor' in w.models and "'hardware_interface/TorqueInterface'" in caplog.text
    finally:
        w.shutdown()


def test_pid_integral_is_clamped():
    pid = Pid(p=0.0, i=10.0, d=0.0, i_clamp_min=-2.0, i_clamp_max=2.0)
    for _ in range(100):
        out = pid.compute(1.0, 0.0, 0.01)
    assert out == 2.0
    pid = Pid(p=2.0, i=0.0, d=0.5)
    assert pid.compute(1.0, -4.0, 0.01) == pytest.approx(0.0)


class FakeHW(object):
    interfaces = {'j': {'effort'}}

    def __init__(self):
        self.sent = []

    def all_joints(self):
        return ['j']

    def state(self, j):
        return 0.0, 0.0, 0.0

    def limits(self, j):
        return -1.0, 1.0, 10.0

    def joint_type(self, j):
        return 'revolute'

    def command(self, j, kind, v):
        self.sent.append((kind, v))

    def release(self, j):
        pass

    def write(self):
        pass


def test_manager_core_needs_no_world_and_clamps_the_setpoint_to_the_limits():
    hw = FakeHW()
    m = ControllerManager(hw)
    assert m.spawn('c', {'type': 'effort_controllers/JointPositionController', 'joint': 'j',
                         'pid': {'p': 3.0}})[0]
    m.set_command('c', 5.0)                 # above upper = 1
    m.update(0.001, 0.001)
    assert hw.sent == [('effort', pytest.approx(3.0))]
    assert not m.set_command('c', float('nan'))[0]


def test_a_controller_that_fails_is_stopped_and_frees_its_joint(caplog):
    hw = FakeHW()
    m = ControllerManager(hw)
    assert m.spawn('c', {'type': 'effort_controllers/JointEffortController', 'joint': 'j'})[0]
    c = m.controllers['c']

    def broken(t, dt):
        raise RuntimeError('boom')
    c.update = broken
    with caplog.at_level(logging.ERROR):
        m.update(0.001, 0.001)
    assert 'controller c failed at t=0.001 (RuntimeError: boom); stopped' in caplog.text
    assert m.list_controllers() == [('c', 'effort_controllers/JointEffortController',
                                     'stopped', ['j'])] and c.state == 'stopped'
    assert m.spawn('d', {'type': 'effort_controllers/JointEffortController', 'joint': 'j'})[0]
