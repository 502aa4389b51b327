"""Scene of model visuals drawn with the shared OSMesa context (fixed-function GL + VBOs).

Lighting is OpenGL's fixed-function model (per vertex; big box faces and planes are split
into grids by ``shapes`` so point lights stay smooth): on llvmpipe it is many times faster
than an equivalent per-pixel GLSL shader, which was measured at 10-60 fps for a full
480x800 frame against 150-300 fps here. Spot lights and projectors are per pixel: an
additive projective-texturing pass each (the spot's cone as an image, ``cone_image``), with
a shadow map for occlusion (projectors always, spots with ``spot_shadows``); with
``sun_shadows`` directional lights are such a pass too (no image, an orthographic map).

Threading: every public method may be called from any thread; all GL work happens under
the context lock. Images handed in by ROS callbacks (``set_dynamic_texture``) are uploaded
by the next ``render()``.
"""
import ctypes
import logging
import math
import sys
import threading

import cv2
import numpy as np

from ..transforms import Pose, quat_to_matrices
from . import shapes
from .context import get_context, linearize_depth

__all__ = ['CameraView', 'Renderer', 'DEFAULT_SUN', 'cone_image']

log = logging.getLogger('sim_world.render')

# Gazebo's default sun: a directional light from above, slightly from the side.
DEFAULT_SUN = dict(direction=(-0.5, 0.1, -0.9), diffuse=(0.8, 0.8, 0.8, 1.0),
                   specular=(0.2, 0.2, 0.2, 1.0))
DEFAULT_AMBIENT = (0.4, 0.4, 0.4)
SWITCH_INTERVAL = 0.0005        # s; see Renderer.submit
DEFAULT_BACKGROUND = (0.7, 0.7, 0.75)

# GL eye frame (x right, y up, looking along -z) from the camera link frame (Gazebo: the
# camera looks along the link's +x, z is up in the image).
EYE_FROM_LINK = np.array([[0.0, -1.0, 0.0, 0.0],
                          [0.0, 0.0, 1.0, 0.0],
                          [-1.0, 0.0, 0.0, 0.0],
                          [0.0, 0.0, 0.0, 1.0]])


class CameraView(object):
    """A pinhole camera: image size, horizontal field of view (radians), world pose of the
    camera link (looking along its +x, z up), clip planes, principal point (pixels, OpenCV
    convention: pixel centres at integer coordinates; None = image centre (w-1)/2, (h-1)/2),
    background colour (rgb 0..1; None = the renderer's, see ``Renderer.set_background``).
    ``fx``/``fy`` override the focal length (pixels) that
    ``hfov`` gives: f = width / (2 tan(hfov / 2)); fy = fx (square pixels)."""

    def __init__(self, width, height, hfov=math.radians(60), pose=None, near=0.02, far=100.0,
                 cx=None, cy=None, background=None, fx=None, fy=None):
        self.width, self.height = int(width), int(height)
        if self.width <= 0 or self.height <= 0:
            raise ValueError('camera image size must be positive, got %dx%d'
                             % (self.width, self.height))
        self.hfov = float(hfov)
        if fx is None and not (0.0 < self.hfov < math.pi):
            raise ValueError('hfov must be between 0 and pi radians, got %r' % hfov)
        if not (0 < near < far):
            raise ValueError('clip planes must satisfy 0 < near < far, got %r, %r' % (near, far))
        self.pose = pose if pose is not None else Pose()
        self.near, self.far = float(near), float(far)
        self.cx = (self.width - 1) / 2.0 if cx is None else float(cx)
        self.cy = (self.height - 1) / 2.0 if cy is None else float(cy)
        self.fx = float(fx) if fx is not None else self.width / (2.0 * math.tan(self.hfov / 2.0))
        self.fy = float(fy) if fy is not None else self.fx
        self.background = tuple(background) if background is not None else None

    def K(self):
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def projection_matrix(self, flip_y=False):
        """4x4 OpenGL projection (row-major math) built from K, so a point in the camera
        frame lands on the pixel K predicts (OpenCV pixel centres: GL pixel i spans
        [i, i+1], its centre i + 0.5 is OpenCV's u = i). flip_y: row 0 of the GL
        framebuffer becomes the image's top row."""
        w, h, n, f = self.width, self.height, self.near, self.far
        cxg, cyg = self.cx + 0.5, self.cy + 0.5
        P = np.array([
            [2.0 * self.fx / w, 0.0, 1.0 - 2.0 * cxg / w, 0.0],
            [0.0, 2.0 * self.fy / h, 2.0 * cyg / h - 1.0, 0.0],
            [0.0, 0.0, -(f + n) / (f - n), -2.0 * f * n / (f - n)],
            [0.0, 0.0, -1.0, 0.0]])
        if flip_y:
            P[1] = -P[1]
        return P

    def view_matrix(self):
        """4x4 world -> GL eye transform."""
        return EYE_FROM_LINK.dot(np.linalg.inv(self.pose.matrix()))

    def project(self, point_world):
        """Pixel (u, v) (OpenCV convention) and depth of a world point."""
        pc = np.linalg.inv(self.pose.matrix()).dot(np.r_[np.asarray(point_world, float), 1.0])
        # camera link: x forward, y left, z up -> optical: x right, y down, z forward
        xo, yo, zo = -pc[1], -pc[2], pc[0]
        return (self.fx * xo / zo + self.cx, self.fy * yo / zo + self.cy), zo


def _pose_matrices(pq):
    """(n, 4, 4) homogeneous matrices of n poses given as rows (x, y, z, qx, qy, qz, qw)."""
    m = np.zeros((len(pq), 4, 4))
    m[:, :3, :3] = quat_to_matrices(pq[:, 3:7])
    m[:, :3, 3] = pq[:, :3]
    m[:, 3, 3] = 1.0
    return m


class _Item(object):
    """One visual of one link, with its GL buffer (created lazily in the render thread)."""

    def __init__(self, model, link, visual, mesh, rgba, texture_key, lit):
        self.model, self.link, self.visual = model, link, visual
        self.mesh = mesh
        self.origin = visual.origin.matrix()
        self.rgba = tuple(float(c) for c in rgba)
        self.texture_key = texture_key
        self.lit = lit
        self.vbo = None
        self.vao = None
        self.world = np.eye(4)
        self.transparent = self.rgba[3] < 0.999


class _DynTex(object):
    def __init__(self):
        self.pending = None      # new image to upload (or False = clear)
        self.face = 'front'
        self.tex = None          # GL texture id
        self.size = None
        self.active = False


class _Projection(object):
    def __init__(self):
        self.model = self.link = None
        self.fov, self.near, self.far, self.brightness = 0.785, 0.05, 10.0, 1.0
        self.on, self.pending, self.tex, self.shape = False, None, None, None


