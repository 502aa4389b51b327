"""One mesh loader (sim_world.mesh) for physics and rendering: a Collada file in centimetres
with Y up (like the thesis's Nexus S export) collides exactly where it is drawn, on both
physics engines. Before the shared loader, physics read the raw file (no <unit>, no
<up_axis>): the mesh drawn 0.2 m long collided 20 m long and lying on its side.
No roscore, no OpenGL context (the drawn extent is the renderer's MeshData)."""
import numpy as np
import pytest

from sim_world import mesh as smesh
from sim_world.model import Collision, Geometry, Inertial, Link, Model, ModelError, sphere_inertia
from sim_world.physics import ENGINES, lump_model, make_engine
from sim_world.render import shapes
from sim_world.transforms import Pose

from meshfiles import write_dae

DT = 0.001
R = 0.005            # radius of the probe balls


@pytest.fixture
def slab_dae(tmp_path):
    """A slab written like a CAD export: centimetres, Y_UP, scrambled winding. In the file:
    20 cm along x, 2 cm along y (up), 10 cm along z -> drawn 0.2 x 0.1 x 0.02 m, flat."""
    tris = shapes.box((20.0, 2.0, 10.0)).positions.reshape(-1, 3, 3).copy()
    tris[::3] = tris[::3, ::-1]
    path = str(tmp_path / 'slab.dae')
    write_dae(path, tris, unit=0.01, up='Y_UP')
    smesh.clear_cache()
    return path


def _drawn_extent(path, scale=(1, 1, 1)):
    lo, hi = shapes.load_mesh(path, scale).bounds()
    return np.asarray(lo, float), np.asarray(hi, float)


def test_drawn_extent_is_metres_z_up(slab_dae):
    lo, hi = _drawn_extent(slab_dae)
    assert np.allclose(hi - lo, (0.2, 0.1, 0.02), atol=1e-6), (lo, hi)


@pytest.mark.parametrize('scale', [(1, 1, 1), (2.0, 1.0, 0.5)])
def test_collision_mesh_equals_drawn_mesh(slab_dae, scale):
    body = lump_model(Model('slab', {'l': Link('l', collisions=[
        Collision(Geometry('mesh', filename=slab_dae, scale=scale))])}, static=True))
    verts, faces = body.shapes[0].mesh
    lo, hi = _drawn_extent(slab_dae, scale)
    assert np.allclose(verts.min(axis=0), lo, atol=1e-6)
    assert np.allclose(verts.max(axis=0), hi, atol=1e-6)
    assert faces.shape[1] == 3 and faces.max() < len(verts)
    assert len(np.unique(np.round(verts, 9), axis=0)) == len(verts)   # merged by position


def _ball(name, xy, z):
    i = sphere_inertia(0.01, R)
    return Model(name, {'l': Link('l', Inertial(0.01, ixx=i[0], iyy=i[1], izz=i[2]),
                                  collisions=[Collision(Geometry('sphere', radius=R))])},
                 pose=Pose((xy[0], xy[1], z)))


@pytest.mark.parametrize('engine_name', ENGINES)
def test_static_cm_y_up_mesh_collides_where_it_is_drawn(engine_name, slab_dae):
    """Balls dropped just inside the drawn outline rest on the drawn top face; balls just
    outside it fall past (ODE: voxel boxes, exact for a box; Bullet: triangle mesh)."""
    lo, hi = _drawn_extent(slab_dae)
    e = make_engine(engine_name, DT, (0.0, 0.0, -9.81))
    try:
        e.add_model(Model('slab', {'l': Link('l', collisions=[
            Collision(Geometry('mesh', filename=slab_dae))])}, static=True))
        m = 0.01
        inside = {'in_c': (0.0, 0.0), 'in_x': (hi[0] - m, 0.0), 'in_y': (0.0, lo[1] + m)}
        outside = {'out_x': (hi[0] + R + m, 0.0), 'out_mx': (lo[0] - R - m, 0.0),
                   'out_y': (0.0, hi[1] + R + m)}
        for name, xy in list(inside.items()) + list(outside.items()):
            e.add_model(_ball(name, xy, hi[2] + R + 0.02))
        e.step(600)
        for name in inside:
            z = e.model_pose(name).p[2]
            assert abs(z - (hi[2] + R)) < 2e-3, (engine_name, name, z, hi[2] + R)
        for name in outside:
            z = e.model_pose(name).p[2]
            assert z < lo[2] - 0.5, (engine_name, name, z)
    finally:
        e.close()


@pytest.mark.parametrize('engine_name', ENGINES)
def test_moving_cm_y_up_mesh_rests_on_its_drawn_bottom(engine_name, slab_dae):
    """A dynamic body with the mesh (Bullet: convex hull) settles on the ground with its
    centre at half the drawn thickness (0.01 m), not at 5 m (the raw file's 10 cm -> 10 m)."""
    lo, hi = _drawn_extent(slab_dae)
    e = make_engine(engine_name, DT, (0.0, 0.0, -9.81))
    try:
        e.add_model(Model('ground', {'l': Link('l', collisions=[
            Collision(Geometry('plane', size=(10, 10)))])}, static=True))
        e.add_model(Model('slab', {'l': Link('l', Inertial(0.1, ixx=1e-4, iyy=3e-4, izz=4e-4),
                                             collisions=[Collision(
                                                 Geometry('mesh', filename=slab_dae))])},
                          pose=Pose((0, 0, (hi[2] - lo[2]) / 2 + 0.01))))
        e.step(800)
        z = e.model_pose('slab').p[2]
        assert abs(z - (hi[2] - lo[2]) / 2) < 2e-3, (engine_name, z)
    finally:
        e.close()


def test_one_read_per_file_and_scale(slab_dae, monkeypatch):
    calls = []
    real = smesh._read
    monkeypatch.setattr(smesh, '_read', lambda *a: calls.append(a) or real(*a))
    shapes.load_mesh(slab_dae)
    lump_model(Model('s', {'l': Link('l', collisions=[
        Collision(Geometry('mesh', filename=slab_dae))])}, static=True))
    shapes.load_mesh(slab_dae, (1.0, 1.0, 1.0))
    assert len(calls) == 1                       # renderer and physics share the read
    shapes.load_mesh(slab_dae, (2.0, 1.0, 1.0))
    assert len(calls) == 2


def test_unreadable_mesh_names_the_file(tmp_path):
    p = tmp_path / 'junk.stl'
    p.write_bytes(b'\x00' * 10)
    with pytest.raises(smesh.MeshLoadError, match='junk.stl'):
        smesh.load(str(p))
    with pytest.raises(ModelError, match='junk.stl'):
        lump_model(Model('j', {'l': Link('l', collisions=[
            Collision(Geometry('mesh', filename=str(p)))])}, static=True))
    with pytest.raises(smesh.MeshLoadError, match='nothere.dae'):
        smesh.load(str(tmp_path / 'nothere.dae'))
