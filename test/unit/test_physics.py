"""Physics on both engines (ODE through pyode, Bullet through pybullet), no roscore.

Every scenario runs on both backends through the one ``PhysicsEngine`` interface the world
uses. Tolerances come from the issue: touch-down within one step of sqrt(2h/g), resting
drift below 1 mm over 2 s.
"""
import logging
import math

import numpy as np
import pytest

from sim_world.model import (Collision, Geometry, Inertial, Joint, Link, Model, ModelError,
                          cuboid_inertia, sphere_inertia, cylinder_inertia)
from sim_world.physics import ENGINES, lump_model, make_engine
from sim_world.transforms import InvalidPose, Pose, quat_from_rpy

G = 9.81
DT = 0.001


@pytest.fixture(params=ENGINES)
def engine(request):
    e = make_engine(request.param, DT, (0.0, 0.0, -G))
    yield e
    e.close()


def box_link(name, size, mass=1.0, origin=None, gravity=True):
    ixx, iyy, izz = cuboid_inertia(mass, *size)
    return Link(name, Inertial(mass, ixx=ixx, iyy=iyy, izz=izz),
                collisions=[Collision(Geometry('box', size=size), origin=origin)],
                gravity=gravity)


def box_model(name, size=(0.1, 0.1, 0.1), mass=1.0, pose=None, gravity=True):
    return Model(name, {'base': box_link('base', size, mass, gravity=gravity)},
                 pose=pose or Pose())


def ground(name='ground_plane'):
    return Model(name, {'link': Link('link', collisions=[
        Collision(Geometry('plane', size=(100, 100)))])}, static=True)


def static_box(name, size, pose):
    return Model(name, {'link': Link('link', collisions=[Collision(Geometry('box', size=size))])},
                 pose=pose, static=True)


def steps_until_contact(e, name, limit):
    for n in range(1, limit + 1):
        e.step()
        if e.in_contact(name):
            return n
    return None


# ---- free fall and contact --------------------------------------------------------------------
@pytest.mark.parametrize('h', [1.0, 0.3])
def test_dropped_box_touches_ground_at_free_fall_time(engine, h):
    engine.add_model(ground())
    engine.add_model(box_model('box', pose=Pose((0.0, 0.0, h + 0.05))))  # bottom face at h
    assert not engine.in_contact('box')
    expected = math.sqrt(2 * h / G)
    n = steps_until_contact(engine, 'box', int(2 * expected / DT))
    assert n is not None, 'the box never touched the ground'
    assert abs(n * DT - expected) <= DT, (n * DT, expected)
    assert engine.in_contact('ground_plane')
    # it lands and stays on the ground, not through it
    engine.step(1000)
    pose = engine.model_pose('box')
    assert abs(pose.p[2] - 0.05) < 3e-3, pose
    assert engine.in_contact('box')
    assert np.linalg.norm(engine.model_twist('box')[0]) < 1e-2


def test_box_at_rest_stays_at_rest(engine):
    engine.add_model(ground())
    start = Pose((0.4, -0.2, 0.05), quat_from_rpy(0, 0, 0.3))
    engine.add_model(box_model('box', pose=start))
    engine.step(2000)
    pose = engine.model_pose('box')
    assert np.linalg.norm(pose.p - start.p) < 1e-3, pose
    assert abs(abs(float(np.dot(pose.q, start.q))) - 1.0) < 1e-6, pose
    assert engine.in_contact('box')


def test_box_rests_on_static_box_desk(engine):
    engine.add_model(ground())
    engine.add_model(static_box('desk', (1.6, 0.8, 0.03), Pose((3.32, -2.1, 0.735))))
    top = 0.735 + 0.015
    engine.add_model(box_model('paperweight', (0.05, 0.05, 0.02), 0.2,
                               Pose((3.3, -2.0, top + 0.01 + 0.05))))
    engine.step(800)
    pose = engine.model_pose('paperweight')
    assert abs(pose.p[2] - (top + 0.01)) < 2e-3, pose
    assert engine.in_contact('paperweight') and engine.in_contact('desk')