class Renderer(object):
    """Visuals of the world's models, drawn into offscreen images (see module doc)."""

    def __init__(self, context=None):
        self.ctx = context or get_context()
        self._items = {}               # model name -> [_Item]
        self._link_poses = {}          # model name -> {link: 4x4}
        self._pending_poses = {}       # model name -> {link: Pose or 4x4}, applied at render
        self._last_pq = {}             # model name -> (link names, (n, 7) positions+quats)
        self._pose_source = None       # fn(model name) -> {link: Pose}, pulled at render
        self._images = {}              # texture path -> RGBA array (loaded once)
        self._meshes = {}              # (mesh file, scale) -> MeshData (read once)
        self._gl_textures = {}         # texture key -> GL id
        self._dyn = {}                 # (model, link) -> _DynTex
        self._projectors = {}          # key -> _Projection (set_projector; simsensors.projector)
        self._lights = None
        self._ambient = DEFAULT_AMBIENT
        self._lock = threading.RLock()
        self.background = DEFAULT_BACKGROUND
        self._trash = []               # GL buffers to delete in the render thread
        self._rgba_bufs = {}
        self.sort_items = True
        self.frames = 0
        self._cone_tex = {}            # (inner, outer, falloff) -> GL texture of its cone
        #: occlusion of projected light by shadow maps (``shadow_size`` pixels on the long
        #: side): projectors always (their picture stops at the first surface), spot lights
        #: on request (one more depth pass per spot and frame)
        self.projector_shadows = True
        self.spot_shadows = False
        self.sun_shadows = False       # directional lights too (an orthographic shadow map)
        self.shadow_size = 512
        # the worker thread of submit(): one frame in flight at most; every other entry
        # point waits for it first, so a frame shows the scene as it was when submitted
        self._idle = threading.Event()
        self._idle.set()
        self._jobs = None
        self._worker = None

    # -- scene ------------------------------------------------------------------------------
    def add_model(self, model):
        """Create draw items for every visual of every link of ``model`` (a
        sim_world.model.Model). A visual whose mesh or texture cannot be read is logged once
        and skipped (mesh) or drawn in its colour (texture); the rest of the model shows."""
        self.wait_idle()
        items = []
        for link_name, link in model.links.items():
            for vis in link.visuals:
                try:
                    mesh = self._mesh(vis.geometry, model)
                except shapes.MeshLoadError as e:
                    log.error('model %s link %s: visual not shown: %s', model.name, link_name, e)
                    continue
                mat = vis.material
                tex_key = None
                if mat.texture:
                    path = model.resolve_path(mat.texture)
                    if self._load_image(path) is not None:
                        tex_key = path
                rgba = mat.rgba
                if tex_key is not None:
                    rgba = (1.0, 1.0, 1.0, float(mat.rgba[3]))
                it = _Item(model.name, link_name, vis, mesh, rgba, tex_key,
                           getattr(mat, 'lit', True))
                it.own_parts = _uses_file_materials(mat) and any(
                    p[2] is not None or p[3] is not None for p in mesh.parts)
                if it.own_parts:
                    it.part_keys = []
                    for i, (_, _, _, img) in enumerate(mesh.parts):
                        key = None
                        if img is not None:
                            key = 'mesh:%d:%d' % (id(mesh), i)     # meshes are cached
                            if key not in self._images:
                                self._images[key] = _rgba(img)
                        it.part_keys.append(key)
                items.append(it)
        poses = {}
        try:
            for ln, p in model.link_poses().items():
                poses[ln] = (model.pose * p).matrix()
        except Exception as e:  # noqa: BLE001 - a broken joint tree: draw at the model pose
            log.warning('model %s: link poses unknown (%s); drawing links at the model pose',
                        model.name, e)
            poses = {ln: model.pose.matrix() for ln in model.links}
        with self._lock:
            if model.name in self._items:
                self._drop(model.name)
            self._items[model.name] = items
            self._pending_poses.pop(model.name, None)
            self._last_pq.pop(model.name, None)
            self._link_poses[model.name] = poses
            self._update_world(model.name)
        return len(items)

    def _mesh(self, geometry, model):
        """MeshData of a geometry; mesh files are read once per (file, scale)."""
        if geometry.kind != 'mesh':
            return shapes.geometry_mesh(geometry)
        path = model.resolve_path(geometry.filename)
        key = (path, tuple(float(v) for v in geometry.scale))
        mesh = self._meshes.get(key)
        if mesh is None:
            mesh = shapes.load_mesh(path, geometry.scale)
            self._meshes[key] = mesh
        return mesh

    def remove_model(self, name):
        self.wait_idle()
        with self._lock:
            self._drop(name)
            self._link_poses.pop(name, None)
            self._pending_poses.pop(name, None)
            self._last_pq.pop(name, None)
            for key in [k for k in self._dyn if k[0] == name]:
                d = self._dyn.pop(key)
                if d.tex is not None:
                    self._trash.append(('tex', d.tex))

    def _drop(self, name):
        for it in self._items.pop(name, []):
            if it.vbo is not None:
                self._trash.append(('buf', it.vbo))
                it.vbo = None
            if it.vao is not None:
                self._trash.append(('vao', it.vao))
                it.vao = None

    def close(self):
        """Free every GL object this renderer made (the shared context stays) and end its
        worker thread: a world reloaded in the same process (sim_world's
        /gazebo/reload_world) makes a new renderer, and the old one must not keep its
        buffers in the context."""
        self.wait_idle()
        with self._lock:
            for name in list(self._items):
                self._drop(name)
            for key in list(self._dyn):
                d = self._dyn.pop(key)
                if d.tex is not None:
                    self._trash.append(('tex', d.tex))
            for pr in self._projectors.values():
                if pr.tex is not None:
                    self._trash.append(('tex', pr.tex))
            self._projectors.clear()
            for tid in list(self._gl_textures.values()) + list(self._cone_tex.values()):
                if tid is not None:
                    self._trash.append(('tex', tid))
            self._gl_textures.clear()
            self._cone_tex.clear()
            self._link_poses.clear()
            self._pending_poses.clear()
            self._last_pq.clear()
            if self._trash:
                with self.ctx:
                    self._empty_trash()
            if self._worker is not None and self._worker.is_alive():
                self._jobs.put(None)
            self._worker = None

    def model_names(self):
        with self._lock:
            return list(self._items)

    def set_link_poses(self, model_name, poses):
        """World poses of links: {link name: Pose (or 4x4 matrix)}. Links not named keep
        their last pose. Cheap: the poses are kept and turned into matrices by the next
        render (the world syncs poses far more often than cameras draw)."""
        self.wait_idle()
        with self._lock:
            pend = self._pending_poses.get(model_name)
            if pend is None:
                self._pending_poses[model_name] = dict(poses)
            else:
                pend.update(poses)

    def set_pose_source(self, fn):
        """Pull link poses at each render instead of having them pushed: ``fn(model_name)``
        returns {link: Pose (or 4x4)} (e.g. ``World.link_poses``); None turns it off. A
        world that steps far more often than anything renders then computes the poses once
        per frame instead of once per step. ``fn`` is called before the renderer takes its
        lock (it may take the world's lock); a model it fails for keeps its last poses."""
        self._pose_source = fn

    def _pull_poses(self):
        fn = self._pose_source
        if fn is None:
            return
        with self._lock:
            names = list(self._items)
        for name in names:
            try:
                poses = fn(name)
            except Exception:  # noqa: BLE001 - e.g. deleted meanwhile: keep the last poses
                continue
            if poses:
                self.set_link_poses(name, poses)

    def _apply_poses(self):
        """Turn the poses set since the last render into matrices: one numpy batch for all
        links; a model whose link poses did not change (static furniture) is skipped."""
        if not self._pending_poses:
            return
        pending, self._pending_poses = self._pending_poses, {}
        changed = []
        for model_name, poses in pending.items():
            cur = self._link_poses.setdefault(model_name, {})
            names = [ln for ln, p in poses.items() if isinstance(p, Pose)]
            for ln, p in poses.items():
                if not isinstance(p, Pose):
                    cur[ln] = np.asarray(p, float)
            if names:
                pq = np.array([np.concatenate((poses[ln].p, poses[ln].q)) for ln in names],
                              float)
                last = self._last_pq.get(model_name)
                if last is not None and last[0] == names and np.array_equal(last[1], pq) \
                        and all(ln in cur for ln in names):
                    if len(names) == len(poses):
                        continue                      # nothing moved
                else:
                    self._last_pq[model_name] = (names, pq)
                    for ln, m in zip(names, _pose_matrices(pq)):
                        cur[ln] = m
            changed.append(model_name)
        for model_name in changed:
            if model_name in self._items:
                self._update_world(model_name)

    def _update_world(self, model_name):
        poses = self._link_poses.get(model_name, {})
        its = [it for it in self._items.get(model_name, []) if it.link in poses]
        if not its:
            return
        world = np.matmul(np.array([poses[it.link] for it in its]),
                          np.array([it.origin for it in its]))
        for it, w in zip(its, world):
            it.world = w

    def set_lights(self, lights, ambient=DEFAULT_AMBIENT, default_sun=True, shadows=None):
        """sim_world.model.Light list (up to 8 are used) and the ambient colour (rgb 0..1).
        With an empty list and ``default_sun`` the Gazebo default sun lights the scene.
        ``shadows`` (None: unchanged) sets ``spot_shadows`` and ``sun_shadows``."""
        self.wait_idle()
        with self._lock:
            if shadows is not None:
                self.spot_shadows = self.sun_shadows = bool(shadows)
            self._lights = list(lights or [])
            self._default_sun = default_sun
            self._ambient = tuple(float(c) for c in list(ambient)[:3])
            if len(self._lights) > 8:
                log.warning('%d lights in the world; the renderer uses the first 8',
                            len(self._lights))

    def set_background(self, rgb):
        """Colour (rgb 0..1) where nothing is drawn, for views that name none."""
        self.wait_idle()
        self.background = tuple(float(c) for c in list(rgb)[:3])

    def set_dynamic_texture(self, model_name, link_name, rgb, face='front'):
        """Show image ``rgb`` (HxWx3 or HxWx4 uint8, row 0 = top) unlit on ``face`` of the
        first box visual of the link ('front' = '+z'; '+x', '-x', '+y', '-y', '+z', '-z',
        'all'); a link without a box shows it on its first visual. None = back to the
        material. The image is copied; the upload happens in the next render."""
        self.wait_idle()
        face = {'front': '+z', 'back': '-z'}.get(face, face)
        if face not in shapes.BOX_FACES and face != 'all':
            raise ValueError('unknown face %r (front, back, +x, -x, +y, -y, +z, -z, all)' % face)
        if rgb is not None:
            rgb = np.asarray(rgb)
            if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] not in (3, 4) \
                    or rgb.shape[0] < 1 or rgb.shape[1] < 1:
                raise ValueError('dynamic texture must be HxWx3 or HxWx4 uint8, got %s %s'
                                 % (rgb.dtype, rgb.shape))
            rgb = np.ascontiguousarray(rgb).copy()
        with self._lock:
            d = self._dyn.setdefault((model_name, link_name), _DynTex())
            d.face = face
            d.pending = rgb if rgb is not None else False

    def set_link_color(self, model_name, link_name, rgba, lit=None):
        """Draw every visual of a link in colour ``rgba`` (0..1; 3 or 4 values), unlit
        (emissive: every camera sees the colour itself, as an LED) with ``lit=False``;
        ``rgba=None`` gives the link back its material. Applies from the next render; kept
        while the model exists. Raises ValueError for a colour that is not 3-4 values in
        0..1, KeyError for an unknown model or link."""
        self.wait_idle()
        if rgba is not None:
            c = [float(v) for v in rgba]
            if len(c) == 3:
                c.append(1.0)
            if len(c) != 4 or not all(0.0 <= v <= 1.0 for v in c):
                raise ValueError('link colour must be 3 or 4 numbers in 0..1, got %r'
                                 % (list(rgba),))
        with self._lock:
            its = [it for it in self._items.get(model_name, []) if it.link == link_name]
            if not its:
                raise KeyError('model %r has no visual on link %r to colour'
                               % (model_name, link_name))
            for it in its:
                if not hasattr(it, 'material0'):
                    it.material0 = (it.rgba, it.lit, it.texture_key)
                if rgba is None:
                    it.rgba, it.lit, it.texture_key = it.material0
                else:
                    it.rgba = tuple(c)
                    it.lit = it.material0[1] if lit is None else bool(lit)
                    it.texture_key = None
                it.transparent = it.rgba[3] < 0.999

    # -- projectors (simsensors.projector) -------------------------------------------------------
    def set_projector(self, key, model_name, link_name, fov, near, far, rgb, brightness=1.0):
        """Project image ``rgb`` (HxWx3 uint8, row 0 = top; None = off) from the link (looking
        along its +x, z up, like a camera) with horizontal field of view ``fov`` (rad) between
        the clip distances, onto every surface in the frustum: added to the lit colour as a
        point light of ``brightness`` at 1 m (1/d^2, cosine falloff) modulated by the image
        and the surface's colour. Occluded: a shadow map from the projector (its own model
        excepted) stops the picture at the first surface it meets (``projector_shadows``)."""
        self.wait_idle()
        if rgb is not None:
            rgb = np.asarray(rgb)
            if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
                raise ValueError('projector image must be HxWx3 uint8, got %s %s'
                                 % (rgb.dtype, rgb.shape))
            rgb = np.ascontiguousarray(rgb).copy()
        with self._lock:
            pr = self._projectors.get(key)
            if pr is None:
                pr = self._projectors[key] = _Projection()
            pr.model, pr.link = model_name, link_name
            pr.fov, pr.near, pr.far, pr.brightness = float(fov), float(near), float(far), \
                float(brightness)
            if rgb is None:
                pr.on = False
            else:
                pr.on, pr.pending = True, rgb

    def remove_projector(self, key):
        self.wait_idle()
        with self._lock:
            pr = self._projectors.pop(key, None)
            if pr is not None and pr.tex is not None:
                self._trash.append(('tex', pr.tex))

    def _projected(self):
        """The lights drawn by projective texturing, as _Projection-like records with the
        world pose ``M`` of a frame looking along its +x: the projectors that are on, and
        the spot lights (their cone as an image, ``cone_image``). Uploads pending images."""
        from OpenGL import GL
        out = []
        for key, pr in list(self._projectors.items()):
            poses = self._link_poses.get(pr.model)
            if not pr.on or poses is None or pr.link not in poses:
                continue
            if pr.pending is not None:
                if pr.tex is None:
                    pr.tex = GL.glGenTextures(1)
                img = pr.pending
                pr.shape = img.shape
                _upload_texture(pr.tex, img, mipmap=False)
                _clamp_black(pr.tex)
                pr.pending = None
            if pr.tex is None:
                continue
            M = poses[pr.link]
            M = M.matrix() if hasattr(M, 'matrix') else np.asarray(M)
            b = pr.brightness
            out.append(dict(key=('projector', key), M=M, fov=pr.fov, size=pr.shape[1::-1],
                            near=pr.near, far=pr.far, tex=pr.tex, diffuse=(b, b, b, 1.0),
                            att=(1e-3, 0.0, 1.0), shadow=self.projector_shadows,
                            exclude=pr.model))
        lights = self._lights or []
        for i, lt in enumerate(lights[:8]):
            if lt.kind == 'directional' and self.sun_shadows:
                sun = self._sun_record(i, lt)
                if sun is not None:
                    out.append(sun)
                continue
            if lt.kind != 'spot':
                continue
            fov = min(max(lt.outer_angle, 1e-3), 2 * math.radians(_SPOT_MAX_HALF_DEG))
            ckey = (round(lt.inner_angle, 6), round(lt.outer_angle, 6), round(lt.falloff, 6))
            tex = self._cone_tex.get(ckey)
            if tex is None:
                tex = self._cone_tex[ckey] = _upload_texture(
                    None, cone_image(lt.inner_angle, lt.outer_angle, lt.falloff), mipmap=False)
                _clamp_black(tex)
            M = np.eye(4)
            M[:3, :3] = _frame_along(lt.world_direction())
            M[:3, 3] = lt.pose.p
            att = list(lt.attenuation) + [1.0, 0.0, 0.0]
            out.append(dict(key=('spot', i), M=M, fov=fov, size=(_CONE_SIZE, _CONE_SIZE),
                            near=0.02, far=max(float(lt.range), 0.05), tex=tex,
                            diffuse=tuple(float(c) for c in lt.diffuse[:4]),
                            att=(max(float(att[0]), 1e-3), float(att[1]), float(att[2])),
                            shadow=self.spot_shadows, exclude=None))
        return out

    def _sun_record(self, i, lt):
        """A directional light as a projected light: no image, no clip planes, light from
        its direction, an orthographic shadow map around what casts shadows (every opaque
        visual but open planes such as the ground, which only receive them)."""
        d = lt.world_direction()
        centres, radii = [], []
        for items in self._items.values():
            for it in items:
                if it.transparent or (it.mesh.double_sided and not it.mesh.parts):
                    continue
                r = getattr(it.mesh, '_radius', None)
                if r is None:
                    pts = it.mesh.positions
                    r = it.mesh._radius = float(np.sqrt((pts.astype(float) ** 2).sum(axis=1)
                                                        .max())) if len(pts) else 0.0
                centres.append(it.world[:3, 3])
                radii.append(r * float(np.abs(it.world[:3, :3]).sum(axis=0).max()))
        if not centres:
            return None
        centres, radii = np.array(centres), np.array(radii)
        lo, hi = (centres - radii[:, None]).min(axis=0), (centres + radii[:, None]).max(axis=0)
        c, r = (lo + hi) / 2.0, max(float(np.linalg.norm(hi - lo)) / 2.0, 0.1)
        M = np.eye(4)
        M[:3, :3] = _frame_along(d)
        M[:3, 3] = c - d * (r + 0.5)
        return dict(key=('sun', i), M=M, ortho=r, size=(1, 1), near=0.01, far=2 * r + 1.0,
                    tex=None, diffuse=tuple(float(v) for v in lt.diffuse[:4]),
                    att=(1.0, 0.0, 0.0), shadow=True, exclude=None,
                    position=(-d[0], -d[1], -d[2], 0.0))

    @staticmethod
    def _ortho(r, near, far):
        return np.array([[1.0 / r, 0, 0, 0], [0, 1.0 / r, 0, 0],
                         [0, 0, -2.0 / (far - near), -(far + near) / (far - near)],
                         [0, 0, 0, 1.0]])

    def _shadow_view(self, pl):
        w, h = pl['size']
        s = float(self.shadow_size)
        sw, sh = (int(s), max(1, int(round(s * h / w)))) if w >= h else \
            (max(1, int(round(s * w / h))), int(s))
        return CameraView(sw, sh, hfov=pl['fov'], near=pl['near'], far=pl['far'])

    def _draw_shadow_map(self, pl):
        """Depth of every opaque visual (but those of the model ``exclude``: the projector's
        own phone) seen from the light's frustum, into its depth texture (a shadow map)."""
        from OpenGL import GL
        if pl.get('ortho'):
            size = int(self.shadow_size) * 2
            pl['depth_tex'] = self.ctx.depth_target(pl['key'], size, size)
            P = self._ortho(pl['ortho'], pl['near'], pl['far'])
        else:
            view = self._shadow_view(pl)
            pl['depth_tex'] = self.ctx.depth_target(pl['key'], view.width, view.height)
            P = view.projection_matrix()
        Vs = EYE_FROM_LINK.dot(np.linalg.inv(pl['M']))
        pl['shadow_matrix'] = P.dot(Vs)
        GL.glClear(GL.GL_DEPTH_BUFFER_BIT)
        GL.glMatrixMode(GL.GL_PROJECTION)
        GL.glLoadMatrixd(P.T.ravel())
        GL.glMatrixMode(GL.GL_MODELVIEW)
        GL.glUseProgram(0)
        GL.glColorMask(GL.GL_FALSE, GL.GL_FALSE, GL.GL_FALSE, GL.GL_FALSE)
        for cap in (GL.GL_LIGHTING, GL.GL_TEXTURE_2D, GL.GL_CULL_FACE, GL.GL_BLEND,
                    GL.GL_CLIP_PLANE0, GL.GL_CLIP_PLANE1, GL.GL_SCISSOR_TEST):
            GL.glDisable(cap)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthFunc(GL.GL_LEQUAL)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glEnable(GL.GL_POLYGON_OFFSET_FILL)
        GL.glPolygonOffset(2.0, 4.0)
        for name, items in self._items.items():
            if name == pl['exclude']:
                continue
            for it in items:
                if it.transparent:
                    continue
                if it.vao is None:
                    self._make_vao(it)
                GL.glBindVertexArray(it.vao)
                GL.glLoadMatrixd(Vs.dot(it.world).T.ravel())
                GL.glDrawArrays(GL.GL_TRIANGLES, 0, it.mesh.count)
        GL.glBindVertexArray(0)
        GL.glDisable(GL.GL_POLYGON_OFFSET_FILL)
        GL.glColorMask(GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE)

    @staticmethod
    def _texgen(unit, matrix):
        """Texture unit ``unit``: eye-linear texgen of world coordinates (the modelview is
        the camera's view when called), texture matrix ``matrix``."""
        from OpenGL import GL
        GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
        GL.glMatrixMode(GL.GL_TEXTURE)
        GL.glLoadMatrixd(matrix.T.ravel())
        GL.glMatrixMode(GL.GL_MODELVIEW)
        for coord, gen, row in ((GL.GL_S, GL.GL_TEXTURE_GEN_S, (1, 0, 0, 0)),
                                (GL.GL_T, GL.GL_TEXTURE_GEN_T, (0, 1, 0, 0)),
                                (GL.GL_R, GL.GL_TEXTURE_GEN_R, (0, 0, 1, 0)),
                                (GL.GL_Q, GL.GL_TEXTURE_GEN_Q, (0, 0, 0, 1))):
            GL.glTexGeni(coord, GL.GL_TEXTURE_GEN_MODE, GL.GL_EYE_LINEAR)
            GL.glTexGenfv(coord, GL.GL_EYE_PLANE, row)
            GL.glEnable(gen)
        GL.glTexEnvi(GL.GL_TEXTURE_ENV, GL.GL_TEXTURE_ENV_MODE, GL.GL_MODULATE)
        GL.glEnable(GL.GL_TEXTURE_2D)

    @staticmethod
    def _texgen_off(unit):
        from OpenGL import GL
        GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
        for gen in (GL.GL_TEXTURE_GEN_S, GL.GL_TEXTURE_GEN_T, GL.GL_TEXTURE_GEN_R,
                    GL.GL_TEXTURE_GEN_Q):
            GL.glDisable(gen)
        GL.glDisable(GL.GL_TEXTURE_2D)
        GL.glMatrixMode(GL.GL_TEXTURE)
        GL.glLoadIdentity()
        GL.glMatrixMode(GL.GL_MODELVIEW)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)

    def _draw_projections(self, V, plights):
        """Additive pass per projected light (projectors, spot lights): the lit colour of
        every lit opaque visual (its material and texture on unit 0) from one point light at
        the light's position (the only light), times the light's image projected by
        eye-linear texgen on unit 1 (texture matrix = bias * projection * view of the
        light), times the shadow-map comparison on unit 2 (1 where the surface is the
        nearest thing the light sees, 0 behind an occluder), clipped to the light's near
        and far distance."""
        from OpenGL import GL
        B = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
        for pl in plights:
            M = pl['M']
            Vp = EYE_FROM_LINK.dot(np.linalg.inv(M))
            pos, fwd = M[:3, 3], M[:3, 0] / np.linalg.norm(M[:3, 0])
            GL.glLoadMatrixd(V.T.ravel())          # planes and light given in world frame
            if pl['tex'] is not None:
                w, h = pl['size']
                view = CameraView(w, h, hfov=pl['fov'], near=pl['near'], far=pl['far'])
                self._texgen(1, B.dot(view.projection_matrix(flip_y=True)).dot(Vp))
                GL.glBindTexture(GL.GL_TEXTURE_2D, pl['tex'])
            if pl.get('depth_tex') is not None:
                self._texgen(2, B.dot(pl['shadow_matrix']))
                GL.glBindTexture(GL.GL_TEXTURE_2D, pl['depth_tex'])
            GL.glActiveTexture(GL.GL_TEXTURE0)
            if pl['tex'] is not None:               # a directional light is not clipped
                GL.glClipPlane(GL.GL_CLIP_PLANE0,
                               tuple(np.r_[fwd, -fwd.dot(pos) - pl['near']]))
                GL.glClipPlane(GL.GL_CLIP_PLANE1,
                               tuple(np.r_[-fwd, fwd.dot(pos) + pl['far']]))
                GL.glEnable(GL.GL_CLIP_PLANE0)
                GL.glEnable(GL.GL_CLIP_PLANE1)
            GL.glLightModelfv(GL.GL_LIGHT_MODEL_AMBIENT, (0.0, 0.0, 0.0, 1.0))
            for i in range(1, 8):
                GL.glDisable(GL.GL_LIGHT0 + i)
            GL.glEnable(GL.GL_LIGHT0)
            GL.glLightfv(GL.GL_LIGHT0, GL.GL_AMBIENT, (0.0, 0.0, 0.0, 1.0))
            GL.glLightfv(GL.GL_LIGHT0, GL.GL_DIFFUSE, pl['diffuse'])
            GL.glLightfv(GL.GL_LIGHT0, GL.GL_SPECULAR, (0.0, 0.0, 0.0, 1.0))
            GL.glLightfv(GL.GL_LIGHT0, GL.GL_POSITION,
                         pl.get('position', (pos[0], pos[1], pos[2], 1.0)))
            GL.glLightf(GL.GL_LIGHT0, GL.GL_SPOT_CUTOFF, 180.0)
            GL.glLightf(GL.GL_LIGHT0, GL.GL_CONSTANT_ATTENUATION, pl['att'][0])
            GL.glLightf(GL.GL_LIGHT0, GL.GL_LINEAR_ATTENUATION, pl['att'][1])
            GL.glLightf(GL.GL_LIGHT0, GL.GL_QUADRATIC_ATTENUATION, pl['att'][2])
            GL.glEnable(GL.GL_BLEND)
            GL.glBlendFunc(GL.GL_ONE, GL.GL_ONE)
            GL.glDepthMask(GL.GL_FALSE)
            GL.glDepthFunc(GL.GL_LEQUAL)
            self._state = (None, None, None)
            for items in self._items.values():
                for it in items:
                    if it.transparent or not it.lit:
                        continue
                    self._draw(it, V, None)
            GL.glBindVertexArray(0)
            self._texgen_off(2)
            self._texgen_off(1)
            GL.glActiveTexture(GL.GL_TEXTURE0)
            GL.glDisable(GL.GL_CLIP_PLANE0)
            GL.glDisable(GL.GL_CLIP_PLANE1)
            GL.glDisable(GL.GL_BLEND)
            GL.glDepthMask(GL.GL_TRUE)
            GL.glDisable(GL.GL_TEXTURE_2D)
            GL.glDisable(GL.GL_LIGHTING)
        self._state = (None, None, None)

    # -- textures ---------------------------------------------------------------------------
    def _load_image(self, path):
        if path in self._images:
            return self._images[path]
        img = None
        try:
            import cv2
            raw = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if raw is None:
                log.error('texture %s cannot be read; using the material colour', path)
            else:
                if raw.ndim == 2:
                    raw = cv2.cvtColor(raw, cv2.COLOR_GRAY2BGRA)
                elif raw.shape[2] == 3:
                    raw = cv2.cvtColor(raw, cv2.COLOR_BGR2BGRA)
                if raw.dtype != np.uint8:
                    raw = (raw / 257).astype(np.uint8)
                img = np.ascontiguousarray(cv2.cvtColor(raw, cv2.COLOR_BGRA2RGBA))
        except Exception as e:  # noqa: BLE001
            log.error('texture %s cannot be read (%s); using the material colour', path, e)
        self._images[path] = img
        return img

    def _gl_texture(self, key):
        tid = self._gl_textures.get(key)
        if tid is None:
            img = self._images.get(key)
            if img is None:
                return None
            tid = _upload_texture(None, img, mipmap=True)
            self._gl_textures[key] = tid
        return tid

    # -- drawing ----------------------------------------------------------------------------
    def render(self, view, depth=False):
        """Draw the scene as ``view`` sees it. Returns HxWx3 uint8 (row 0 = top), or
        (rgb, depth) with depth HxW float32 metres along the optical axis, inf where
        nothing was drawn."""
        self.wait_idle()
        self._pull_poses()
        return self._render(view, depth, apply=True)

    # -- rendering in a worker thread (overlapping the world's stepping) ---------------------
    def submit(self, view, done, depth=False):
        """Render ``view`` in the renderer's worker thread and call ``done(rgb, depth)``
        there (depth None unless asked); returns at once. The frame shows the scene as it is
        now: the poses are taken here, and every other call (a new submit, render, any
        change to the scene) first waits for the frame in flight (``wait_idle``). OpenGL
        calls release the GIL (ctypes), so the caller's thread runs on (steps physics)
        while llvmpipe rasterises and reads the frame back."""
        import queue
        self.wait_idle()
        self._pull_poses()
        with self._lock:
            self._apply_poses()
            if self._worker is None or not self._worker.is_alive():
                # the worker needs the GIL back promptly between its GL calls (Python's
                # default switch interval, 5 ms, is longer than a frame): measured with
                # bench/camera, 0.5 ms gives the office world's RTF 8.7 against 8.0
                sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
                self._jobs = queue.Queue()
                self._worker = threading.Thread(target=self._work, name='renderer',
                                                daemon=True)
                self._worker.start()
            self._idle.clear()
            self._jobs.put((view, depth, done))

    def wait_idle(self):
        """Return when no submitted frame is in flight (its ``done`` has returned)."""
        if not self._idle.is_set() and threading.current_thread() is not self._worker:
            self._idle.wait()

    def _work(self):
        while True:
            job = self._jobs.get()
            if job is None:            # close()
                return
            view, depth, done = job
            try:
                out = self._render(view, depth, apply=False)
                if depth:
                    done(out[0], out[1])
                else:
                    done(out, None)
            except Exception as e:  # noqa: BLE001 - one bad frame must not stop the thread
                log.error('frame rendered in the worker thread failed: %s: %s',
                          type(e).__name__, e)
            finally:
                self._idle.set()

    def _render(self, view, depth, apply):
        from OpenGL import GL
        w, h = view.width, view.height
        with self.ctx, self._lock:
            self.ctx.target(w, h)
            if apply:
                self._apply_poses()
            self._empty_trash()
            self._upload_dynamic()
            plights = self._projected()
            for pl in plights:
                if pl['shadow']:
                    self._draw_shadow_map(pl)
            self.ctx.target(w, h)
            bg = view.background if view.background is not None else self.background
            GL.glClearColor(bg[0], bg[1], bg[2], 1.0)
            GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
            GL.glMatrixMode(GL.GL_PROJECTION)
            GL.glLoadMatrixd(view.projection_matrix(flip_y=True).T.ravel())
            GL.glMatrixMode(GL.GL_MODELVIEW)
            V = view.view_matrix()
            GL.glLoadMatrixd(V.T.ravel())
            self._setup_state()
            self._setup_lights()
            self._state = (None, None, None)
            self._draw_all(V)
            if plights:
                self._draw_projections(V, plights)
            # flipped projection: row 0 is the top. RGBA readback is several times faster
            # than RGB on llvmpipe; dropping alpha in OpenCV costs less than the difference.
            rgba = self.ctx.read_rgba_raw(w, h, self._rgba_buffer(w, h))
            rgb = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
            d = None
            if depth:
                d = linearize_depth(self.ctx.read_depth_raw(w, h), view.near, view.far)
            self.frames += 1
        return (rgb, d) if depth else rgb

    def _rgba_buffer(self, w, h):
        buf = self._rgba_bufs.get((w, h))
        if buf is None:
            buf = self._rgba_bufs[(w, h)] = np.empty((h, w, 4), np.uint8)
        return buf

    def _empty_trash(self):
        from OpenGL import GL
        for kind, obj in self._trash:
            try:
                if kind == 'buf':
                    GL.glDeleteBuffers(1, [obj])
                elif kind == 'vao':
                    GL.glDeleteVertexArrays(1, [obj])
                else:
                    GL.glDeleteTextures([obj])
            except Exception:  # noqa: BLE001
                pass
        self._trash = []

    def _upload_dynamic(self):
        for d in self._dyn.values():
            if d.pending is None:
                continue
            img, d.pending = d.pending, None
            if img is False:
                d.active = False
                continue
            size = (img.shape[1], img.shape[0], img.shape[2])
            # same size: update in place; new size: re-specify the same texture object
            d.tex = _upload_texture(d.tex, img, mipmap=False, replace=d.size == size)
            d.size = size
            d.active = True

    def _setup_state(self):
        """Every piece of GL state the drawing relies on (the context is shared with other
        components that set their own)."""
        from OpenGL import GL
        GL.glUseProgram(0)
        for cap in (GL.GL_SCISSOR_TEST, GL.GL_STENCIL_TEST, GL.GL_ALPHA_TEST,
                    GL.GL_POLYGON_OFFSET_FILL, GL.GL_NORMALIZE):
            GL.glDisable(cap)
        GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_FILL)
        GL.glColorMask(GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE, GL.GL_TRUE)
        GL.glActiveTexture(GL.GL_TEXTURE0)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthFunc(GL.GL_LEQUAL)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glFrontFace(GL.GL_CW)     # the flipped projection mirrors the winding
        GL.glCullFace(GL.GL_BACK)
        GL.glShadeModel(GL.GL_SMOOTH)
        GL.glEnable(GL.GL_COLOR_MATERIAL)
        GL.glColorMaterial(GL.GL_FRONT_AND_BACK, GL.GL_AMBIENT_AND_DIFFUSE)
        GL.glMaterialfv(GL.GL_FRONT_AND_BACK, GL.GL_SPECULAR, (0.1, 0.1, 0.1, 1.0))
        GL.glMaterialf(GL.GL_FRONT_AND_BACK, GL.GL_SHININESS, 20.0)
        GL.glTexEnvi(GL.GL_TEXTURE_ENV, GL.GL_TEXTURE_ENV_MODE, GL.GL_MODULATE)
        GL.glDisable(GL.GL_BLEND)

    def _setup_lights(self):
        from OpenGL import GL
        lights = self._lights
        if not lights and (self._lights is None or getattr(self, '_default_sun', True)):
            lights = [None]
        amb = self._ambient
        GL.glLightModelfv(GL.GL_LIGHT_MODEL_AMBIENT, (amb[0], amb[1], amb[2], 1.0))
        GL.glLightModeli(GL.GL_LIGHT_MODEL_LOCAL_VIEWER, GL.GL_FALSE)
        for i in range(8):
            L = GL.GL_LIGHT0 + i
            if i >= len(lights):
                GL.glDisable(L)
                continue
            lt = lights[i]
            GL.glEnable(L)
            GL.glLightfv(L, GL.GL_AMBIENT, (0.0, 0.0, 0.0, 1.0))
            if lt is None:
                d = np.asarray(DEFAULT_SUN['direction'], float)
                d = d / np.linalg.norm(d)
                GL.glLightfv(L, GL.GL_DIFFUSE, DEFAULT_SUN['diffuse'])
                GL.glLightfv(L, GL.GL_SPECULAR, DEFAULT_SUN['specular'])
                GL.glLightfv(L, GL.GL_POSITION, (-d[0], -d[1], -d[2], 0.0))
                continue
            GL.glLightfv(L, GL.GL_DIFFUSE, tuple(float(c) for c in lt.diffuse[:4]))
            GL.glLightfv(L, GL.GL_SPECULAR, tuple(float(c) for c in lt.specular[:4]))
            if lt.kind == 'directional' and self.sun_shadows:
                GL.glDisable(L)          # drawn by the projective pass, shadowed
                continue
            if lt.kind == 'directional':
                d = lt.pose.rotate(lt.direction)
                n = np.linalg.norm(d)
                d = d / n if n > 1e-9 else np.array([0, 0, -1.0])
                GL.glLightfv(L, GL.GL_POSITION, (-d[0], -d[1], -d[2], 0.0))
                GL.glLightf(L, GL.GL_SPOT_CUTOFF, 180.0)
                for a in (GL.GL_CONSTANT_ATTENUATION,):
                    GL.glLightf(L, a, 1.0)
                GL.glLightf(L, GL.GL_LINEAR_ATTENUATION, 0.0)
                GL.glLightf(L, GL.GL_QUADRATIC_ATTENUATION, 0.0)
            elif lt.kind == 'spot':      # drawn by the projective pass (_draw_projections)
                GL.glDisable(L)
            else:   # point
                p = lt.pose.p
                GL.glLightfv(L, GL.GL_POSITION, (p[0], p[1], p[2], 1.0))
                GL.glLightf(L, GL.GL_SPOT_CUTOFF, 180.0)
                att = list(lt.attenuation) + [1.0, 0.0, 0.0]
                GL.glLightf(L, GL.GL_CONSTANT_ATTENUATION, max(float(att[0]), 1e-3))
                GL.glLightf(L, GL.GL_LINEAR_ATTENUATION, float(att[1]))
                GL.glLightf(L, GL.GL_QUADRATIC_ATTENUATION, float(att[2]))

    def _draw_all(self, V):
        from OpenGL import GL
        opaque, transparent = [], []
        for items in self._items.values():
            for it in items:
                (transparent if it.transparent else opaque).append(it)
        # near to far: llvmpipe skips shading of fragments behind what is already drawn;
        # planes (the ground) last, they are under everything
        def dist(it):
            c = V.dot(it.world[:, 3])
            return (it.mesh.double_sided and not it.mesh.parts, c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
        if self.sort_items:
            opaque.sort(key=dist)
            transparent.sort(key=dist, reverse=True)
        dyn_items = {}
        for key, d in self._dyn.items():
            if d.active and d.tex is not None:
                its = self._items.get(key[0], [])
                target = next((i for i in its if i.link == key[1] and i.mesh.faces), None)
                if target is None:
                    target = next((i for i in its if i.link == key[1]), None)
                if target is not None:
                    dyn_items[id(target)] = d
        for it in opaque:
            self._draw(it, V, dyn_items.get(id(it)))
        if transparent:
            GL.glEnable(GL.GL_BLEND)
            GL.glBlendFunc(GL.GL_SRC_ALPHA, GL.GL_ONE_MINUS_SRC_ALPHA)
            GL.glDepthMask(GL.GL_FALSE)
            for it in transparent:
                self._draw(it, V, dyn_items.get(id(it)))
            GL.glDepthMask(GL.GL_TRUE)
            GL.glDisable(GL.GL_BLEND)
        GL.glBindVertexArray(0)
        GL.glDisable(GL.GL_TEXTURE_2D)

    def _draw(self, it, V, dyn):
        from OpenGL import GL
        if it.vao is None:
            self._make_vao(it)
        GL.glBindVertexArray(it.vao)
        GL.glLoadMatrixd(V.dot(it.world).T.ravel())
        two = bool(it.mesh.double_sided)
        if two != self._state[2]:
            # open meshes: no culling, and the side facing the camera is the lit side
            (GL.glDisable if two else GL.glEnable)(GL.GL_CULL_FACE)
            GL.glLightModeli(GL.GL_LIGHT_MODEL_TWO_SIDE, GL.GL_TRUE if two else GL.GL_FALSE)
            self._state = self._state[:2] + (two,)
        ranges = [(0, it.mesh.count)]
        dyn_ranges = []
        if dyn is not None:
            if dyn.face == 'all' or not it.mesh.faces:
                ranges, dyn_ranges = [], [(0, it.mesh.count)]
            else:
                ranges = [r for f, r in it.mesh.faces.items() if f != dyn.face]
                dyn_ranges = [it.mesh.faces[dyn.face]]
        if it.own_parts and ranges:
            for (first, count, color, _img), key in zip(it.mesh.parts, it.part_keys):
                rgba = color if color is not None else it.rgba
                self._material(key if key is not None else None,
                               (1, 1, 1, rgba[3]) if key is not None else rgba, it.lit)
                GL.glDrawArrays(GL.GL_TRIANGLES, first, count)
        elif ranges:
            self._material(it.texture_key, it.rgba, it.lit)
            for first, count in ranges:
                GL.glDrawArrays(GL.GL_TRIANGLES, first, count)
        if dyn_ranges:
            self._material(None, (1.0, 1.0, 1.0, 1.0), False, tid=dyn.tex)
            for first, count in dyn_ranges:
                GL.glDrawArrays(GL.GL_TRIANGLES, first, count)

    @staticmethod
    def _make_vao(it):
        """A vertex array object holding the item's buffer and its (legacy) array pointers:
        one bind per draw instead of three pointer calls."""
        from OpenGL import GL
        data = it.mesh.interleaved()
        it.vao = GL.glGenVertexArrays(1)
        GL.glBindVertexArray(it.vao)
        it.vbo = GL.glGenBuffers(1)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, it.vbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, data.nbytes, data, GL.GL_STATIC_DRAW)
        GL.glEnableClientState(GL.GL_VERTEX_ARRAY)
        GL.glEnableClientState(GL.GL_NORMAL_ARRAY)
        GL.glEnableClientState(GL.GL_TEXTURE_COORD_ARRAY)
        GL.glVertexPointer(3, GL.GL_FLOAT, 32, ctypes.c_void_p(0))
        GL.glNormalPointer(GL.GL_FLOAT, 32, ctypes.c_void_p(12))
        GL.glTexCoordPointer(2, GL.GL_FLOAT, 32, ctypes.c_void_p(24))
        GL.glBindVertexArray(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)

    def _material(self, tex_key, rgba, lit, tid=None):
        from OpenGL import GL
        if tid is None and tex_key is not None:
            tid = self._gl_texture(tex_key)
        lit = bool(lit)
        if lit != self._state[0]:
            (GL.glEnable if lit else GL.glDisable)(GL.GL_LIGHTING)
        textured = tid is not None
        if textured != self._state[1]:
            (GL.glEnable if textured else GL.glDisable)(GL.GL_TEXTURE_2D)
        self._state = (lit, textured, self._state[2])
        if textured:
            GL.glBindTexture(GL.GL_TEXTURE_2D, tid)
        GL.glColor4f(rgba[0], rgba[1], rgba[2], rgba[3])


