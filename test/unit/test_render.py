"""Offscreen renderer (sim_world.render): exact pinhole projection, depth, lights, textures,
video texture faces, meshes (OBJ/STL/DAE written here), model removal. No roscore; one
OSMesa context for the whole process, small images so the file runs in a few seconds."""
import math

import cv2
import numpy as np
import pytest

from sim_world.model import Geometry, Light, Link, Material, Model, Visual
from sim_world.render import CameraView, Renderer, get_context, shapes
from sim_world.transforms import Pose

from meshfiles import write_dae

RED = Material((1.0, 0.0, 0.0, 1.0), lit=False)


def _model(name, geometry, pose, material=None, base_dir=None, link='base'):
    vis = Visual(geometry, material=material or Material((0.8, 0.8, 0.8, 1.0), name='grey'))
    return Model(name, links={link: Link(link, visuals=[vis])}, pose=pose, base_dir=base_dir)


def _centroid(mask):
    ys, xs = np.nonzero(mask)
    assert len(xs) > 3, 'object not visible'
    return xs.mean(), ys.mean()


def _red(rgb):
    return (rgb[:, :, 0] > 200) & (rgb[:, :, 1] < 60) & (rgb[:, :, 2] < 60)


# --- the projection is the pinhole camera_info describes ----------------------------------
CASES = [
    # width, height, hfov deg, cx, cy, camera pose (xyz, rpy), point in world
    (160, 120, 60.0, None, None, ((0, 0, 0), (0, 0, 0)), (2.0, 0.4, -0.3)),
    (120, 200, 45.0, None, None, ((1, 2, 0.5), (0, 0, 1.0)), (1.5, 4.0, 0.2)),
    (200, 100, 90.0, 70.0, 40.0, ((0, 0, 1), (0, 0.5, 0)), (2.0, -0.9, 0.2)),
    (97, 61, 30.0, 50.3, 27.8, ((0, 0, 0), (0.3, 0, 0)), (3.0, 0.2, 0.1)),
]


@pytest.mark.parametrize('w,h,hfov,cx,cy,cam,point', CASES)
def test_point_lands_on_the_pixel_camera_info_predicts(w, h, hfov, cx, cy, cam, point):
    r = Renderer()
    r.add_model(_model('ball', Geometry('sphere', radius=0.025), Pose(point), RED))
    view = CameraView(w, h, math.radians(hfov), Pose.from_xyz_rpy(*cam), cx=cx, cy=cy,
                      background=(0, 0, 0))
    # prediction from the camera_info numbers alone: K and the optical-frame point
    f = w / (2 * math.tan(math.radians(hfov) / 2))
    ccx = (w - 1) / 2.0 if cx is None else cx
    ccy = (h - 1) / 2.0 if cy is None else cy
    pc = Pose.from_xyz_rpy(*cam).inverse().transform_point(point)   # link frame
    x, y, z = -pc[1], -pc[2], pc[0]                                  # optical frame
    u, v = f * x / z + ccx, f * y / z + ccy
    assert 0 <= u < w and 0 <= v < h
    rgb, depth = r.render(view, depth=True)
    assert rgb.shape == (h, w, 3) and rgb.dtype == np.uint8
    gu, gv = _centroid(_red(rgb))
    assert abs(gu - u) < 1.0 and abs(gv - v) < 1.0, ((gu, gv), (u, v))
    # depth along the optical axis at the centre of the sphere: z minus (about) the radius
    d = depth[int(round(v)), int(round(u))]
    assert abs(d - (z - 0.025)) < 0.01, (d, z)
    assert np.isinf(depth[0, 0]) and depth.dtype == np.float32
    r.remove_model('ball')


