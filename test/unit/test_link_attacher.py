"""The link attacher (issue 48 parts 4 and 5): gazebo_ros_link_attacher's services on a World
without roscore, the fixed joint in both engines, and the phone held by pybullet_data's
xarm6: it stays within 1 mm of its offset while the arm moves, and its IMU reads the motion.
"""
import logging
import math
import os

import numpy as np
import pytest

from mobile_device_sim.srv import Attach, AttachRequest

from sim_world.attacher import LinkAttacher
from sim_world.physics import ENGINES, make_engine
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

import worlds

PHONE = '''<robot name="phone"><link name="body"><inertial><mass value="0.15"/>
<inertia ixx="2e-4" iyy="1e-4" izz="3e-4"/></inertial>
<collision><geometry><box size="0.07 0.14 0.008"/></geometry></collision></link></robot>'''
#: gazebo_ros_link_attacher's srv/Attach.srv (pal-robotics/gazebo_ros_link_attacher)
UPSTREAM = ('string model_name_1\nstring link_name_1\nstring model_name_2\n'
            'string link_name_2\n---\nbool ok\n')
HOME = {'joint2': -0.3, 'joint3': -0.5, 'joint5': 0.8}
OFFSET = Pose([0.0, 0.0, 0.05])


def xarm6():
    pybullet_data = pytest.importorskip('pybullet_data')
    return load_urdf_file(os.path.join(pybullet_data.getDataPath(), 'xarm',
                                       'xarm6_robot.urdf'))


def phone(pose=None):
    m = parse_urdf(PHONE)
    if pose is not None:
        m.pose = pose
    return m


def arm_holding_phone(e):
    e.add_model(xarm6())
    e.set_joint_positions('xarm6', HOME)
    e.add_model(phone(e.link_pose('xarm6', 'link6') * OFFSET))
    assert e.attach('xarm6', 'link6', 'phone', 'body')


def offset_error(e):
    rel = e.link_pose('xarm6', 'link6').inverse() * e.link_pose('phone', 'body')
    d = float(np.linalg.norm(rel.p - OFFSET.p))
    angle = 2 * math.acos(min(1.0, abs(float(rel.q[3]))))
    return d, angle


def test_attach_srv_is_gazebo_ros_link_attachers():
    """Our srv/Attach.srv is the upstream definition: the same md5sum."""
    from genmsg import MsgContext, msg_loader
    from genmsg.gentools import compute_md5
    ctx = MsgContext.create_default()
    spec = msg_loader.load_srv_from_string(ctx, UPSTREAM, 'gazebo_ros_link_attacher/Attach')
    msg_loader.load_depends(ctx, spec, {})
    assert Attach._md5sum == compute_md5(ctx, spec)


@pytest.mark.parametrize('engine', ENGINES)
def test_phone_held_by_xarm6_link6_stays_within_1_mm(engine, caplog):
    """Each joint follows a sine under a PD effort loop for 1.5 s: the phone held by link6
    keeps its offset within 1 mm and 10 mrad (checked every 10 ms) while it travels."""
    caplog.set_level(logging.ERROR)
    e = make_engine(engine)
    try:
        arm_holding_phone(e)
        start = e.link_pose('phone', 'body').p.copy()
        names = ['joint%d' % i for i in range(1, 7)]
        worst = [0.0, 0.0]
        travel = 0.0
        for k in range(1500):
            t = k * e.step_size
            for i, jn in enumerate(names):
                q, v = e.joint_state('xarm6', jn)
                target = HOME.get(jn, 0.0) + 0.5 * math.sin(math.pi * t) * (-1) ** i
                e.apply_joint_effort('xarm6', jn, 400 * (target - q) - 20 * v, steps=1,
                                     key='pd')
            e.step()
            if k % 10 == 9:
                d, a = offset_error(e)
                worst = [max(worst[0], d), max(worst[1], a)]
                travel = max(travel, float(np.linalg.norm(e.link_pose('phone', 'body').p
                                                          - start)))
        assert travel > 0.1, 'the arm hardly moved the phone'
        assert worst[0] < 1e-3, worst
        assert worst[1] < 1e-2, worst       # ODE's fixed joint: ~5 mrad (ERP 0.2)
        assert e.detach('xarm6', 'link6', 'phone', 'body')
        assert e.attachments() == []
    finally:
        e.close()


@pytest.mark.parametrize('engine', ENGINES)
def test_the_held_phone_is_carried_regripped_and_let_go(engine, caplog):
    caplog.set_level(logging.ERROR)
    e = make_engine(engine, gravity=(0, 0, -9.81))
    try:
        arm_holding_phone(e)
        # set_model_configuration: the phone is carried along at once, at rest, by the same
        # joint (a kinematic controller moves the arm every step: nothing is remade)
        native = e._attached.items[0].native
        e.set_joint_positions('xarm6', {'joint1': 1.0})
        assert offset_error(e)[0] < 1e-9
        assert e._attached.items[0].native is native
        # teleporting the held phone holds it again where it is put
        put = e.link_pose('xarm6', 'link6') * Pose([0.0, 0.1, 0.05])
        e.set_model_pose('phone', put)
        e.set_joint_positions('xarm6', {'joint1': 0.5})
        rel = e.link_pose('xarm6', 'link6').inverse() * e.link_pose('phone', 'body')
        assert rel.p == pytest.approx([0.0, 0.1, 0.05], abs=1e-9)
        # attaching twice changes nothing; the reverse order is another attachment: refused
        assert not e.attach('xarm6', 'link6', 'phone', 'body')
        with pytest.raises(ValueError, match='attached already'):
            e.attach('phone', 'body', 'xarm6', 'link6')
        # let go: gravity takes the phone, the arm moves on without it
        assert e.detach('xarm6', 'link6', 'phone', 'body')
        assert not e.detach('xarm6', 'link6', 'phone', 'body')
        z = e.link_pose('phone', 'body').p[2]
        e.step(200)
        assert e.link_pose('phone', 'body').p[2] < z - 0.1
        # removing a model drops its attachments
        e.attach('xarm6', 'link6', 'phone', 'body')
        e.remove_model('phone')
        assert e.attachments() == []
        e.step(10)
    finally:
        e.close()