_CONE_SIZE = 128
_SPOT_MAX_HALF_DEG = 80.0       # a spot wider than 160 degrees is cut there


def cone_image(inner, outer, falloff, size=_CONE_SIZE):
    """The cone of an SDF spot light as a square grey image (HxWx3 uint8) for a frustum of
    full angle min(outer, 160 degrees): each pixel is ``Light.spot_factor`` of its ray, so
    projecting the image from the light gives the cone per pixel (the renderer's lighting
    is otherwise per vertex)."""
    from ..model import Light
    fov = min(max(outer, 1e-3), 2 * math.radians(_SPOT_MAX_HALF_DEG))
    t = math.tan(fov / 2.0)
    g = (2.0 * (np.arange(size) + 0.5) / size - 1.0) * t
    x, y = np.meshgrid(g, g)
    c = 1.0 / np.sqrt(1.0 + x * x + y * y)                  # cos of the angle off the axis
    lt = Light('cone', 'spot', inner_angle=inner, outer_angle=outer, falloff=falloff)
    f = lt.cone(c)
    img = np.clip(np.round(f * 255.0), 0, 255).astype(np.uint8)
    return np.ascontiguousarray(np.repeat(img[:, :, None], 3, axis=2))


def _frame_along(d):
    """A rotation whose +x is the unit vector d (z as close to world up as may be)."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    ref = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    z = ref - d * d.dot(ref)
    z /= np.linalg.norm(z)
    return np.column_stack([d, np.cross(z, d), z])


def _clamp_black(tid):
    """Nothing outside a projected image: clamp to a transparent black border."""
    from OpenGL import GL
    GL.glBindTexture(GL.GL_TEXTURE_2D, tid)
    GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_BORDER)
    GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_BORDER)
    GL.glTexParameterfv(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_BORDER_COLOR, (0, 0, 0, 0))


def _uses_file_materials(mat):
    """True when a visual names no material of its own (the mesh file's colours apply)."""
    return (mat.name is None and not mat.texture
            and np.allclose(mat.rgba, (0.8, 0.8, 0.8, 1.0)))


def _rgba(img):
    img = np.asarray(img, np.uint8)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.shape[2] == 3:
        img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return np.ascontiguousarray(img)


def _upload_texture(tid, img, mipmap=True, replace=False):
    """Upload HxWx3/4 uint8 (row 0 = top, at t = 0) into texture ``tid`` (new when None)."""
    from OpenGL import GL
    h, w, c = img.shape
    fmt = GL.GL_RGBA if c == 4 else GL.GL_RGB
    if tid is None:
        tid = GL.glGenTextures(1)
        replace = False
    GL.glBindTexture(GL.GL_TEXTURE_2D, tid)
    GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
    if replace:
        GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, w, h, fmt, GL.GL_UNSIGNED_BYTE, img)
    else:
        GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA8, w, h, 0, fmt, GL.GL_UNSIGNED_BYTE, img)
    GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_S, GL.GL_REPEAT)
    GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_T, GL.GL_REPEAT)
    GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR)
    if mipmap:
        GL.glGenerateMipmap(GL.GL_TEXTURE_2D)
        # Ogre's (Gazebo's) default "bilinear": linear within the nearest mip level; on
        # llvmpipe 35-45 % faster per frame than trilinear for the QR world
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER,
                           GL.GL_LINEAR_MIPMAP_NEAREST)
    else:
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR)
    return tid
