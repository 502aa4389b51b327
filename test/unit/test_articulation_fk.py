"""The fast forward kinematics of the kinematic joint set (issue 48's speed aims): the body
poses ``articulation.BodyPoses`` folds into constants, and the engines' joint sets that use
them, against the straightforward composition ``articulation.forward(...)[i] * spec.com``
on random configurations. No roscore, both engines, about a second."""
import math
import os

import numpy as np
import pytest

from sim_world.physics import ENGINES, make_engine
from sim_world.physics.articulation import BodyPoses, build_articulation, forward
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf

pybullet_data = pytest.importorskip('pybullet_data')
XARM = os.path.join(pybullet_data.getDataPath(), 'xarm', 'xarm6_robot.urdf')
TOL = 1e-9

#: every kind of group BodyPoses folds: revolute and continuous joints on non-unit tilted
#: axes, a prismatic one, a preserved fixed joint, inertial frames turned and offset
MIXED = '''<robot name="mixed"><link name="world"/>
<joint name="weld" type="fixed"><parent link="world"/><child link="base"/></joint>
<link name="base"><inertial><origin xyz="0.01 0.02 0.05" rpy="0.1 0.2 0.3"/><mass value="2"/>
<inertia ixx="0.02" iyy="0.03" izz="0.04"/></inertial></link>
<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
<origin xyz="0.1 0 0.2" rpy="0.3 -0.2 0.5"/><axis xyz="0 2 1"/>
<limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
<link name="l1"><inertial><origin xyz="0.05 -0.02 0.1" rpy="-0.4 0.1 0.7"/><mass value="1"/>
<inertia ixx="0.01" iyy="0.02" izz="0.005" ixy="0.001"/></inertial></link>
<joint name="slide" type="prismatic"><parent link="l1"/><child link="l2"/>
<origin xyz="0 0.1 0.3" rpy="0 0.4 0"/><axis xyz="1 1 0"/>
<limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
<link name="l2"><inertial><origin xyz="0 0 0.05" rpy="0.2 0 0"/><mass value="0.5"/>
<inertia ixx="0.001" iyy="0.001" izz="0.001"/></inertial></link>
<joint name="kept" type="fixed"><parent link="l2"/><child link="l3"/>
<origin xyz="0.02 0 0.1" rpy="0 0 1.2"/></joint>
<gazebo reference="kept"><preserveFixedJoint>true</preserveFixedJoint></gazebo>
<link name="l3"><inertial><origin xyz="0.01 0.01 0" rpy="0 0.3 0"/><mass value="0.3"/>
<inertia ixx="0.001" iyy="0.002" izz="0.001"/></inertial></link>
<joint name="spin" type="continuous"><parent link="l3"/><child link="l4"/>
<origin xyz="0 0 0.1" rpy="1.0 0 0"/><axis xyz="0.3 -0.1 1"/></joint>
<link name="l4"><inertial><origin xyz="0.03 0 0.02" rpy="0 0 -0.6"/><mass value="0.2"/>
<inertia ixx="0.001" iyy="0.001" izz="0.002"/></inertial></link>
</robot>'''


def reference(art, root_body, positions):
    """The body poses composed the straightforward way, as Pose products."""
    frames = forward(art, root_body * art.groups[0].com_inv, positions)
    return [f * g.spec.com for f, g in zip(frames, art.groups)]


def random_pose(rng):
    q = rng.normal(size=4)
    return Pose(rng.uniform(-2, 2, 3), q / np.linalg.norm(q))


def assert_close(fast, ref):
    assert len(fast) == len(ref)
    for (p, wxyz), r in zip(fast, ref):
        q = np.array(wxyz[1:] + wxyz[:1])
        assert np.abs(np.array(p) - r.p).max() < TOL
        assert np.abs(q - r.q).max() < TOL      # the same quaternion, not its negative


