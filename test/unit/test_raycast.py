"""sim_world.raycast: first hits and inside-intervals over the world's collision shapes (box,
sphere, cylinder, mesh, plane) at their current poses, on both engines."""
import numpy as np
import pytest

from sim_world.model import Collision, Geometry, Link, Model
from sim_world.raycast import RayCaster
from sim_world.sdf import parse_sdf_model
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

import worlds

world = worlds.world_fixture(seed=1)


def static(name, geom, pose, material=None):
    m = Model(name)
    m.static = True
    m.links['body'] = Link('body', collisions=[Collision(geom, material=material)])
    m.pose = pose
    return m


def wall(name, x, thickness, material=None):
    return static(name, Geometry('box', size=(thickness, 4.0, 3.0)), Pose((x, 0, 1.5)),
                  material)


def test_box_distance_normal_point(world):
    world.add_model(wall('w', 3.0, 0.2))
    h = world.raycast((0, 0, 1), (1, 0, 0), 10)
    assert h is not None and h.model == 'w' and h.link == 'body'
    assert h.distance == pytest.approx(2.9)
    assert np.allclose(h.point, (2.9, 0, 1)) and np.allclose(h.normal, (-1, 0, 0))
    assert world.raycast((0, 0, 1), (1, 0, 0), 2.8) is None       # beyond max_dist
    assert world.raycast((0, 0, 1), (-1, 0, 0), 10) is None       # behind
    assert world.raycast((0, 0, 1), (0, 0, 1), 10) is None        # up: nothing
    assert world.raycast((0, 0, 1), (1, 1, 0), 10) is None        # passes the wall's end
    h = world.raycast((0, 0, 1), (2, 1, 0), 10)                   # oblique, unnormalised
    assert h.distance == pytest.approx(2.9 * np.sqrt(1.25))


def test_rotated_box(world):
    # a 1 m cube turned 45 degrees about z: the ray meets its edge at sqrt(2)/2 from centre
    world.add_model(static('c', Geometry('box', size=(1, 1, 1)),
                           Pose.from_xyz_rpy((5, 0, 1), (0, 0, np.pi / 4))))
    h = world.raycast((0, 0, 1), (1, 0, 0), 10)
    assert h.distance == pytest.approx(5 - np.sqrt(0.5), abs=1e-9)


def test_two_walls_two_intervals(world):
    world.add_model(wall('a', 2.0, 0.2, 'drywall'))
    world.add_model(wall('b', 5.0, 0.3, 'concrete'))
    iv = world.segment_intervals((0, 0, 1), (8, 0, 1))
    assert [(m, mat) for _, _, m, _, mat in iv] == [('a', 'drywall'), ('b', 'concrete')]
    assert iv[0][0] == pytest.approx(1.9) and iv[0][1] - iv[0][0] == pytest.approx(0.2)
    assert iv[1][0] == pytest.approx(4.85) and iv[1][1] - iv[1][0] == pytest.approx(0.3)
    # segment ending inside the second wall: clipped
    iv = world.segment_intervals((0, 0, 1), (5.0, 0, 1))
    assert iv[-1][1] == pytest.approx(5.0) and iv[-1][1] - iv[-1][0] == pytest.approx(0.15)
    # a slanted segment crosses more wall: thickness / cos
    iv = world.segment_intervals((0, -1, 1), (4, 1, 1))
    assert iv[0][1] - iv[0][0] == pytest.approx(0.2 * np.sqrt(20) / 4)
    # ignore list
    iv = world.segment_intervals((0, 0, 1), (8, 0, 1), ignore=('a',))
    assert [m for _, _, m, _, _ in iv] == ['b']
    h = world.raycast((0, 0, 1), (1, 0, 0), 10, ignore=('a',))
    assert h.model == 'b' and h.distance == pytest.approx(4.85)
    h = world.raycast((0, 0, 1), (1, 0, 0), 10, ignore=('a::body',))
    assert h.model == 'b'


def test_sphere_cylinder_plane(world):
    world.add_model(static('s', Geometry('sphere', radius=0.5), Pose((3, 0, 1))))
    world.add_model(static('cyl', Geometry('cylinder', radius=0.25, length=2.0),
                           Pose((0, 3, 1))))
    world.add_model(static('ground', Geometry('plane', normal=(0, 0, 1)), Pose()))
    h = world.raycast((0, 0, 1), (1, 0, 0), 10)
    assert h.model == 's' and h.distance == pytest.approx(2.5)
    assert np.allclose(h.normal, (-1, 0, 0))
    iv = world.segment_intervals((0, 0, 1), (5, 0, 1))
    assert len(iv) == 1 and iv[0][1] - iv[0][0] == pytest.approx(1.0)
    h = world.raycast((0, 0, 1), (0, 1, 0), 10)
    assert h.model == 'cyl' and h.distance == pytest.approx(2.75)
    assert np.allclose(h.normal, (0, -1, 0), atol=1e-9)
    h = world.raycast((0, 3, 5), (0, 0, -1), 10)                  # onto the cylinder's cap
    assert h.model == 'cyl' and h.distance == pytest.approx(3.0)
    assert np.allclose(h.normal, (0, 0, 1))
    h = world.raycast((1, 1, 2), (0, 0, -1), 10)                  # the ground
    assert h.model == 'ground' and h.distance == pytest.approx(2.0)
    iv = world.segment_intervals((1, 1, 1), (1, 1, -1))            # ground: half-space below
    assert len(iv) == 1 and iv[0][0] == pytest.approx(1.0) and iv[0][1] == pytest.approx(2.0)


