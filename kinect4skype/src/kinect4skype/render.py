"""Point clouds drawn offscreen through the project's one OSMesa context (sim_world.render).

The thesis's pcl2image subclassed PCL's VTK viewer, which needs an X display; this draws
the points with vertex/colour arrays (a VBO, GL_POINTS, glPointSize) in the shared context's
framebuffer object of the image size, with ``sim_world.render.CameraView``'s projection (so a
point lands exactly on the pixel the pinhole model K predicts) and reads the image back.

Viewpoint convention: the *optical* frame of the virtual camera (x right, y down, looking
along +z), given in the cloud's frame. The identity is the view of the sensor that made
an optical-frame cloud (the Kinect's and the sim camera's ``points``).
"""
import math

import cv2
import numpy as np

from sim_world.render import CameraView, get_context
from sim_world.transforms import Pose, quat_from_rpy

__all__ = ['PointCloudRenderer', 'COLOR_MODES', 'optical_to_link']

COLOR_MODES = ('auto', 'rgb', 'depth')

# camera link (x forward, y left, z up) expressed in the optical frame (x right, y down,
# z forward): link x = optical z, link y = -optical x, link z = -optical y
_LINK_IN_OPTICAL = np.array([[0.0, -1.0, 0.0, 0.0],
                             [0.0, 0.0, -1.0, 0.0],
                             [1.0, 0.0, 0.0, 0.0],
                             [0.0, 0.0, 0.0, 1.0]])


def optical_to_link(optical_pose):
    """Pose of the optical frame -> pose of the camera link CameraView expects."""
    return Pose.from_matrix(optical_pose.matrix().dot(_LINK_IN_OPTICAL))


def viewpoint_from_list(v):
    """[x, y, z, roll, pitch, yaw] (radians) -> Pose; raises ValueError on bad input."""
    v = [float(a) for a in v]
    if len(v) != 6 or not all(math.isfinite(a) for a in v):
        raise ValueError('viewpoint must be 6 finite numbers [x, y, z, roll, pitch, yaw], got %r'
                         % (v,))
    return Pose(v[:3], quat_from_rpy(*v[3:]))


