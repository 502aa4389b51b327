"""gazebo_ros_control's DefaultRobotHWSim beyond the plain interfaces (issue 48 part 4): PID
gains for position and velocity interfaces (``<ns>/gazebo_ros_control/pid_gains/<joint>``)
and the e-stop (``eStopTopic``), on both engines. No roscore."""
import logging
import math

import pytest

from test_control import physics, run, with_control  # noqa: F401 (physics: a fixture)
from test_joints import pendulum, rotor

GAINS = {'p': 100.0, 'i': 200.0, 'd': 10.0, 'i_clamp': 10.0}
POS = ('arm', {'type': 'position_controllers/JointPositionController', 'joint': 'hinge'})


def gravity_torque(q):
    return 1.0 * 9.81 * 0.5 * math.sin(q)        # the pendulum's m g L sin(q)


def test_position_pid_gains_drive_the_joint_by_an_effort(physics):
    w, plugin = run(physics, with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    POS)
    try:
        assert plugin.set_pid_gains({'hinge': GAINS}) == ['hinge']
        assert plugin.manager.set_command('arm', 0.8)[0]
        w.step(2)
        q = w.joint_states('pend')['hinge'][0]
        assert 0.0 < q < 0.2               # on its way, not set there as a kinematic joint is
        w.step(3000)
        q, v = w.joint_states('pend')['hinge']
        assert abs(q - 0.8) < 0.002 and abs(v) < 0.01
        # it holds against gravity with the gravity torque, as an effort joint would
        assert plugin.hw.efforts['hinge'] == pytest.approx(gravity_torque(q), rel=0.05)
    finally:
        w.shutdown()


def test_without_gains_the_position_joint_is_kinematic(physics):
    w, plugin = run(physics, with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    POS)
    try:
        plugin.manager.set_command('arm', 0.8)
        w.step(2)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.8, abs=1e-6)
        assert 'hinge' not in plugin.hw.efforts
    finally:
        w.shutdown()


def test_velocity_pid_gains_reach_the_velocity_through_the_wheels_inertia(physics):
    w, plugin = run(physics, with_control(rotor(effort=5.0), 'VelocityJointInterface', 'spin'),
                    0, ('spin_ctrl', {'type': 'velocity_controllers/JointVelocityController',
                                      'joint': 'spin'}))
    try:
        assert plugin.set_pid_gains({'spin': {'p': 20.0}}) == ['spin']
        plugin.manager.set_command('spin_ctrl', 2.0)
        w.step(20)
        v = w.joint_states('rotor')['spin'][1]
        # the effort is clamped to 5 N m: 0.5 kg m^2 reach at most 5/0.5 * 0.02 = 0.2 rad/s
        assert 0.0 < v <= 0.21
        assert plugin.hw.efforts['spin'] == pytest.approx(5.0)
        w.step(2000)
        assert w.joint_states('rotor')['spin'][1] == pytest.approx(2.0, abs=0.02)
    finally:
        w.shutdown()


def test_bad_gains_are_one_line_each_and_the_joint_stays_kinematic(physics, caplog):
    w, plugin = run(physics, with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    POS)
    try:
        with caplog.at_level(logging.ERROR):
            assert plugin.set_pid_gains({'hinge': {'i': 1.0}}) == []
            assert plugin.set_pid_gains({'hinge': {'p': 'strong'}}) == []
            assert plugin.set_pid_gains({'nope': GAINS}) == []
            assert plugin.set_pid_gains(['hinge']) == []
        lines = [r.getMessage() for r in caplog.records]
        assert len(lines) == 4, lines
        assert 'gazebo_ros_control/pid_gains/hinge/p is missing' in lines[0]
        assert "pid_gains/hinge/p must be a number, got 'strong'" in lines[1]
        assert "'nope'" in lines[2] and 'no position or velocity interface' in lines[2]
        assert 'must be a dict' in lines[3]
        plugin.manager.set_command('arm', 0.5)
        w.step(2)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.5, abs=1e-6)
    finally:
        w.shutdown()


def test_e_stop_holds_positions_zeroes_efforts_and_restarts_the_controllers(physics):
    w, plugin = run(physics, with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    POS)
    try:
        plugin.manager.set_command('arm', 0.5)
        w.step(200)
        plugin.e_stop(True)
        plugin.manager.set_command('arm', 1.2)          # ignored while the e-stop is on
        w.step(500)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.5, abs=1e-3)
        plugin.e_stop(False)                             # restarted: holds where it is
        w.step(200)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(0.5, abs=1e-3)
        assert plugin.manager.controllers['arm'].command == pytest.approx(0.5, abs=1e-3)
        plugin.manager.set_command('arm', 1.2)
        w.step(2)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(1.2, abs=1e-6)
    finally:
        w.shutdown()


