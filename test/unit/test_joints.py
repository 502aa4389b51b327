"""Articulated models (issue 48): joints as Gazebo's URDF converter reads them, simulated in
both engines, checked against the physics they should follow. No roscore.

Pendulum: a rod of mass m whose centre of mass hangs L below a hinge; its period at
amplitude a is 2 pi sqrt(I_p / (m g L)) (1 + a^2/16 + 11 a^4/3072), I_p = I_c + m L^2.
"""
import logging
import math

import numpy as np
import pytest

from sim_world.model import ModelError
from sim_world.physics import ENGINES, make_engine
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

G = 9.81
M, L, IC = 1.0, 0.5, 0.02          # kg, m, kg m^2 about the centre of mass (y axis)
IP = IC + M * L * L


def pendulum(damping=0.0, extra=''):
    return parse_urdf('''<robot name="pend"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 2"/></joint>
<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
<joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/><axis xyz="0 1 0"/>
<dynamics damping="%g"/></joint>
<link name="rod"><inertial><origin xyz="0 0 -%g"/><mass value="%g"/>
<inertia ixx="%g" iyy="%g" izz="0.001"/></inertial>
<collision><origin xyz="0 0 -%g"/><geometry><sphere radius="0.05"/></geometry></collision></link>
%s</robot>''' % (damping, L, M, IC, IC, L, extra))


def door(friction=0.0, effort=100.0):
    return parse_urdf('''<robot name="door"><link name="world"/>
<joint name="frame" type="fixed"><parent link="world"/><child link="post"/></joint>
<link name="post"><inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1"/></inertial></link>
<joint name="hinge" type="revolute"><parent link="post"/><child link="leaf"/><axis xyz="0 0 1"/>
<limit lower="0" upper="1.5" effort="%g" velocity="10"/><dynamics friction="%g"/></joint>
<link name="leaf"><inertial><origin xyz="0.45 0 1"/><mass value="10"/>
<inertia ixx="1" iyy="1" izz="0.7"/></inertial>
<collision><origin xyz="0.45 0 1"/><geometry><box size="0.9 0.04 2"/></geometry></collision></link>
</robot>''' % (effort, friction))


def rotor(effort=-1.0):
    lim = '<limit effort="%g" velocity="1000"/>' % effort if effort >= 0 else ''
    return parse_urdf('''<robot name="rotor"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 1"/></joint>
<link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
<joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 0 1"/>%s</joint>
<link name="wheel"><inertial><mass value="2"/><inertia ixx="0.5" iyy="0.5" izz="0.5"/></inertial></link>
</robot>''' % lim)


@pytest.fixture(params=ENGINES)
def engine(request):
    e = make_engine(request.param, step_size=0.001)
    yield e
    e.close()


def swing(e, amplitude, seconds):
    e.set_joint_positions('pend', {'hinge': amplitude})
    qs = []
    for _ in range(int(round(seconds / e.step_size))):
        e.step()
        qs.append(e.joint_state('pend', 'hinge')[0])
    return np.array(qs)


def crossings(qs, dt):
    """Times of downward zero crossings, linearly interpolated."""
    out = []
    for i in range(1, len(qs)):
        if qs[i - 1] > 0 >= qs[i]:
            out.append((i - 1 + qs[i - 1] / (qs[i - 1] - qs[i])) * dt)
    return np.array(out)


def period_of(e, amplitude=0.3, swings=10):
    e.add_model(pendulum())
    t0 = 2 * math.pi * math.sqrt(IP / (M * G * L))
    qs = swing(e, amplitude, t0 * (swings + 0.6))
    c = crossings(qs, e.step_size)
    assert len(c) >= swings
    return (c[-1] - c[0]) / (len(c) - 1), qs, t0


def test_pendulum_period_and_amplitude(engine):
    a = 0.3
    period, qs, t0 = period_of(engine, a)
    expected = t0 * (1 + a * a / 16 + 11 * a ** 4 / 3072)
    assert period == pytest.approx(expected, rel=0.01)
    n = int(round(t0 / engine.step_size))
    first, last = qs[:n].max(), qs[-n:].max()
    assert abs(last - first) / first < 0.01