@pytest.mark.parametrize('kind', ['sphere', 'cylinder'])
def test_round_shapes_rest_at_their_size(engine, kind):
    engine.add_model(ground())
    if kind == 'sphere':
        geom, inertia, height = Geometry('sphere', radius=0.05), sphere_inertia(0.5, 0.05), 0.05
    else:
        geom = Geometry('cylinder', radius=0.04, length=0.2)
        inertia, height = cylinder_inertia(0.5, 0.04, 0.2), 0.1
    link = Link('l', Inertial(0.5, ixx=inertia[0], iyy=inertia[1], izz=inertia[2]),
                collisions=[Collision(geom)])
    engine.add_model(Model('obj', {'l': link}, pose=Pose((0, 0, height + 0.02))))
    engine.step(1000)
    pose = engine.model_pose('obj')
    assert abs(pose.p[2] - height) < 2e-3, pose
    assert np.linalg.norm(pose.p[:2]) < 1e-3


def test_static_mesh_collides(engine, tmp_path):
    trimesh = pytest.importorskip('trimesh')
    path = tmp_path / 'slab.stl'
    trimesh.creation.box(extents=(1.0, 1.0, 0.2)).export(str(path))
    slab = Model('slab', {'l': Link('l', collisions=[
        Collision(Geometry('mesh', filename=str(path), scale=(1.0, 1.0, 2.0)))])},
        pose=Pose((0, 0, 0.5)), static=True)
    engine.add_model(slab)
    engine.add_model(box_model('box', pose=Pose((0.1, 0.1, 0.5 + 0.2 + 0.05 + 0.03))))
    engine.step(800)
    z = engine.model_pose('box').p[2]
    assert abs(z - (0.5 + 0.2 + 0.05)) < 3e-3, z   # scaled slab: top at 0.5 + 0.2
    assert engine.in_contact('box') and engine.in_contact('slab')


def test_mesh_boxes_cover_the_mesh_and_keep_holes():
    """ODE's mesh fallback (pyode has no trimesh support): boxes from a voxelisation."""
    trimesh = pytest.importorskip('trimesh')
    from sim_world.physics.base import mesh_boxes

    def inside(boxes, pt):
        return any(np.all(np.abs(np.asarray(pt) - c) <= s / 2 + 1e-9) for c, s in boxes)

    slab = trimesh.creation.box(extents=(1.0, 0.5, 0.2))
    boxes = mesh_boxes(slab.vertices, slab.faces)
    assert len(boxes) == 1 and np.allclose(boxes[0][1], (1.0, 0.5, 0.2))
    ring = trimesh.creation.annulus(r_min=0.3, r_max=0.5, height=0.2)
    boxes = mesh_boxes(ring.vertices, ring.faces)
    assert inside(boxes, (0.4, 0, 0)) and inside(boxes, (0, -0.4, 0.05))
    assert not inside(boxes, (0, 0, 0)) and not inside(boxes, (0.15, 0.1, 0))
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    boxes = mesh_boxes(ball.vertices, ball.faces)
    volume = sum(float(np.prod(s)) for _, s in boxes)
    assert abs(volume - ball.volume) / ball.volume < 0.2, volume
    assert inside(boxes, (0, 0, 0)) and not inside(boxes, (0.45, 0.45, 0))


def test_ring_mesh_lets_a_ball_fall_through_its_hole(engine, tmp_path):
    trimesh = pytest.importorskip('trimesh')
    path = str(tmp_path / 'ring.stl')
    trimesh.creation.annulus(r_min=0.3, r_max=0.5, height=0.1).export(path)
    engine.add_model(Model('ring', {'l': Link('l', collisions=[
        Collision(Geometry('mesh', filename=path))])}, pose=Pose((0, 0, 1.0)), static=True))
    engine.add_model(ground())
    i = sphere_inertia(0.1, 0.05)
    for name, x in (('through', 0.0), ('on_rim', 0.4)):
        link = Link('l', Inertial(0.1, ixx=i[0], iyy=i[1], izz=i[2]),
                    collisions=[Collision(Geometry('sphere', radius=0.05))])
        engine.add_model(Model(name, {'l': link}, pose=Pose((x, 0, 1.2))))
    engine.step(1000)
    assert engine.model_pose('through').p[2] < 0.1        # fell through the hole
    assert engine.model_pose('on_rim').p[2] > 1.0         # caught by the rim


# ---- teleport, twist, floating --------------------------------------------------------------------
def test_teleported_model_stays_where_it_was_put(engine):
    engine.add_model(ground())
    engine.add_model(box_model('box', pose=Pose((0, 0, 0.05))))
    engine.step(100)
    target = Pose((2.0, 1.0, 0.05), quat_from_rpy(0, 0, math.radians(30)))
    engine.set_model_pose('box', target)
    assert engine.model_pose('box').almost_equal(target, 1e-9)
    links = engine.link_poses('box')
    assert links['base'].almost_equal(target, 1e-9)
    engine.step(1000)
    pose = engine.model_pose('box')
    assert np.linalg.norm(pose.p - target.p) < 1e-3, pose
    assert abs(abs(float(np.dot(pose.q, target.q))) - 1.0) < 1e-6