def test_mesh_box_like_a_box(world, tmp_path):
    import trimesh
    path = str(tmp_path / 'cube.stl')
    trimesh.creation.box(extents=(0.4, 2, 2)).export(path)
    m = parse_sdf_model('''<model name="mesh"><static>true</static><pose>3 0 1 0 0 0</pose>
      <link name="l"><collision name="c"><geometry><mesh><uri>%s</uri></mesh></geometry>
      <material>glass</material></collision></link></model>''' % path)
    world.add_model(m)
    h = world.raycast((0, 0, 1), (1, 0.1, 0), 10)
    assert h.model == 'mesh' and h.distance == pytest.approx(2.8 * np.sqrt(1.01))
    assert h.material == 'glass'
    assert np.allclose(h.normal, (-1, 0, 0))
    iv = world.segment_intervals((0, 0, 1), (6, 0, 1))
    assert len(iv) == 1 and iv[0][1] - iv[0][0] == pytest.approx(0.4)
    assert iv[0][4] == 'glass'


def test_moving_model_seen_at_once(world):
    m = parse_urdf('''<robot name="blk"><link name="b">
      <inertial><mass value="1"/><inertia ixx="1e-2" iyy="1e-2" izz="1e-2"/></inertial>
      <collision><geometry><box size="0.2 0.2 0.2"/></geometry>
      <material name="wood"/></collision></link></robot>''')
    world.add_model(m, pose=Pose((2, 0, 5)))
    assert world.raycast((0, 0, 5), (1, 0, 0), 10).distance == pytest.approx(1.9)
    assert world.raycast((0, 0, 5), (1, 0, 0), 10).material == 'wood'
    world.set_state('blk', Pose((4, 0, 5)))                         # teleport, no step
    assert world.raycast((0, 0, 5), (1, 0, 0), 10).distance == pytest.approx(3.9)
    world.step(300)                                                # it falls 0.44 m
    z = world.model_state('blk')[0].p[2]
    h = world.raycast((0, 0, z), (1, 0, 0), 10)
    assert h is not None and h.distance == pytest.approx(3.9, abs=1e-3)
    assert world.raycast((0, 0, 5), (1, 0, 0), 10) is None
    world.delete_model('blk')
    assert world.raycast((0, 0, z), (1, 0, 0), 10) is None


def test_office_walls(world):
    world.load_world_file(worlds.OFFICE)
    # from the desk westwards: the inner drywall wall (x 1.4..1.6), then the west wall (x < 0)
    h = world.raycast((3.32, -1.0, 1.5), (-1, 0, 0), 20)
    assert (h.model, h.material) == ('inner_wall', 'drywall')
    assert h.distance == pytest.approx(3.32 - 1.6)
    h = world.raycast((3.32, -1.0, 1.5), (-1, 0, 0), 20, ignore=('inner_wall',))
    assert h.model == 'walls' and h.link == 'west' and h.distance == pytest.approx(3.32)
    iv = world.segment_intervals((3.0, -1.0, 1.5), (-3.0, -1.0, 1.5))
    assert [(i[2], i[3]) for i in iv] == [('inner_wall', 'wall'), ('walls', 'west')]
    assert iv[0][1] - iv[0][0] == pytest.approx(0.2)
    assert iv[1][1] - iv[1][0] == pytest.approx(0.1)
    # through the inner door (y > -0.1) nothing but the west wall
    iv = world.segment_intervals((3.0, 0.5, 1.5), (-3.0, 0.5, 1.5))
    assert [(i[2], i[3]) for i in iv] == [('walls', 'west')]


def test_bad_input(world):
    with pytest.raises(ValueError):
        world.raycast((0, 0, 0), (0, 0, 0), 1)
    with pytest.raises(ValueError):
        world.segment_intervals((0, 0, np.nan), (1, 0, 0))
    assert world.segment_intervals((1, 1, 1), (1, 1, 1)) == []


def test_caster_standalone():
    with worlds.opened('ode', 1) as w:
        w.add_model(wall('w', 1.0, 0.1))
        c = RayCaster(w)
        assert c.raycast((0, 0, 1), (1, 0, 0), 5).distance == pytest.approx(0.95)