def test_pendulum_damping_decay(engine):
    c = 0.05
    engine.add_model(pendulum(damping=c))
    qs = swing(engine, 0.2, 8.0)
    n = len(qs)
    peaks = [(i, qs[i]) for i in range(1, n - 1) if qs[i - 1] < qs[i] >= qs[i + 1] and qs[i] > 0]
    (i0, p0), (i1, p1) = peaks[0], peaks[-1]
    rate = math.log(p0 / p1) / ((i1 - i0) * engine.step_size)
    assert rate == pytest.approx(c / (2 * IP), rel=0.05)


def test_engines_agree_on_the_period():
    periods = []
    for name in ENGINES:
        e = make_engine(name)
        periods.append(period_of(e, 0.3, 5)[0])
        e.close()
    assert abs(periods[0] - periods[1]) / periods[0] < 0.005


def test_door_limits_hold_under_20_nm(engine):
    engine.add_model(door())
    engine.apply_joint_effort('door', 'hinge', 20.0, steps=2000)
    engine.step(2000)
    q = engine.joint_state('door', 'hinge')[0]
    assert abs(q - 1.5) < 0.01
    engine.apply_joint_effort('door', 'hinge', -20.0, steps=3000)
    engine.step(3000)
    assert abs(engine.joint_state('door', 'hinge')[0]) < 0.01
    # the leaf moved with the joint: its far edge is where the hinge angle says
    engine.set_joint_positions('door', {'hinge': 1.0})
    tip = engine.link_pose('door', 'leaf') * np.array([0.9, 0.0, 0.0])
    assert tip == pytest.approx([0.9 * math.cos(1.0), 0.9 * math.sin(1.0), 0.0], abs=1e-4)


def test_door_friction(engine):
    f = 2.0
    engine.add_model(door(friction=f))
    engine.set_joint_positions('door', {'hinge': 0.5})
    engine.apply_joint_effort('door', 'hinge', 0.5 * f, steps=500)
    engine.step(500)
    assert abs(engine.joint_state('door', 'hinge')[0] - 0.5) < 1e-3
    engine.apply_joint_effort('door', 'hinge', 2 * f, steps=500)
    engine.step(500)
    assert engine.joint_state('door', 'hinge')[0] - 0.5 > 0.02


def test_continuous_joint_does_not_wrap(engine):
    engine.add_model(rotor())
    engine.set_joint_velocity('rotor', 'spin', 1.0)
    engine.step(10000)
    q, v = engine.joint_state('rotor', 'spin')
    assert q == pytest.approx(10.0, abs=0.01)
    assert v == pytest.approx(1.0, abs=1e-3)


def test_effort_is_clamped_to_the_limit(engine):
    engine.add_model(rotor(effort=20.0))
    engine.apply_joint_effort('rotor', 'spin', 1e6, steps=100)
    engine.step(100)
    # 20 N m on 0.5 kg m^2 for 0.1 s
    assert engine.joint_state('rotor', 'spin')[1] == pytest.approx(20 * 0.1 / 0.5, rel=0.01)


def test_no_push_beyond_the_velocity_limit(engine):
    m = rotor(effort=20.0)
    m.joint('spin').velocity = 1.0
    engine.add_model(m)
    engine.apply_joint_effort('rotor', 'spin', 20.0)
    engine.step(1000)
    assert engine.joint_state('rotor', 'spin')[1] < 1.0 + 20 / 0.5 * 0.001 * 1.5


def test_same_seed_same_joint_states(engine):
    def run():
        e = make_engine(engine.name)
        e.add_model(pendulum(damping=0.01))
        e.set_joint_positions('pend', {'hinge': 0.7})
        out = []
        for _ in range(300):
            e.step()
            out.append(e.joint_state('pend', 'hinge'))
        e.close()
        return out
    assert run() == run()


def test_set_model_pose_moves_the_tree_and_reset(engine):
    m = pendulum()
    m.joint('hinge').initial = 0.2
    engine.add_model(m)
    assert engine.joint_state('pend', 'hinge')[0] == pytest.approx(0.2, abs=1e-9)
    engine.step(200)
    before = engine.link_poses('pend')
    engine.set_model_pose('pend', Pose((1.0, 2.0, 0.0)))
    after = engine.link_poses('pend')
    for ln in before:
        assert after[ln].p - before[ln].p == pytest.approx([1.0, 2.0, 0.0], abs=1e-6)
    engine.step(10)
    assert engine.link_pose("pend", "base").p == pytest.approx([1.0, 2.0, 2.0], abs=1e-3)
    engine.reset_joints('pend')
    assert engine.joint_state('pend', 'hinge') == pytest.approx((0.2, 0.0), abs=1e-9)