def test_teleport_keeps_twist_and_static_teleport(engine):
    engine.set_gravity((0, 0, 0))
    engine.add_model(box_model('box', pose=Pose((0, 0, 5))))
    engine.set_model_twist('box', (0.5, 0, 0), (0, 0, 0))
    engine.set_model_pose('box', Pose((1, 1, 5)))
    lin, ang = engine.model_twist('box')
    assert np.allclose(lin, (0.5, 0, 0), atol=1e-9) and np.allclose(ang, 0, atol=1e-9)
    engine.step(1000)
    assert np.allclose(engine.model_pose('box').p, (1.5, 1, 5), atol=1e-6)
    # a static model moves only when teleported, and its shapes move with it
    engine.add_model(static_box('wall', (0.1, 2, 2), Pose((10, 0, 0))))
    engine.set_model_pose('wall', Pose((1.6, 1, 5)))
    assert engine.model_pose('wall').almost_equal(Pose((1.6, 1, 5)))
    assert np.allclose(engine.model_twist('wall')[0], 0)
    engine.step(1)
    assert engine.in_contact('box') and engine.in_contact('wall')


def test_floating_gravity_off_model_stays(engine):
    engine.add_model(ground())
    start = Pose((3.288, -2.11, 1.0), quat_from_rpy(0.1, -0.2, 0.3))
    engine.add_model(box_model('mobile_device', (0.063, 0.1239, 0.01088), 0.129, start,
                               gravity=False))
    engine.add_model(box_model('falls', pose=Pose((5, 5, 1))))
    engine.step(2000)
    pose = engine.model_pose('mobile_device')
    assert np.linalg.norm(pose.p - start.p) < 1e-6, pose
    assert abs(abs(float(np.dot(pose.q, start.q))) - 1.0) < 1e-9
    assert not engine.in_contact('mobile_device')
    assert engine.model_pose('falls').p[2] < 0.06   # gravity still acts on the others


def test_gravity_per_body_whatever_the_mix(engine):
    """Mostly floating bodies, then mostly falling ones (Bullet switches which group gets
    the per-step force): each body keeps its own gravity through additions, removals and
    a gravity change."""
    for i in range(3):
        engine.add_model(box_model('float%d' % i, pose=Pose((i, 0, 2)), gravity=False))
    engine.add_model(box_model('fall0', pose=Pose((0, 3, 2))))
    engine.step(200)      # 0.2 s: a falling body drops g t^2 / 2 = 0.196 m
    for i in range(3):
        assert engine.model_pose('float%d' % i).p[2] == pytest.approx(2.0, abs=1e-9)
    assert engine.model_pose('fall0').p[2] == pytest.approx(2 - 0.5 * G * 0.2 ** 2, abs=2e-3)
    for i in range(1, 4):
        engine.add_model(box_model('fall%d' % i, pose=Pose((i, 3, 2))))
    engine.remove_model('float0')
    engine.set_model_twist('fall0', (0, 0, 0), (0, 0, 0))
    engine.set_gravity((0, 0, -2 * G))
    engine.step(100)
    for i in range(1, 3):
        assert engine.model_pose('float%d' % i).p[2] == pytest.approx(2.0, abs=1e-9)
    for i in range(1, 4):
        assert engine.model_pose('fall%d' % i).p[2] == pytest.approx(2 - G * 0.1 ** 2, abs=2e-3)
    assert np.linalg.norm(engine.model_twist('float1')[1]) < 1e-9


def test_ode_floating_phone_costs_no_collision_callback():
    """ODE: static geoms sit in their own space and planes behind a bounding-box gate, so
    a body that touches nothing runs no Python collision callback per step."""
    e = make_engine('ode', DT)
    e.add_model(ground())
    e.add_model(static_box('desk', (1.6, 0.8, 0.03), Pose((3.32, -2.1, 0.735))))
    e.add_model(box_model('mobile_device', (0.063, 0.1239, 0.01088), 0.129,
                          Pose((3.288, -2.11, 1.0)), gravity=False))
    calls = []
    near = e._near
    e._near = lambda *a: (calls.append(a[1:]), near(*a))
    e.step(100)
    assert calls == []
    e.set_model_pose('mobile_device', Pose((3.288, -2.11, 0.75 + 0.0054)))   # on the desk
    e.step(1)
    assert len(calls) >= 1 and e.in_contact('mobile_device')
    e.set_model_pose('mobile_device', Pose((0, 0, 0.0054)))                  # on the floor
    e.step(1)
    assert e.in_contact('mobile_device') and e.in_contact('ground_plane')
    e.close()