def test_a_thread_that_reuses_an_ended_threads_id_still_draws():
    """Thread ids come back: a renderer's worker started after another thread that last
    used the context has ended often gets that thread's id. The context must still be
    made current in it (it was not: frames came back from a context current nowhere,
    'NULL pointer access', when the suite ran in another order)."""
    import threading
    ctx = get_context()
    idents, frames = [], []
    for i in range(4):
        r = Renderer()
        r.add_model(_model('ball%d' % i, Geometry('sphere', radius=0.3), Pose((2, 0, 0)), RED))
        done = threading.Event()

        def keep(rgb, depth, done=done):
            frames.append(_red(rgb).sum())
            done.set()
        r.submit(CameraView(40, 40, math.radians(60), Pose(), background=(0, 0, 0)), keep)
        assert done.wait(10)
        idents.append(r._worker.ident)
        r._jobs.put(None)                 # the worker ends; nothing else touches the context
        r._worker.join(10)
        r._worker = None
    assert len(set(idents)) < len(idents), 'no thread id came back: the case is not shown'
    assert len(frames) == 4 and min(frames) > 50, frames
    with ctx:                             # and the thread that made the context still can
        ctx.target(3, 3)


def test_camera_looks_along_link_x_with_z_up():
    r = Renderer()
    # red ball ahead (+x) and above (+z): top half of the image; nothing behind the camera
    r.add_model(_model('up', Geometry('sphere', radius=0.1), Pose((2, 0, 0.5)), RED))
    r.add_model(_model('left', Geometry('sphere', radius=0.1), Pose((2, 0.5, 0)),
                       Material((0, 1, 0, 1), lit=False)))
    r.add_model(_model('behind', Geometry('sphere', radius=0.5), Pose((-2, 0, 0)),
                       Material((0, 0, 1, 1), lit=False)))
    rgb = r.render(CameraView(100, 100, math.radians(90), Pose(), background=(0, 0, 0)))
    u, v = _centroid(_red(rgb))
    assert v < 45 and abs(u - 49.5) < 1
    ys, xs = np.nonzero((rgb[:, :, 1] > 200) & (rgb[:, :, 0] < 60))
    assert xs.mean() < 45 and abs(ys.mean() - 49.5) < 1     # +y (left) is left in the image
    assert not ((rgb[:, :, 2] > 200) & (rgb[:, :, 0] < 60)).any()


def test_background_colour_and_set_background():
    r = Renderer()
    rgb = r.render(CameraView(8, 6, 1.0, background=(1.0, 0.0, 0.5)))
    assert (rgb == [255, 0, 128]).all()
    r.set_background((0.0, 1.0, 0.0))
    assert (r.render(CameraView(8, 6, 1.0)) == [0, 255, 0]).all()


def test_link_poses_move_visuals_and_remove_model():
    r = Renderer()
    m = _model('b', Geometry('box', size=(0.2, 0.2, 0.2)), Pose((2, 0, 0)), RED, link='l')
    r.add_model(m)
    view = CameraView(80, 60, math.radians(60), background=(0, 0, 0))
    u0, _ = _centroid(_red(r.render(view)))
    r.set_link_poses('b', {'l': Pose((2, -0.5, 0))})      # to the right
    u1, _ = _centroid(_red(r.render(view)))
    assert u1 > u0 + 5
    r.remove_model('b')
    assert not _red(r.render(view)).any()
    assert r.model_names() == []


# --- lights ---------------------------------------------------------------------------------
def _lit_plate(r, normal_towards_camera=True):
    # a white box face looking at the camera (camera at origin looking +x): its -x face
    r.add_model(_model('plate', Geometry('box', size=(0.1, 1, 1)), Pose((2, 0, 0)),
                       Material((1, 1, 1, 1), name='white')))