def check_random(model, n, seed):
    art = build_articulation(model)
    fast = BodyPoses(art)
    rng = np.random.default_rng(seed)
    names = [js.name for js in art.moving]
    for k in range(n):
        root = random_pose(rng)
        positions = dict(zip(names, rng.uniform(-math.pi, math.pi, len(names))))
        if k == 0:
            positions = {}                       # every joint at 0 (missing: 0)
        got = fast(tuple(root.p.tolist()), tuple(root.q.tolist()), positions)
        assert_close(got, reference(art, root, positions))
    return art


def test_xarm6_body_poses_equal_the_straightforward_composition():
    art = check_random(load_urdf_file(XARM), 50, 1)
    assert len(art.groups) == 7 and len(art.moving) == 6


def test_every_joint_kind_equals_the_straightforward_composition():
    art = check_random(parse_urdf(MIXED), 50, 2)
    kinds = [c[1] for c in BodyPoses(art).consts if c is not None]
    assert sorted(kinds) == [BodyPoses.ROT, BodyPoses.ROT, BodyPoses.SLIDE, BodyPoses.FIXED]


def test_a_joint_with_its_own_frame_goes_through_joint_motion():
    model = parse_urdf(MIXED)
    for j in model.joints:
        if j.name in ('j1', 'slide'):      # an SDF joint <pose> in the child link frame
            j.frame = Pose((0.02, -0.01, 0.03), (0.1, 0.2, -0.1, 0.97))
    art = check_random(model, 20, 3)
    kinds = [c[1] for c in BodyPoses(art).consts if c is not None]
    assert kinds.count(BodyPoses.GENERAL) == 2


@pytest.mark.parametrize('physics', ENGINES)
def test_the_engines_joint_set_puts_every_link_where_the_composition_does(physics):
    """set_joint_positions (the kinematic path of a position interface) against the links'
    poses composed from the model: ODE through BodyPoses, Bullet through its own
    kinematics after one batched reset."""
    e = make_engine(physics, step_size=0.001)
    try:
        model = load_urdf_file(XARM)
        model.pose = Pose((0.3, -0.2, 0.01), (0.0, 0.0, math.sin(0.2), math.cos(0.2)))
        e.add_model(model)
        rng = np.random.default_rng(4)
        names = [j for j in e.joint_names('xarm6') if e.joint('xarm6', j).movable]
        for k in range(5):
            q = dict(zip(names, rng.uniform(-1.5, 1.5, len(names))))
            e.set_joint_positions('xarm6', q)
            root = e.model_pose('xarm6')
            want = dict((ln, root * off) for ln, off in model.joint_poses(q).items())
            got = e.link_poses('xarm6')
            for ln, pose in want.items():
                assert np.abs(got[ln].p - pose.p).max() < 1e-9, ln
                assert pose.almost_equal(got[ln], 1e-9), ln
            for jn in names:
                pos, vel = e.joint_state('xarm6', jn)
                assert pos == pytest.approx(q[jn], abs=1e-9) and vel == pytest.approx(0, abs=1e-9)
            e.step(3)
    finally:
        e.close()


def test_the_trajectorys_segment_hint_finds_what_the_search_finds():
    """The trajectory controller keeps each joint's segment index between steps as a hint
    (trajectory.find_segment): any hint gives the binary search's answer, repeated start
    times (held points, bridges) and times before, between and after included."""
    from sim_world.control.trajectory import Segment, State, find_segment
    rng = np.random.default_rng(5)
    for _ in range(200):
        t0s = np.sort(rng.choice([0.0, 0.5, 1.0, 1.5, 2.0, 3.0], rng.integers(1, 7)))
        segs = [Segment(a, State(0.0), a + 0.1, State(1.0)) for a in t0s]
        for t in (-1.0, 0.0, 0.25, 0.5, 1.0, 1.7, 2.0, 5.0):
            want = find_segment(segs, t)
            for hint in range(-1, len(segs) + 2):
                assert find_segment(segs, t, hint) == want, (t0s, t, hint)