def test_no_damping_and_twist_of_link_origin(engine):
    """Gravity off, no contacts: the centre of mass moves in a straight line at constant
    speed and the spin stays constant (pybullet's default damping is zeroed); the twist is
    that of the root link origin, which here is 0.1 m away from the centre of mass."""
    engine.set_gravity((0, 0, 0))
    links = {'a': box_link('a', (0.1, 0.1, 0.1), 1.0),
             'b': box_link('b', (0.1, 0.1, 0.1), 1.0)}
    joints = [Joint('a_b', 'fixed', 'a', 'b', Pose((0.2, 0, 0)))]
    engine.add_model(Model('dumbbell', links, joints, pose=Pose((0, 0, 2))))
    engine.set_model_twist('dumbbell', (0, 0, 0), (0, 0, 1.0))
    lin, ang = engine.model_twist('dumbbell')
    assert np.allclose(lin, 0, atol=1e-9) and np.allclose(ang, (0, 0, 1), atol=1e-9)
    # root origin at rest, so the centre of mass (0.1 m along x) moves at w x r = (0, 0.1, 0)
    engine.step(1000)
    com = engine.model_pose('dumbbell') * np.array([0.1, 0, 0])
    assert np.allclose(com, (0.1, 0.1, 2), atol=1e-5), com
    lin, ang = engine.model_twist('dumbbell')
    assert np.allclose(ang, (0, 0, 1), atol=1e-4), ang
    yaw = engine.model_pose('dumbbell').rpy()[2]
    assert abs(yaw - 1.0) < 1e-3, yaw
    # origin velocity = v_com + w x (origin - com)
    r = engine.model_pose('dumbbell').p - com
    assert np.allclose(lin, np.array([0, 0.1, 0]) + np.cross(ang, r), atol=1e-4)
    b = engine.link_poses('dumbbell')['b']
    assert np.allclose(b.p, engine.model_pose('dumbbell') * np.array([0.2, 0, 0]))


def test_set_gravity(engine):
    engine.add_model(box_model('box', pose=Pose((0, 0, 1))))
    engine.set_gravity((0, 0, 0))
    engine.step(500)
    assert engine.model_pose('box').p[2] == pytest.approx(1.0, abs=1e-9)
    engine.set_gravity((0, 0, -G))
    engine.step(100)
    assert engine.model_pose('box').p[2] < 1.0 - 0.04


def test_remove_model(engine):
    engine.add_model(ground())
    engine.add_model(box_model('box', pose=Pose((0, 0, 0.05))))
    engine.step(10)
    engine.remove_model('box')
    assert not engine.has_model('box') and engine.has_model('ground_plane')
    assert engine.model_names() == ['ground_plane']
    with pytest.raises(KeyError):
        engine.remove_model('box')
    with pytest.raises(KeyError):
        engine.model_pose('box')
    engine.step(10)
    engine.add_model(box_model('box', pose=Pose((0, 0, 0.05))))   # the name is free again
    engine.step(10)
    assert engine.in_contact('box')


# ---- lumping and inertia ------------------------------------------------------------------------
def test_thesis_cuboid_inertia():
    ixx, iyy, izz = cuboid_inertia(0.129, 0.063, 0.1239, 0.01088)
    assert round(ixx, 6) == 0.000166
    assert round(iyy, 6) == 0.000044
    assert round(izz, 6) == 0.000208
    link = Link('body', Inertial(0.129, ixx=ixx, iyy=iyy, izz=izz),
                collisions=[Collision(Geometry('box', size=(0.063, 0.1239, 0.01088)))])
    spec = lump_model(Model('mobile_device', {'body': link}))
    assert spec.mass == pytest.approx(0.129)
    assert sorted(spec.inertia) == pytest.approx(sorted([ixx, iyy, izz]), rel=1e-9)