def test_links_of_a_model_do_not_collide():
    """The rod's sphere starts inside the base's box: without self_collide nothing pushes."""
    for name in ENGINES:
        e = make_engine(name, gravity=(0, 0, 0))
        e.add_model(pendulum())
        e.set_joint_positions('pend', {'hinge': 0.0})
        e.step(100)
        assert abs(e.joint_state('pend', 'hinge')[0]) < 1e-9
        e.close()


# ---- parsing: what Gazebo's converter does, and what is refused -------------------------------

def urdf(joint, links=('a', 'b')):
    body = ''.join('<link name="%s"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" '
                   'izz="0.01"/></inertial></link>' % n for n in links)
    return '<robot name="r">%s%s</robot>' % (body, joint)


def test_joint_elements_are_read():
    m = parse_urdf(urdf('<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                        '<axis xyz="0 0 2"/><limit lower="-1" upper="1" effort="5" velocity="2"/>'
                        '<dynamics damping="0.3" friction="0.1"/></joint>'))
    j = m.joint('j')
    assert (j.lower, j.upper, j.effort, j.velocity, j.damping, j.friction) == \
        (-1.0, 1.0, 5.0, 2.0, 0.3, 0.1)
    assert list(j.axis) == [0.0, 0.0, 1.0]


@pytest.mark.parametrize('joint, words', [
    ('<joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint>', 'no <limit>'),
    ('<joint name="j" type="floating"><parent link="a"/><child link="b"/></joint>', 'not supported'),
    ('<joint name="j" type="planar"><parent link="a"/><child link="b"/></joint>', 'not supported'),
    ('<joint name="j" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/>'
     '</joint>', 'not a direction'),
    ('<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<limit lower="nan" upper="1" effort="1" velocity="1"/></joint>', 'non-finite'),
    ('<joint name="j" type="continuous"><parent link="a"/><child link="x"/></joint>', 'unknown child'),
    ('<joint name="j" type="continuous"><parent link="x"/><child link="b"/></joint>', 'unknown parent'),
    ('<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>'
     '<joint name="j" type="fixed"><parent link="b"/><child link="c"/></joint>', 'defined twice'),
])
def test_bad_joints_are_refused_by_name(joint, words):
    with pytest.raises(ModelError) as e:
        parse_urdf(urdf(joint, ('a', 'b', 'c')))
    assert words in str(e.value) and "'j'" in str(e.value)


def test_lower_above_upper_and_mimic_cycles_warn_by_name(caplog):
    with caplog.at_level(logging.WARNING):
        m = parse_urdf(urdf(
            '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/>'
            '<limit lower="1" upper="-1" effort="1" velocity="1"/><mimic joint="j2"/></joint>'
            '<joint name="j2" type="continuous"><parent link="b"/><child link="c"/>'
            '<mimic joint="j1"/></joint>', ('a', 'b', 'c')))
    text = caplog.text
    assert "'j1'" in text and 'ignored' in text and 'cycle' in text
    assert m.joint('j1').lower is None and m.joint('j1').upper is None


def test_massless_link_on_a_movable_joint_is_not_simulated(engine, caplog):
    m = parse_urdf('''<robot name="r"><link name="a"><inertial><mass value="1"/>
<inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link><link name="b"/>
<link name="c"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>
<joint name="k" type="continuous"><parent link="b"/><child link="c"/><origin xyz="1 0 0"/></joint>
</robot>''')
    with caplog.at_level(logging.WARNING, logger='sim_world.physics'):
        engine.add_model(m)
    assert "link 'b' has no inertia" in caplog.text
    assert engine.joint_names('r') == []
    assert set(engine.link_poses('r')) == {'a', 'b', 'c'}


def test_mass_zero_links_are_massless_not_refused():
    m = parse_urdf(urdf('<joint name="j" type="fixed"><parent link="a"/><child link="z"/></joint>',
                        ('a',)).replace('</robot>', '<link name="z"><inertial><mass value="0"/>'
                                                    '</inertial></link></robot>'))
    assert m.links['z'].inertial is None