class PointCloudRenderer(object):
    BATCH = 8192   # points per draw call (see render())

    def __init__(self, width=640, height=480, hfov=math.radians(60), viewpoint=None,
                 point_size=2.0, color_mode='auto', depth_range=(0.0, 0.0),
                 background=(0.0, 0.0, 0.0), near=0.05, far=100.0):
        if color_mode not in COLOR_MODES:
            raise ValueError('color_mode must be one of %s, got %r' % (', '.join(COLOR_MODES),
                                                                      color_mode))
        if not point_size > 0:
            raise ValueError('point_size must be positive, got %r' % point_size)
        self.ctx = get_context()
        self.viewpoint = viewpoint if viewpoint is not None else Pose()
        self.view = CameraView(width, height, hfov, optical_to_link(self.viewpoint),
                               near=near, far=far)
        self.width, self.height = self.view.width, self.view.height
        self.hfov = hfov
        self.point_size = float(point_size)
        self.color_mode = color_mode
        self.depth_range = tuple(float(a) for a in depth_range)
        self.background = tuple(float(a) for a in background)
        self._vbo = None
        self._rgba = np.empty((self.height, self.width, 4), np.uint8)
        self.frames = 0

    def set_viewpoint(self, pose):
        """Optical-frame pose of the virtual camera in the cloud's frame."""
        self.viewpoint = pose
        self.view.pose = optical_to_link(pose)

    # -- colours ----------------------------------------------------------------------------
    def depths(self, xyz):
        """Distance of each point along the virtual camera's optical axis."""
        m = np.linalg.inv(self.viewpoint.matrix())
        return xyz.dot(m[2, :3].astype(np.float32)) + np.float32(m[2, 3])

    def depth_colors(self, xyz):
        """Nx3 uint8 colour map of depth: near red ... far blue (OpenCV's JET)."""
        z = self.depths(xyz)
        lo, hi = self.depth_range
        if not hi > lo:
            sample = z[::max(1, z.size // 4096)]      # robust range from a subsample
            vis = sample[sample > self.view.near]
            if vis.size == 0:
                lo, hi = 0.0, 1.0
            else:
                lo, hi = np.percentile(vis, (1, 99)) if vis.size > 100 else (vis.min(), vis.max())
                if hi - lo < 1e-6:
                    hi = lo + 1e-6
        t = np.clip((hi - z) / (hi - lo), 0.0, 1.0)
        lut = cv2.applyColorMap(np.arange(256, dtype=np.uint8).reshape(-1, 1),
                                cv2.COLORMAP_JET)[:, 0, ::-1]   # BGR -> RGB
        return lut[(t * 255).astype(np.uint8)]

    def mode_for(self, rgb):
        """The colour mode used for a cloud with (rgb given) or without (None) colours."""
        if self.color_mode == 'auto':
            return 'rgb' if rgb is not None else 'depth'
        return self.color_mode

    # -- drawing ----------------------------------------------------------------------------
    def render(self, xyz, colors):
        """Draw Nx3 float32 points with Nx3 uint8 colours. Returns HxWx3 uint8, row 0 top."""
        from OpenGL import GL
        xyz = np.ascontiguousarray(xyz, np.float32)
        colors = np.ascontiguousarray(colors, np.uint8)
        n = xyz.shape[0]
        w, h = self.width, self.height
        bg = self.background
        with self.ctx:
            self.ctx.target(w, h)
            # the context is shared: set every piece of state this drawing relies on
            GL.glUseProgram(0)
            GL.glBindVertexArray(0)
            for cap in (GL.GL_LIGHTING, GL.GL_TEXTURE_2D, GL.GL_CULL_FACE, GL.GL_BLEND,
                        GL.GL_POINT_SMOOTH, GL.GL_PROGRAM_POINT_SIZE, GL.GL_COLOR_MATERIAL):
                GL.glDisable(cap)
            GL.glEnable(GL.GL_DEPTH_TEST)
            GL.glDepthFunc(GL.GL_LESS)
            GL.glDepthMask(GL.GL_TRUE)
            GL.glClearColor(bg[0], bg[1], bg[2], 1.0)
            GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
            GL.glMatrixMode(GL.GL_PROJECTION)
            GL.glLoadMatrixd(self.view.projection_matrix(flip_y=True).T.ravel())
            GL.glMatrixMode(GL.GL_MODELVIEW)
            GL.glLoadMatrixd(self.view.view_matrix().T.ravel())
            if n:
                if self._vbo is None:
                    self._vbo = GL.glGenBuffers(1)
                GL.glBindBuffer(GL.GL_ARRAY_BUFFER, self._vbo)
                nb_xyz = xyz.nbytes
                GL.glBufferData(GL.GL_ARRAY_BUFFER, nb_xyz + colors.nbytes, None,
                                GL.GL_STREAM_DRAW)
                GL.glBufferSubData(GL.GL_ARRAY_BUFFER, 0, nb_xyz, xyz)
                GL.glBufferSubData(GL.GL_ARRAY_BUFFER, nb_xyz, colors.nbytes, colors)
                GL.glPointSize(self.point_size)
                GL.glEnableClientState(GL.GL_VERTEX_ARRAY)
                GL.glEnableClientState(GL.GL_COLOR_ARRAY)
                GL.glVertexPointer(3, GL.GL_FLOAT, 0, None)
                GL.glColorPointer(3, GL.GL_UNSIGNED_BYTE, 0, GL.GLvoidp(nb_xyz))
                # llvmpipe bins a whole draw call into one scene; a big point draw overflows
                # it and gets several times slower per point (200k points: ~300 ms in one
                # call, ~30 ms in batches here). Batches, each finished, keep scenes small.
                for first in range(0, n, self.BATCH):
                    GL.glDrawArrays(GL.GL_POINTS, first, min(self.BATCH, n - first))
                    GL.glFinish()
                GL.glDisableClientState(GL.GL_COLOR_ARRAY)
                GL.glDisableClientState(GL.GL_VERTEX_ARRAY)
                GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
                GL.glPointSize(1.0)
            rgba = self.ctx.read_rgba_raw(w, h, self._rgba)
            rgb = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
            self.frames += 1
        return rgb

    def render_cloud(self, xyz, rgb):
        """Colour (per color_mode) and draw. Returns (image, mode); image is None when
        color_mode is 'rgb' and the cloud has no colour field."""
        mode = self.mode_for(rgb)
        if mode == 'rgb':
            if rgb is None:
                return None, mode
            return self.render(xyz, rgb), mode
        return self.render(xyz, self.depth_colors(xyz)), mode

    # -- benchmark helpers ------------------------------------------------------------------
    def baseline_fps(self, seconds):
        """Clear + RGBA readback of an empty frame per second (the floor of any render)."""
        import time
        from OpenGL import GL
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            with self.ctx:
                self.ctx.target(self.width, self.height)
                GL.glClearColor(0, 0, 0, 1)
                GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
                rgba = self.ctx.read_rgba_raw(self.width, self.height, self._rgba)
                cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
            n += 1
        return n / (time.perf_counter() - t0)