def test_lumped_mass_com_inertia_of_two_boxes_on_fixed_joint(caplog):
    a = box_link('a', (0.1, 0.1, 0.1), 1.0)
    b = box_link('b', (0.1, 0.2, 0.1), 3.0)
    joints = [Joint('a_to_b', 'fixed', 'a', 'b', Pose((0.2, 0, 0)))]
    spec = lump_model(Model('pair', {'a': a, 'b': b}, joints))
    assert spec.mass == pytest.approx(4.0)
    assert np.allclose(spec.com.p, (0.15, 0, 0))
    # parallel-axis theorem about the common COM at x = 0.15
    ia = np.diag(cuboid_inertia(1.0, 0.1, 0.1, 0.1))
    ib = np.diag(cuboid_inertia(3.0, 0.1, 0.2, 0.1))
    shift = np.diag([0.0, 1.0, 1.0]) * (1.0 * 0.15 ** 2 + 3.0 * 0.05 ** 2)
    expected = ia + ib + shift
    r = spec.com.matrix()[:3, :3]
    got = r.dot(np.diag(spec.inertia)).dot(r.T)   # principal frame back to link axes
    assert np.allclose(got, expected, atol=1e-12), got
    assert np.allclose(r.dot(r.T), np.eye(3)) and np.linalg.det(r) == pytest.approx(1.0)
    # both collision shapes are attached with their offsets
    assert [s.link for s in spec.shapes] == ['a', 'b']
    assert np.allclose(spec.shapes[1].pose.p, (0.2, 0, 0))
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_lumped_inertial_origins_and_rotated_joint():
    """Inertial origins and rotated joints: the COM and tensor follow the transforms."""
    rot = quat_from_rpy(0, 0, math.pi / 2)
    a = Link('a', Inertial(2.0, origin=Pose((0, 0, 0.1)), ixx=0.01, iyy=0.02, izz=0.03))
    b = Link('b', Inertial(2.0, origin=Pose((0.1, 0, 0)), ixx=0.01, iyy=0.02, izz=0.03))
    spec = lump_model(Model('m', {'a': a, 'b': b},
                            [Joint('j', 'fixed', 'a', 'b', Pose((0, 0.5, 0), rot))]))
    # b's inertial sits at (0, 0.5, 0) + R(90 deg yaw)*(0.1, 0, 0) = (0, 0.6, 0)
    assert np.allclose(spec.com.p, (0, 0.3, 0.05))
    r = spec.com.matrix()[:3, :3]
    got = r.dot(np.diag(spec.inertia)).dot(r.T)
    ib = np.diag([0.02, 0.01, 0.03])        # b's tensor rotated by 90 degrees about z
    ia = np.diag([0.01, 0.02, 0.03])
    da, db = np.array([0, -0.3, 0.05]), np.array([0, 0.3, -0.05])
    pa = 2.0 * (da.dot(da) * np.eye(3) - np.outer(da, da))
    pb = 2.0 * (db.dot(db) * np.eye(3) - np.outer(db, db))
    assert np.allclose(got, ia + ib + pa + pb, atol=1e-12)


def test_lumped_body_dynamics_on_both_engines(engine):
    """The engine uses the lumped body: a model with its COM off the link origin, dropped
    onto the ground tilted, settles with the heavy end down; link poses follow."""
    links = {'light': box_link('light', (0.1, 0.1, 0.1), 0.1),
             'heavy': box_link('heavy', (0.1, 0.1, 0.1), 2.0)}
    joints = [Joint('j', 'fixed', 'light', 'heavy', Pose((0.3, 0, 0)))]
    engine.add_model(ground())
    engine.add_model(Model('bar', links, joints, pose=Pose((0, 0, 0.06))))
    engine.step(500)
    lp = engine.link_poses('bar')
    assert set(lp) == {'light', 'heavy'}
    assert abs(lp['heavy'].p[2] - 0.05) < 3e-3 and abs(lp['light'].p[2] - 0.05) < 3e-3
    assert np.linalg.norm(lp['heavy'].p - lp['light'].p) == pytest.approx(0.3, abs=1e-9)


def test_non_fixed_joint_is_articulated(engine):
    """Issue 48: a revolute joint is simulated (no longer lumped): the arm swings down
    under gravity around the elbow while the base stays one body of its own."""
    links = {'base': box_link('base', (0.1, 0.1, 0.1)), 'arm': box_link('arm', (0.1, 0.1, 0.1))}
    joints = [Joint('elbow', 'continuous', 'base', 'arm', Pose((0, 0, 0.2)), axis=(0, 1, 0))]
    engine.add_model(Model('robot', links, joints, pose=Pose((0, 0, 1))))
    assert engine.joint_names('robot') == ['elbow']
    assert engine.joint_state('robot', 'elbow') == pytest.approx((0.0, 0.0), abs=1e-9)