def test_sdf_joint_axis_limit_dynamics_pose():
    from sim_world.sdf import parse_sdf_model
    m = parse_sdf_model('''<model name="m"><link name="a"><inertial><mass>1</mass></inertial></link>
<link name="b"><pose>1 0 0 0 0 0</pose><inertial><mass>1</mass></inertial></link>
<joint name="j" type="revolute"><parent>a</parent><child>b</child><pose>0.5 0 0 0 0 0</pose>
<axis><xyz>0 0 1</xyz><limit><lower>-0.5</lower><upper>0.5</upper><effort>3</effort>
<velocity>1</velocity></limit><dynamics><damping>0.2</damping><friction>0.1</friction></dynamics>
</axis></joint></model>''')
    j = m.joint('j')
    assert (j.lower, j.upper, j.effort, j.velocity, j.damping, j.friction) == \
        (-0.5, 0.5, 3.0, 1.0, 0.2, 0.1)
    assert list(j.frame.p) == [0.5, 0.0, 0.0]
    e = make_engine('ode', gravity=(0, 0, 0))
    e.add_model(m)
    e.set_joint_positions('m', {'j': 0.5})
    # b's origin turns about the pivot 1.5 m from a's origin
    assert e.link_pose('m', 'b').p == pytest.approx(
        [1.5 - 0.5 * math.cos(0.5), -0.5 * math.sin(0.5), 0.0], abs=1e-3)
    e.close()


def test_bad_positions_are_refused_by_name(engine):
    engine.add_model(pendulum())
    with pytest.raises(KeyError, match='nope'):
        engine.set_joint_positions('pend', {'nope': 1.0})
    with pytest.raises(ValueError, match='hinge'):
        engine.set_joint_positions('pend', {'hinge': float('nan')})
    with pytest.raises(ValueError, match='hinge'):
        engine.apply_joint_effort('pend', 'hinge', float('inf'))
    engine.step(10)
    assert all(np.all(np.isfinite(p.p)) for p in engine.link_poses('pend').values())


@pytest.mark.parametrize('physics', ENGINES)
def test_world_sensor_link_follows_and_reset_restores_joints(physics):
    """Through sim_world.world.World: a sensor's link state (entity_state) follows the
    moving link, and reset_world puts the joint back at its spawn value, at rest."""
    from sim_world.world import World
    w = World(physics=physics)
    try:
        m = pendulum()
        m.joint('hinge').initial = 0.4
        w.add_model(m)
        w.step(300)
        q, _ = w.physics.joint_state('pend', 'hinge')
        pose, lin, ang = w.entity_state('pend::rod')
        com = pose * np.array([0.0, 0.0, -L])
        assert com == pytest.approx([-L * math.sin(q), 0.0, 2.0 - L * math.cos(q)], abs=2e-5)
        assert ang[1] == pytest.approx(w.physics.joint_state('pend', 'hinge')[1], abs=1e-6)
        w.reset()
        assert w.physics.joint_state('pend', 'hinge') == pytest.approx((0.4, 0.0), abs=1e-9)
    finally:
        w.shutdown()


def test_xarm6_from_pybullet_data_loads_and_both_engines_agree(caplog):
    """pybullet_data's xarm6 (welded by its `world` link, collision meshes missing from the
    pip package: one warning per mesh naming the link, the model spawns without them) falls
    under gravity the same way in both engines."""
    import os
    pybullet_data = pytest.importorskip('pybullet_data')
    from sim_world.urdf import load_urdf_file
    path = os.path.join(pybullet_data.getDataPath(), 'xarm', 'xarm6_robot.urdf')
    states = []
    for name in ENGINES:
        e = make_engine(name)
        with caplog.at_level(logging.WARNING, logger='sim_world.physics'):
            e.add_model(load_urdf_file(path))
        e.step(300)
        states.append(e.joint_states('xarm6'))
        e.close()
    assert "link 'link6': collision mesh" in caplog.text and 'not found' in caplog.text
    assert sorted(states[0]) == ['joint%d' % i for i in range(1, 7)]
    for jn in states[0]:
        assert states[0][jn][0] == pytest.approx(states[1][jn][0], abs=0.01), jn
    assert abs(states[0]['joint2'][0]) > 0.1          # it moved: gravity folds the arm