@pytest.mark.parametrize('engine', ENGINES)
def test_a_static_model_holds_the_phone_in_place(engine):
    e = make_engine(engine)
    try:
        shelf = parse_urdf('<robot name="shelf"><link name="top"><collision><geometry>'
                           '<box size="1 1 0.1"/></geometry></collision></link></robot>')
        shelf.static = True
        e.add_model(shelf)
        e.add_model(phone(Pose([0.0, 0.0, 0.3])))
        assert e.attach('shelf', 'top', 'phone', 'body')
        e.step(300)
        assert e.link_pose('phone', 'body').p == pytest.approx([0.0, 0.0, 0.3], abs=1e-3)
        sign = parse_urdf(PHONE.replace('phone', 'sign'))
        sign.static = True
        e.add_model(sign)
        with pytest.raises(ValueError, match='both static'):
            e.attach('shelf', 'top', 'sign', 'body')
        assert e.detach('shelf', 'top', 'phone', 'body')
        e.step(300)
        assert e.link_pose('phone', 'body').p[2] < 0.2
    finally:
        e.close()


def test_bullet_refuses_two_one_body_models_by_name():
    e = make_engine('bullet')
    try:
        e.add_model(phone(Pose([0.0, 0.0, 1.0])))
        e.add_model(parse_urdf(PHONE.replace('phone', 'hand')))
        with pytest.raises(ValueError, match="models 'hand' and 'phone'.*ode"):
            e.attach('hand', 'body', 'phone', 'body')
        assert e.attachments() == []
        e.step(10)
    finally:
        e.close()


def _world(engine):
    w = World(physics=engine, seed=1)
    w.add_model(xarm6())
    w.physics.set_joint_positions('xarm6', HOME)
    w.add_model(phone(w.link_pose('xarm6', 'link6') * OFFSET))
    return w


class _Api(object):
    def __init__(self, world):
        self.world = world


def req(m1='xarm6', l1='link6', m2='phone', l2='body'):
    return AttachRequest(model_name_1=m1, link_name_1=l1, model_name_2=m2, link_name_2=l2)


@pytest.mark.parametrize('engine', ENGINES)
def test_services_answer_and_refuse_bad_input_in_one_line(engine, caplog):
    caplog.set_level(logging.ERROR)
    w = _world(engine)
    lines = []
    try:
        svc = LinkAttacher(_Api(w), serve=False, log=lines.append)
        bad = [
            (req(m1='nope'), "no model named 'nope'"),
            (req(l1='claw'), "no link 'claw'"),
            (req(m2=''), 'no model name given'),
            (req(m2='xarm6', l2='link6'), 'cannot be attached to itself'),
            (req(m2='xarm6', l2='link2'), 'both of model'),
        ]
        for r, words in bad:
            n = len(lines)
            assert svc.attach(r).ok is False
            assert len(lines) == n + 1 and words in lines[-1], (words, lines[n:])
        n = len(lines)
        assert svc.detach(req()).ok is False
        assert len(lines) == n + 1 and 'no such attachment' in lines[-1]
        assert w.physics.attachments() == []
        assert svc.attach(req()).ok is True
        assert svc.attach(req()).ok is True           # again: nothing changes
        assert w.physics.attachments() == [('xarm6', 'link6', 'phone', 'body')]
        w.step(100)
        assert svc.detach(req()).ok is True
        # reset_world lets go of everything
        assert svc.attach(req()).ok is True
        w.reset()
        assert w.physics.attachments() == []
        w.step(10)
        assert all(np.all(np.isfinite(p.p)) for p in w.link_poses('xarm6').values())
    finally:
        w.shutdown()


@pytest.mark.parametrize('engine', ENGINES)
def test_the_held_phones_imu_reads_the_arms_motion(engine, caplog):
    """The real phone (model mobile_device, its IMU plugin) held by link6 while joint1
    turns at 0.5 rad/s (no gravity): the gyro reads link6's angular velocity in the phone's frame."""
    from simsensors.imu import ImuPlugin
    caplog.set_level(logging.ERROR)
    w = worlds.make_world(engine, phone=(0.0, 0.0, 0.0),
                          gravity=(0.0, 0.0, 0.0))
    try:
        w.add_model(xarm6())
        w.physics.set_joint_positions('xarm6', HOME)
        w.set_state('mobile_device', w.link_pose('xarm6', 'link6') * OFFSET)
        root = w.models['mobile_device'].root_link
        assert w.physics.attach('xarm6', 'link6', 'mobile_device', root)
        imu = worlds.plugin_of(w, ImuPlugin, 'mobile_device')
        imu.force = True
        w.physics.set_joint_dynamics('xarm6', 'joint1', damping=0.0, friction=0.0)
        w.physics.set_joint_velocity('xarm6', 'joint1', 0.5)
        w.step(200)
        pose, _lin, ang = w.entity_state('xarm6::link6')
        gyro = imu.last[1]
        assert np.linalg.norm(ang) > 0.3
        imu_pose = w.entity_state('mobile_device')[0]
        expected = imu_pose.inverse().rotate(ang)
        assert gyro == pytest.approx(expected, abs=0.05)
    finally:
        w.shutdown()