def test_mixed_gravity_links_keep_gravity(engine, caplog):
    links = {'a': box_link('a', (0.1, 0.1, 0.1), gravity=False),
             'b': box_link('b', (0.1, 0.1, 0.1), gravity=True)}
    with caplog.at_level(logging.WARNING, logger='sim_world.physics'):
        engine.add_model(Model('half', links, [Joint('j', 'fixed', 'a', 'b', Pose((0.2, 0, 0)))],
                               pose=Pose((0, 0, 1))))
    assert any('gravity' in r.getMessage() for r in caplog.records)
    engine.step(100)
    assert engine.model_pose('half').p[2] < 0.96


# ---- bad input ----------------------------------------------------------------------------------
def test_zero_mass_is_refused(engine):
    with pytest.raises(ModelError, match='mass'):
        Inertial(0.0)
    m = box_model('box')
    m.links['base'].inertial.mass = 0.0
    with pytest.raises(ModelError, match=r"model 'box'.*mass"):
        engine.add_model(m)
    assert not engine.has_model('box')
    m.links['base'].inertial.mass = float('nan')
    with pytest.raises(ModelError, match='mass'):
        engine.add_model(m)


def test_nan_pose_is_refused(engine):
    with pytest.raises(InvalidPose):
        Pose((float('nan'), 0, 0))
    m = box_model('box')
    m.pose.p[2] = float('nan')
    with pytest.raises(InvalidPose, match=r"model 'box'.*position"):
        engine.add_model(m)
    assert not engine.has_model('box')
    engine.add_model(box_model('ok', pose=Pose((0, 0, 1))))
    bad = Pose()
    bad.q = np.zeros(4)
    with pytest.raises(InvalidPose, match='normalised'):
        engine.set_model_pose('ok', bad)
    bad = Pose()
    bad.q = np.array([0.0, float('inf'), 0.0, 1.0])
    with pytest.raises(InvalidPose, match='quaternion'):
        engine.set_model_pose('ok', bad)
    with pytest.raises(ValueError, match='velocity'):
        engine.set_model_twist('ok', (float('nan'), 0, 0), (0, 0, 0))
    assert engine.model_pose('ok').almost_equal(Pose((0, 0, 1)))
    engine.step(10)   # still works


@pytest.mark.parametrize('case', ['no_inertial', 'zero_inertia', 'dynamic_plane', 'duplicate',
                                  'missing_mesh', 'no_links', 'not_a_model'])
def test_bad_models_are_refused_with_a_clear_message(engine, case, tmp_path):
    engine.add_model(box_model('first', pose=Pose((0, 0, 1))))
    if case == 'no_inertial':
        model, match = Model('ghost', {'l': Link('l')}), 'none of its links has an <inertial>'
    elif case == 'zero_inertia':
        link = Link('l', Inertial(1.0, ixx=0.0, iyy=0.0, izz=0.0))
        model, match = Model('flat', {'l': link}), 'not positive definite'
    elif case == 'dynamic_plane':
        link = Link('l', Inertial(1.0), collisions=[Collision(Geometry('plane'))])
        model, match = Model('floor', {'l': link}), 'plane collision'
    elif case == 'duplicate':
        model, match = box_model('first'), 'already exists'
    elif case == 'missing_mesh':
        missing = str(tmp_path / 'nowhere.stl')
        link = Link('l', collisions=[Collision(Geometry('mesh', filename=missing))])
        model, match = Model('m', {'l': link}, static=True), 'nowhere.stl'
    elif case == 'no_links':
        model, match = Model('empty'), 'no links'
    else:
        model, match = 'box', 'Model'
    with pytest.raises(ModelError, match=match):
        engine.add_model(model)
    assert engine.model_names() == ['first']
    engine.step(5)
    assert engine.model_pose('first').p[2] < 1.0


def test_make_engine_refuses_unknown_names_and_steps():
    with pytest.raises(ValueError, match='ode, bullet'):
        make_engine('havok')
    with pytest.raises(ValueError, match='step size'):
        make_engine('ode', step_size=0)
    e = make_engine('ODE', 0.002)
    assert e.name == 'ode' and e.step_size == 0.002