def test_e_stop_zeroes_efforts_and_velocities(physics):
    w, plugin = run(physics, with_control(rotor(), 'EffortJointInterface', 'spin'), 0,
                    ('push', {'type': 'effort_controllers/JointEffortController',
                              'joint': 'spin'}))
    try:
        plugin.manager.set_command('push', 1.0)
        w.step(500)
        v0 = w.joint_states('rotor')['spin'][1]
        assert v0 == pytest.approx(1.0, rel=0.05)          # 1 N m / 0.5 kg m^2 for 0.5 s
        plugin.e_stop(True)
        w.step(500)
        assert plugin.hw.efforts['spin'] == 0.0
        # no effort: the wheel coasts at the speed it had
        assert w.joint_states('rotor')['spin'][1] == pytest.approx(v0, rel=0.02)
    finally:
        w.shutdown()


# -- the trajectory controllers' velocity variant and stop_trajectory_duration --------------
def _jtc(kind, joint, **extra):
    params = {'type': '%s_controllers/JointTrajectoryController' % kind, 'joints': [joint]}
    params.update(extra)
    return params


def test_velocity_trajectory_controller_follows_a_trajectory(physics):
    from sim_world.control.trajectory import Point, Trajectory
    w, plugin = run(physics, with_control(rotor(), 'VelocityJointInterface', 'spin'), 0,
                    ('traj', _jtc('velocity', 'spin', gains={'spin': {'p': 20.0}},
                                  velocity_ff={'spin': 1.0})))
    try:
        c = plugin.manager.controllers['traj']
        assert c.TYPE in dict((t[1], 1) for t in plugin.manager.list_controllers())
        c.submit_command(Trajectory(['spin'], [Point([1.0], [0.0], [], 1.0),
                                               Point([2.0], [0.0], [], 2.0)]))
        w.step(1000)
        q, v = w.joint_states('rotor')['spin']
        assert q == pytest.approx(1.0, abs=0.02)
        w.step(1500)
        q, v = w.joint_states('rotor')['spin']
        assert q == pytest.approx(2.0, abs=0.01) and abs(v) < 0.05
    finally:
        w.shutdown()


def test_velocity_trajectory_controller_needs_gains(physics, caplog):
    w, plugin = run(physics, with_control(rotor(), 'VelocityJointInterface', 'spin'), 0)
    try:
        with caplog.at_level(logging.ERROR):
            ok, msg = plugin.manager.load_controller('traj', _jtc('velocity', 'spin'))
            assert not ok and 'traj/gains is missing' in msg
            ok, msg = plugin.manager.load_controller(
                'traj', _jtc('velocity', 'spin', gains={'spin': {'p': 1.0}}, velocity_ff=[1]))
            assert not ok and 'traj/velocity_ff must be a dict' in msg
    finally:
        w.shutdown()


@pytest.mark.parametrize('stop', [0.0, 0.5])
def test_stop_trajectory_duration_brings_a_moving_joint_to_rest(stop):
    from sim_world.control.trajectory import Point, Trajectory
    w, plugin = run('ode', with_control(pendulum(), 'PositionJointInterface', 'hinge'), 0,
                    ('traj', _jtc('position', 'hinge', stop_trajectory_duration=stop)))
    try:
        c = plugin.manager.controllers['traj']
        c.submit_command(Trajectory(['hinge'], [Point([0.0], [], [], 0.0),
                                                Point([2.0], [], [], 1.0)]))
        w.step(500)                                       # halfway: 1 rad, 2 rad/s
        q0 = w.joint_states('pend')['hinge'][0]
        assert q0 == pytest.approx(1.0, abs=0.01)
        c.submit_command(Trajectory(['hinge'], []))       # empty: stop and hold
        w.step(250)
        q_mid = w.joint_states('pend')['hinge'][0]
        w.step(500)
        q1 = w.joint_states('pend')['hinge'][0]
        if stop == 0:
            assert q_mid == pytest.approx(q0, abs=0.01) and q1 == pytest.approx(q0, abs=0.01)
        else:
            # rest 5/8 v T further on, reached smoothly (still moving halfway)
            assert q0 + 0.01 < q_mid < q1
            assert q1 == pytest.approx(q0 + 0.625 * 2.0 * stop, abs=0.02)
        w.step(200)
        assert w.joint_states('pend')['hinge'][0] == pytest.approx(q1, abs=1e-3)
    finally:
        w.shutdown()