def _mean_centre(rgb):
    h, w = rgb.shape[:2]
    return rgb[h // 3:2 * h // 3, w // 3:2 * w // 3].astype(float).mean()


def test_directional_light_ambient_and_point_light():
    view = CameraView(60, 60, math.radians(30), background=(0, 0, 0))
    r = Renderer()
    _lit_plate(r)
    r.set_lights([], ambient=(0.0, 0.0, 0.0), default_sun=False)
    dark = _mean_centre(r.render(view))
    assert dark < 5
    r.set_lights([], ambient=(0.3, 0.3, 0.3), default_sun=False)
    amb = _mean_centre(r.render(view))
    assert 60 < amb < 95          # 0.3 * 255
    # a sun shining along +x lights the face turned away from it? no: the -x face is lit by
    # light travelling along +x (coming from the camera side)
    sun = Light('sun', 'directional', direction=(1, 0, 0), diffuse=(0.6, 0.6, 0.6, 1))
    r.set_lights([sun], ambient=(0.3, 0.3, 0.3))
    lit = _mean_centre(r.render(view))
    assert lit > amb + 100
    away = Light('sun', 'directional', direction=(-1, 0, 0), diffuse=(0.6, 0.6, 0.6, 1))
    r.set_lights([away], ambient=(0.3, 0.3, 0.3))
    assert abs(_mean_centre(r.render(view)) - amb) < 3
    # point light in front of the plate, falling off with distance
    near = Light('bulb', 'point', pose=Pose((1.5, 0, 0)), diffuse=(1, 1, 1, 1),
                 attenuation=(0.0, 0.0, 1.0))
    far = Light('bulb', 'point', pose=Pose((0.0, 0, 0)), diffuse=(1, 1, 1, 1),
                attenuation=(0.0, 0.0, 1.0))
    r.set_lights([near], ambient=(0, 0, 0))
    b_near = _mean_centre(r.render(view))
    r.set_lights([far], ambient=(0, 0, 0))
    b_far = _mean_centre(r.render(view))
    assert b_near > 200 and 30 < b_far < 100     # 1/0.5^2 saturates, 1/1.95^2 = 0.26


def test_default_sun_when_no_lights_given():
    view = CameraView(60, 60, math.radians(30), Pose.from_xyz_rpy((2, 0, 3), (0, math.pi / 2, 0)),
                      background=(0, 0, 0))
    r = Renderer()
    r.add_model(_model('top', Geometry('box', size=(1, 1, 0.1)), Pose((2, 0, 0)),
                       Material((1, 1, 1, 1), name='white')))
    r.set_lights([], ambient=(0.2, 0.2, 0.2))          # default sun from above
    assert _mean_centre(r.render(view)) > 150


# --- textures -------------------------------------------------------------------------------
def _quadrants(h=64, w=64):
    img = np.zeros((h, w, 3), np.uint8)
    img[:h // 2, :w // 2] = (255, 0, 0)        # top-left red
    img[:h // 2, w // 2:] = (0, 255, 0)        # top-right green
    img[h // 2:, :w // 2] = (0, 0, 255)        # bottom-left blue
    img[h // 2:, w // 2:] = (255, 255, 0)      # bottom-right yellow
    return img


def _looking_down(height=2.0, size=100):
    # camera above the origin looking down (-z); image up = world +x, image right = -y
    return CameraView(size, size, math.radians(60),
                      Pose.from_xyz_rpy((0, 0, height), (0, math.pi / 2, 0)),
                      background=(0, 0, 0))


def _colour_at(rgb, u, v):
    return rgb[int(v), int(u)].astype(int)


def test_dynamic_texture_on_front_face_unlit_and_upright():
    r = Renderer()
    r.set_lights([], ambient=(0, 0, 0), default_sun=False)    # dark world
    # a phone-like box: long along x, display on +z
    r.add_model(_model('phone', Geometry('box', size=(1.0, 0.6, 0.05)), Pose(), link='body'))
    view = _looking_down()
    assert r.render(view).max() < 5                           # unlit box in the dark
    r.set_dynamic_texture('phone', 'body', _quadrants(), face='front')
    rgb = r.render(view)
    # seen from above with +x up in the image: the picture stands upright, unmirrored
    c = (49.5, 49.5)
    assert list(_colour_at(rgb, c[0] - 10, c[1] - 15)) == [255, 0, 0]
    assert list(_colour_at(rgb, c[0] + 10, c[1] - 15)) == [0, 255, 0]
    assert list(_colour_at(rgb, c[0] - 10, c[1] + 15)) == [0, 0, 255]
    assert list(_colour_at(rgb, c[0] + 10, c[1] + 15)) == [255, 255, 0]
    # replacing the picture, RGBA input, then back to the material
    rgba = np.zeros((10, 20, 4), np.uint8)
    rgba[:] = (10, 200, 30, 255)
    r.set_dynamic_texture('phone', 'body', rgba, face='+z')
    assert list(_colour_at(r.render(view), *c)) == [10, 200, 30]
    r.set_dynamic_texture('phone', 'body', None)
    assert r.render(view).max() < 5


def test_dynamic_texture_only_on_the_chosen_face():
    r = Renderer()
    r.set_lights([], ambient=(0, 0, 0), default_sun=False)
    r.add_model(_model('cube', Geometry('box', size=(0.5, 0.5, 0.5)), Pose(), link='body'))
    top = _looking_down()
    side = CameraView(100, 100, math.radians(60), Pose((-2, 0, 0)), background=(0, 0, 0))
    white = np.full((4, 4, 3), 255, np.uint8)
    r.set_dynamic_texture('cube', 'body', white, face='-x')
    assert r.render(top).max() < 5 and r.render(side)[45:55, 45:55].min() > 250
    r.set_dynamic_texture('cube', 'body', white, face='all')
    assert r.render(top)[45:55, 45:55].min() > 250
    with pytest.raises(ValueError):
        r.set_dynamic_texture('cube', 'body', white, face='diagonal')
    with pytest.raises(ValueError):
        r.set_dynamic_texture('cube', 'body', np.zeros((4, 4), np.float32))


def test_material_texture_png_and_jpeg(tmp_path):
    for ext in ('png', 'jpg'):
        path = str(tmp_path / ('quad.' + ext))
        cv2.imwrite(path, _quadrants(128, 128)[:, :, ::-1])
        r = Renderer()
        mat = Material((1, 1, 1, 1), texture='quad.' + ext, name='tex', lit=False)
        r.add_model(_model('t' + ext, Geometry('box', size=(1, 1, 0.05)), Pose(), mat,
                           base_dir=str(tmp_path)))
        rgb = r.render(_looking_down()).astype(int)
        tol = 2 if ext == 'png' else 40
        assert np.abs(_colour_at(rgb, 35, 35) - [255, 0, 0]).max() <= tol
        assert np.abs(_colour_at(rgb, 64, 64) - [255, 255, 0]).max() <= tol


def test_missing_texture_and_mesh_are_logged_and_the_rest_shows(tmp_path, caplog):
    r = Renderer()
    m = Model('broken', links={'a': Link('a', visuals=[
        Visual(Geometry('mesh', filename='nothere.stl'), material=RED),
        Visual(Geometry('box', size=(0.5, 0.5, 0.05)),
               material=Material((1, 0, 0, 1), texture='nothere.png', lit=False))])},
        base_dir=str(tmp_path))
    assert r.add_model(m) == 1
    assert 'nothere.stl' in caplog.text and 'nothere.png' in caplog.text
    assert _red(r.render(_looking_down())).sum() > 100       # drawn in its colour


# --- meshes written here: OBJ without normals, open STL, Collada with unit and up axis -----
def _cube_tris(s=0.1):
    b = shapes.box((2 * s, 2 * s, 2 * s))          # small: one cell per face, 12 triangles
    return b.positions.reshape(-1, 3, 3)


def _write_obj(path, tris):
    verts, lines = [], []
    for t in tris:
        for p in t:
            verts.append('v %.6f %.6f %.6f' % tuple(p))
    for i in range(len(tris)):
        lines.append('f %d %d %d' % (3 * i + 1, 3 * i + 2, 3 * i + 3))
    with open(path, 'w') as f:
        f.write('\n'.join(verts + lines) + '\n')


def _write_stl(path, tris):
    with open(path, 'w') as f:
        f.write('solid t\n')
        for t in tris:
            f.write(' facet normal 0 0 0\n  outer loop\n')
            for p in t:
                f.write('   vertex %.6f %.6f %.6f\n' % tuple(p))
            f.write('  endloop\n endfacet\n')
        f.write('endsolid t\n')


def test_obj_without_normals_gets_flat_faces_and_outward_normals(tmp_path):
    tris = _cube_tris()
    tris[::2] = tris[::2, ::-1]              # scramble the winding of every other triangle
    _write_obj(str(tmp_path / 'cube.obj'), tris)
    md = shapes.load_mesh(str(tmp_path / 'cube.obj'))
    assert md.count == 36 and not md.double_sided            # closed: culled, one-sided
    centres = md.positions.reshape(-1, 3, 3).mean(axis=1)
    nz = md.normals.reshape(-1, 3, 3)
    # every corner normal equals its face's outward axis (flat faces, winding repaired)
    axis = np.zeros_like(centres)
    k = np.abs(centres).argmax(axis=1)
    axis[np.arange(len(k)), k] = np.sign(centres[np.arange(len(k)), k])
    assert np.allclose(nz, axis[:, None, :], atol=1e-6)
    # rendered: the lit top face is one flat shade
    r = Renderer()
    r.add_model(_model('obj', Geometry('mesh', filename='cube.obj'), Pose(), base_dir=str(tmp_path)))
    r.set_lights([Light('s', direction=(0, 0, -1))], ambient=(0.2, 0.2, 0.2))
    rgb = r.render(_looking_down(height=0.6))
    patch = rgb[40:60, 40:60].astype(int)
    assert patch.max() - patch.min() <= 2 and patch.mean() > 150


def _hemisphere(radius=0.5, n=24):
    sph = shapes.sphere(radius, slices=n, stacks=n)
    tris = sph.positions.reshape(-1, 3, 3)
    return tris[tris[:, :, 2].mean(axis=1) < 0]               # the lower half: an open bowl


def test_open_stl_is_drawn_and_lit_from_both_sides(tmp_path):
    tris = _hemisphere()
    _write_stl(str(tmp_path / 'bowl.stl'), tris)
    md = shapes.load_mesh(str(tmp_path / 'bowl.stl'))
    assert md.double_sided
    r = Renderer()
    r.add_model(_model('bowl', Geometry('mesh', filename='bowl.stl'), Pose(), base_dir=str(tmp_path)))
    r.set_lights([Light('s', direction=(0, 0, -1))], ambient=(0.2, 0.2, 0.2))
    inside = r.render(_looking_down(height=1.5))             # looking into the bowl
    below = r.render(CameraView(100, 100, math.radians(60),
                                Pose.from_xyz_rpy((0, 0, -3), (0, -math.pi / 2, 0)),
                                background=(0, 0, 0)))       # from below: the unlit outside
    # inside, lit from above: the bottom of the bowl faces the light (bright, smooth)
    centre = inside[40:60, 40:60, 0].astype(int)
    assert centre.mean() > 150
    # smooth shading: no jumps between neighbouring pixels (flat facets would show steps)
    assert np.abs(np.diff(centre, n=2, axis=0)).max() <= 3
    assert np.abs(np.diff(centre, n=2, axis=1)).max() <= 3
    # the outside is visible (not culled away) but only ambient-lit
    assert 30 < below[45:55, 45:55].mean() < 70


def test_inconsistent_winding_renders_like_consistent(tmp_path):
    good = _hemisphere()
    bad = good.copy()
    bad[1::3] = bad[1::3, ::-1]
    _write_stl(str(tmp_path / 'good.stl'), good)
    _write_stl(str(tmp_path / 'bad.stl'), bad)
    imgs = []
    for name in ('good', 'bad'):
        r = Renderer()
        r.add_model(_model(name, Geometry('mesh', filename=name + '.stl'), Pose(),
                           base_dir=str(tmp_path)))
        r.set_lights([Light('s', direction=(0.3, 0, -1))], ambient=(0.2, 0.2, 0.2))
        imgs.append(r.render(_looking_down(height=3.0)).astype(int))
    assert np.abs(imgs[0] - imgs[1]).max() <= 3


@pytest.mark.parametrize('unit,up', [(1.0, 'Z_UP'), (0.01, 'Z_UP'), (1.0, 'Y_UP'),
                                     (0.001, 'Y_UP')])
def test_collada_unit_and_up_axis(tmp_path, unit, up):
    # a bar 1 m long along the file's up axis, 0.2 m thick, written in the file's units
    tris = shapes.box((0.2, 0.2, 1.0) if up == 'Z_UP' else (0.2, 1.0, 0.2)).positions
    tris = tris.reshape(-1, 3, 3) / unit
    write_dae(str(tmp_path / 'bar.dae'), tris, unit, up)
    md = shapes.load_mesh(str(tmp_path / 'bar.dae'), scale=(1, 1, 1))
    lo, hi = md.bounds()
    assert np.allclose(hi - lo, (0.2, 0.2, 1.0), atol=1e-5), (lo, hi)   # upright, metres
    assert not md.double_sided
    # and the scale of the <mesh scale> applies on top
    md2 = shapes.load_mesh(str(tmp_path / 'bar.dae'), scale=(2, 1, 0.5))
    lo, hi = md2.bounds()
    assert np.allclose(hi - lo, (0.4, 0.2, 0.5), atol=1e-5)


def test_mesh_errors_name_the_file(tmp_path):
    with pytest.raises(shapes.MeshLoadError, match='nothere.obj'):
        shapes.load_mesh(str(tmp_path / 'nothere.obj'))
    p = tmp_path / 'junk.stl'
    p.write_bytes(b'\x00' * 10)
    with pytest.raises(shapes.MeshLoadError, match='junk.stl'):
        shapes.load_mesh(str(p))


def test_crease_normals_smooth_curves_flat_edges():
    sph = shapes.sphere(1.0, 16, 8)
    v = sph.positions.astype(float)
    f = np.arange(len(v)).reshape(-1, 3)
    n = shapes.crease_normals(v, f, 40.0)
    # on a sphere the smoothed normal points along the position
    assert np.abs(np.einsum('ij,ij->i', n, v / np.linalg.norm(v, axis=1)[:, None]) - 1).max() < 0.02
    cyl = shapes.cylinder(1.0, 1.0, 32)
    n = shapes.crease_normals(cyl.positions, np.arange(cyl.count).reshape(-1, 3), 40.0)
    assert np.allclose(n, cyl.normals, atol=0.02)     # smooth side, flat caps


def test_context_targets_and_readback():
    ctx = get_context()
    assert 'llvmpipe' in ctx.renderer_name or 'softpipe' in ctx.renderer_name or ctx.renderer_name
    from OpenGL import GL
    with ctx:
        ctx.target(7, 5)
        GL.glClearColor(0.0, 0.0, 1.0, 1.0)
        GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
        GL.glEnable(GL.GL_SCISSOR_TEST)
        GL.glScissor(0, 4, 7, 1)             # GL row 4 = the top row of the image
        GL.glClearColor(1.0, 0.0, 0.0, 1.0)
        GL.glClear(GL.GL_COLOR_BUFFER_BIT)
        GL.glDisable(GL.GL_SCISSOR_TEST)
        rgb = ctx.read_rgb(7, 5)
        depth = ctx.read_depth(7, 5, 0.1, 10.0)
    assert rgb.shape == (5, 7, 3)
    assert (rgb[0] == [255, 0, 0]).all() and (rgb[1:] == [0, 0, 255]).all()
    assert np.isinf(depth).all()
    assert get_context() is ctx


def test_obj_with_mtl_texture_uses_the_files_texture(tmp_path):
    (tmp_path / 'quad.obj').write_text(
        'mtllib quad.mtl\nv -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n'
        'vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n')
    (tmp_path / 'quad.mtl').write_text('newmtl m\nKd 1 1 1\nmap_Kd quad.png\n')
    cv2.imwrite(str(tmp_path / 'quad.png'), _quadrants(64, 64)[:, :, ::-1])
    r = Renderer()
    r.set_lights([], ambient=(1, 1, 1), default_sun=False)    # full ambient: texture colours
    vis = Visual(Geometry('mesh', filename='quad.obj'))       # no material: the file's
    r.add_model(Model('q', links={'l': Link('l', visuals=[vis])}, base_dir=str(tmp_path)))
    rgb = r.render(_looking_down(height=1.5)).astype(int)
    # texture top (v = 1) lies at +y = image left, its left (u = 0) at -x = image bottom
    assert np.abs(_colour_at(rgb, 40, 60) - [255, 0, 0]).max() < 10        # top-left: red
    assert np.abs(_colour_at(rgb, 40, 40) - [0, 255, 0]).max() < 10        # top-right: green
    assert np.abs(_colour_at(rgb, 60, 60) - [0, 0, 255]).max() < 10        # bottom-left: blue
    assert np.abs(_colour_at(rgb, 60, 40) - [255, 255, 0]).max() < 10      # bottom-right


@pytest.mark.parametrize('face,up', [('+x', (0, 0, 1)), ('-x', (0, 0, 1)), ('+y', (0, 0, 1)),
                                     ('-y', (0, 0, 1)), ('+z', (1, 0, 0)), ('-z', (-1, 0, 0))])
def test_every_face_shows_the_image_upright_and_unmirrored(face, up):
    """Seen from outside with the documented 'up' (Gazebo's box layout) at the top of the
    camera image, the picture on a face reads as it is."""
    r = Renderer()
    r.set_lights([], ambient=(0, 0, 0), default_sun=False)
    r.add_model(_model('cube', Geometry('box', size=(1, 1, 1)), Pose(), link='body'))
    r.set_dynamic_texture('cube', 'body', _quadrants(), face=face)
    n = np.zeros(3)
    n['xyz'.index(face[1])] = 1.0 if face[0] == '+' else -1.0
    x = -n                                   # the camera link looks at the face
    z = np.asarray(up, float)                # and has the face's up as its up
    m = np.eye(4)
    m[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    m[:3, 3] = 2.5 * n
    rgb = r.render(CameraView(100, 100, math.radians(40), Pose.from_matrix(m),
                              background=(0, 0, 0)))
    assert list(_colour_at(rgb, 40, 40)) == [255, 0, 0]       # top-left
    assert list(_colour_at(rgb, 60, 40)) == [0, 255, 0]       # top-right
    assert list(_colour_at(rgb, 40, 60)) == [0, 0, 255]       # bottom-left
    assert list(_colour_at(rgb, 60, 60)) == [255, 255, 0]     # bottom-right


def test_collada_colour_applies_unless_the_visual_names_a_material(tmp_path):
    write_dae(str(tmp_path / 'red.dae'), shapes.box((0.6, 0.6, 0.6)).positions.reshape(-1, 3, 3),
              colour=(0.9, 0.1, 0.1))
    r = Renderer()
    r.set_lights([], ambient=(1, 1, 1), default_sun=False)
    r.add_model(Model('own', links={'l': Link('l', visuals=[
        Visual(Geometry('mesh', filename='red.dae'))])}, base_dir=str(tmp_path)))
    c = _colour_at(r.render(_looking_down()), 49, 49)
    assert np.abs(c - [230, 26, 26]).max() < 4, c
    r.add_model(Model('own', links={'l': Link('l', visuals=[
        Visual(Geometry('mesh', filename='red.dae'), material=Material((0, 0, 1, 1), name='b'))])},
        base_dir=str(tmp_path)))                        # re-added with a URDF material
    assert list(_colour_at(r.render(_looking_down()), 49, 49)) == [0, 0, 255]


def test_state_left_by_other_users_of_the_context_does_not_leak_in():
    from OpenGL import GL
    r = Renderer()
    r.add_model(_model('ball', Geometry('sphere', radius=0.3), Pose((2, 0, 0)), RED))
    view = CameraView(64, 48, math.radians(60), background=(0, 0, 0))
    ref = r.render(view)
    ctx = get_context()
    with ctx:                               # e.g. pcl2image drawing points in between
        ctx.target(64, 48)
        GL.glEnable(GL.GL_SCISSOR_TEST)
        GL.glScissor(0, 0, 1, 1)
        GL.glDisable(GL.GL_DEPTH_TEST)
        GL.glDisable(GL.GL_COLOR_MATERIAL)
        GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_LINE)
        GL.glColorMask(GL.GL_FALSE, GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE)
    try:
        assert np.array_equal(r.render(view), ref)
    finally:
        with ctx:
            GL.glDisable(GL.GL_SCISSOR_TEST)
            GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_FILL)
            GL.glColorMask(GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE)


def test_a_mesh_file_is_read_once_for_many_models(tmp_path, monkeypatch):
    _write_stl(str(tmp_path / 'bowl.stl'), _hemisphere())
    calls = []
    real = shapes.load_mesh
    monkeypatch.setattr(shapes, 'load_mesh', lambda *a, **k: calls.append(a) or real(*a, **k))
    r = Renderer()
    for i in range(3):
        r.add_model(_model('b%d' % i, Geometry('mesh', filename='bowl.stl'), Pose((2, i - 1, 0)),
                           base_dir=str(tmp_path)))
    r.add_model(_model('big', Geometry('mesh', filename='bowl.stl', scale=(2, 2, 2)),
                       Pose((4, 0, 0)), base_dir=str(tmp_path)))
    assert len(calls) == 2                       # one per (file, scale)
    assert r.render(CameraView(40, 30, 1.2, background=(0, 0, 0))).max() > 0


def test_phone_shell_like_the_thesis_nexus_s_renders_from_the_back(tmp_path):
    """The thesis's Collada Nexus S showed a 'faulty back view' in Gazebo (figure 3.3b). A
    phone-shaped shell with the usual CAD export defects -- centimetres, Y_UP, scrambled
    winding, an open side (the back cover missing) -- must show from behind: the inside of
    the front cover, lit, not a hole and not black."""
    shell = shapes.box((6.3, 12.4, 1.1))             # cm; y is the long axis (Y_UP file)
    tris = shell.positions.reshape(-1, 3, 3)
    centres = tris.mean(axis=1)
    # drop the back cover: in the file's frame (Y_UP) the phone's back is -z
    tris = tris[centres[:, 2] > -0.5]
    tris = tris.copy()
    tris[::3] = tris[::3, ::-1]
    write_dae(str(tmp_path / 'phone.dae'), tris, unit=0.01, up='Y_UP', colour=(0.2, 0.2, 0.8))
    md = shapes.load_mesh(str(tmp_path / 'phone.dae'))
    lo, hi = md.bounds()
    # metres, long axis up (z) after the Y_UP fix, thickness along y
    assert np.allclose(hi - lo, (0.063, 0.011, 0.124), atol=1e-4), hi - lo
    assert md.double_sided
    r = Renderer()
    r.set_lights([Light('sun', direction=(0, -1, -0.2))], ambient=(0.3, 0.3, 0.3))
    r.add_model(Model('phone', links={'l': Link('l', visuals=[
        Visual(Geometry('mesh', filename='phone.dae'))])}, base_dir=str(tmp_path)))
    # Y_UP -> Z_UP turns the file's -z (the open back) to +y: look into it from +y, with
    # the sun behind the camera
    back = CameraView(80, 80, math.radians(20), Pose.from_xyz_rpy((0, 0.5, 0), (0, 0, -math.pi / 2)),
                      background=(0, 0, 0))
    inside = r.render(back)[35:45, 35:45].astype(int)
    assert (inside[:, :, 2] > 120).all(), inside[:, :, 2]      # inside of the front: lit
    # the closed front from -y: drawn (ambient only, the sun is on the other side)
    front = CameraView(80, 80, math.radians(20), Pose.from_xyz_rpy((0, -0.5, 0), (0, 0, math.pi / 2)),
                       background=(0, 0, 0))
    outside = r.render(front)[35:45, 35:45].astype(int)
    assert (outside[:, :, 2] > 40).all() and (outside[:, :, 2] < 90).all(), outside[:, :, 2]
