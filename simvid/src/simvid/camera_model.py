"""Pinhole camera math of the sim camera: intrinsics, camera_info, lens distortion applied
to the image, point clouds from depth. Pure numpy/OpenCV (no GL, no ROS master needed);
``SimCamera`` ties it to a ``sim_world.render.Renderer``.

Conventions (as ROS/OpenCV use them): pixel centres at integer coordinates, u to the
right, v down; the optical frame has x right, y down, z forward. The camera link of the URDF
looks along its +x with z up (Gazebo); the renderer handles that turn.

Focal length (thesis table 4.1): f = width / (2 tan(hfov / 2)), fx = fy = f (square
pixels; the vertical field of view follows the aspect ratio). Principal point: (w-1)/2,
(h-1)/2 unless given (0 = automatic, as the thesis's Cx/Cy).

Distortion: plumb_bob, D = [k1, k2, t1, t2, k3] (OpenCV's k1 k2 p1 p2 k3). The image is
rendered undistorted by a pinhole camera large enough to hold what the lens bends into the
frame, then warped with ``cv2.remap`` through maps computed once per parameter set, so that
``cv2.undistort``/``cv2.undistortPoints`` with the published K and D straighten it again.
"""
import math

import numpy as np

# Gazebo's <image><format> (and the 2011 <imageFormat>) -> ROS encoding
IMAGE_FORMATS = {'R8G8B8': 'rgb8', 'RGB_INT8': 'rgb8', 'B8G8R8': 'bgr8', 'BGR_INT8': 'bgr8',
                 'L8': 'mono8', 'L_INT8': 'mono8'}

__all__ = ['IMAGE_FORMATS', 'CameraModelError', 'focal_from_hfov', 'hfov_from_focal', 'Intrinsics',
           'Distorter', 'camera_info', 'pack_rgb', 'points_from_depth', 'point_cloud2',
           'SimCamera']


class CameraModelError(ValueError):
    """Camera parameters that make no camera; the message says which."""


def focal_from_hfov(width, hfov):
    """Focal length in pixels of an image ``width`` px wide with horizontal FOV ``hfov`` rad."""
    if not (0.0 < hfov < math.pi):
        raise CameraModelError('horizontal field of view must be between 0 and 180 degrees, '
                               'got %.4g rad (%.4g deg)' % (hfov, math.degrees(hfov)))
    return width / (2.0 * math.tan(hfov / 2.0))


def hfov_from_focal(width, f):
    if not f > 0:
        raise CameraModelError('focal length must be positive, got %r' % f)
    return 2.0 * math.atan(width / (2.0 * f))


class Intrinsics(object):
    """Image size, K entries and plumb_bob distortion coefficients."""

    def __init__(self, width, height, hfov=math.radians(60), focal_length=0.0, cx=0.0, cy=0.0,
                 distortion=(0.0, 0.0, 0.0, 0.0, 0.0)):
        try:
            width, height = int(width), int(height)
        except (TypeError, ValueError):
            raise CameraModelError('image size must be two integers, got %r x %r'
                                   % (width, height))
        if width <= 0 or height <= 0 or width > 8192 or height > 8192:
            raise CameraModelError('image size must be 1..8192 pixels, got %dx%d'
                                   % (width, height))
        self.width, self.height = width, height
        vals = [hfov, focal_length, cx, cy] + list(distortion)
        if not all(np.isfinite(float(v)) for v in vals):
            raise CameraModelError('camera parameters must be finite numbers, got hfov=%r '
                                   'focal_length=%r cx=%r cy=%r distortion=%r'
                                   % (hfov, focal_length, cx, cy, list(distortion)))
        if focal_length and focal_length > 0:
            self.fx = float(focal_length)
            self.hfov = hfov_from_focal(width, self.fx)
        elif focal_length and focal_length < 0:
            raise CameraModelError('focal_length must be positive (0 = automatic), got %r'
                                   % focal_length)
        else:
            self.fx = focal_from_hfov(width, float(hfov))
            self.hfov = float(hfov)
        self.fy = self.fx
        self.cx = float(cx) if cx else (width - 1) / 2.0
        self.cy = float(cy) if cy else (height - 1) / 2.0
        d = [float(x) for x in distortion]
        if len(d) != 5:
            raise CameraModelError('distortion needs 5 coefficients k1 k2 t1 t2 k3, got %r' % d)
        self.D = np.array(d)

    @property
    def vfov(self):
        return 2.0 * math.atan(self.height / (2.0 * self.fy))

    def K(self):
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def P(self):
        return np.hstack([self.K(), np.zeros((3, 1))])

    @property
    def distorted(self):
        return bool(np.any(self.D != 0.0))

    def key(self):
        return (self.width, self.height, self.fx, self.fy, self.cx, self.cy, tuple(self.D))

    def project(self, xyz_optical):
        """Pixels (N, 2) of points (N, 3) in the optical frame, with distortion."""
        import cv2
        pts = np.asarray(xyz_optical, float).reshape(-1, 1, 3)
        uv, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), self.K(), self.D)
        return uv.reshape(-1, 2)


def distort_normalized(x, y, D):
    """plumb_bob forward model on normalized coordinates."""
    k1, k2, t1, t2, k3 = D
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * t1 * x * y + t2 * (r2 + 2.0 * x * x)
    yd = y * radial + t1 * (r2 + 2.0 * y * y) + 2.0 * t2 * x * y
    return xd, yd


def undistort_normalized(xd, yd, D, iterations=20):
    """Invert ``distort_normalized`` by fixed-point iteration plus Newton polish; returns
    (x, y, ok) with ok False where the inverse does not exist (beyond the lens's fold)."""
    k1, k2, t1, t2, k3 = D
    x, y = xd.copy(), yd.copy()
    for _ in range(iterations):
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dx = 2.0 * t1 * x * y + t2 * (r2 + 2.0 * x * x)
        dy = t1 * (r2 + 2.0 * y * y) + 2.0 * t2 * x * y
        with np.errstate(all='ignore'):
            x = (xd - dx) / radial
            y = (yd - dy) / radial
    for _ in range(5):    # Newton on the 2x2 system
        with np.errstate(all='ignore'):
            fx, fy = distort_normalized(x, y, D)
            ex, ey = fx - xd, fy - yd
            h = 1e-6
            ax, ay = distort_normalized(x + h, y, D)
            bx, by = distort_normalized(x, y + h, D)
            j11, j21 = (ax - fx) / h, (ay - fy) / h
            j12, j22 = (bx - fx) / h, (by - fy) / h
            det = j11 * j22 - j12 * j21
            x = x - (j22 * ex - j12 * ey) / det
            y = y - (-j21 * ex + j11 * ey) / det
    with np.errstate(all='ignore'):
        fx, fy = distort_normalized(x, y, D)
        err = np.hypot(fx - xd, fy - yd)
        # a valid inverse has a positive Jacobian (the lens does not fold back)
        ax, ay = distort_normalized(x + 1e-6, y, D)
        bx, by = distort_normalized(x, y + 1e-6, D)
        det = (ax - fx) * (by - fy) - (bx - fx) * (ay - fy)
    ok = np.isfinite(x) & np.isfinite(y) & (err < 1e-7) & (det > 0)
    return x, y, ok


class Distorter(object):
    """Render camera + remap maps for one Intrinsics.

    ``render_view_params``: (width, height, fx, fy, cx, cy) of the undistorted pinhole image
    to render; ``apply(img)`` warps it into the published (distorted) image; ``rays``: per
    output pixel the undistorted normalized coordinates (x/z, y/z) of its line of sight
    (NaN where the lens sees nothing), for point clouds.
    """

    MAX_SCALE = 2.5   # render at most 2.5x the output size per axis

    def __init__(self, intr):
        self.intr = intr
        w, h = intr.width, intr.height
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        xd = (u - intr.cx) / intr.fx
        yd = (v - intr.cy) / intr.fy
        self.identity = not intr.distorted
        if self.identity:
            self.render_view_params = (w, h, intr.fx, intr.fy, intr.cx, intr.cy)
            self.rays = (xd.astype(np.float32), yd.astype(np.float32))
            self.map1 = self.map2 = None
            return
        import cv2                      # only for a lens with distortion (0.2 s to import)
        x, y, ok = undistort_normalized(xd, yd, intr.D)
        if not ok.any():
            raise CameraModelError('distortion %s maps no pixel of the image to a line of sight'
                                   % list(intr.D))
        xs, ys = x[ok], y[ok]
        fx, fy = intr.fx, intr.fy
        x0, x1 = float(xs.min()), float(xs.max())
        y0, y1 = float(ys.min()), float(ys.max())
        wr, hr = fx * (x1 - x0) + 4.0, fy * (y1 - y0) + 4.0
        s = min(1.0, self.MAX_SCALE * w / wr, self.MAX_SCALE * h / hr)
        fxr, fyr = fx * s, fy * s
        wr_i = int(math.ceil(fxr * (x1 - x0))) + 4
        hr_i = int(math.ceil(fyr * (y1 - y0))) + 4
        cxr = -fxr * x0 + 2.0
        cyr = -fyr * y0 + 2.0
        self.render_view_params = (wr_i, hr_i, fxr, fyr, cxr, cyr)
        mx = np.where(ok, fxr * x + cxr, -10.0).astype(np.float32)
        my = np.where(ok, fyr * y + cyr, -10.0).astype(np.float32)
        self.map1, self.map2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
        self._nearest = (mx, my)
        nan = np.float32(np.nan)
        self.rays = (np.where(ok, x, nan).astype(np.float32), np.where(ok, y, nan).astype(np.float32))

    def apply(self, img, border=(0, 0, 0)):
        import cv2
        if self.identity:
            return img
        return cv2.remap(img, self.map1, self.map2, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=border)

    def apply_depth(self, depth):
        import cv2
        if self.identity:
            return depth
        return cv2.remap(depth, self._nearest[0], self._nearest[1], cv2.INTER_NEAREST,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=float('inf'))


def camera_info(intr, stamp=None, frame_id='', msg=None):
    """sensor_msgs/CameraInfo of ``intr`` (plumb_bob D, R = I, P = [K | 0])."""
    from sensor_msgs.msg import CameraInfo
    if msg is None:
        msg = CameraInfo()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.width, msg.height = intr.width, intr.height
    msg.distortion_model = 'plumb_bob'
    msg.D = [float(x) for x in intr.D]
    msg.K = [float(x) for x in intr.K().ravel()]
    msg.R = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    msg.P = [float(x) for x in intr.P().ravel()]
    msg.binning_x = msg.binning_y = 0
    return msg


def pack_rgb(rgb):
    """HxWx3 uint8 -> HxW float32 whose bits are 0x00RRGGBB (PCL's packed rgb field)."""
    rgb = np.asarray(rgb, np.uint8)
    u = ((rgb[..., 0].astype(np.uint32) << 16) | (rgb[..., 1].astype(np.uint32) << 8)
         | rgb[..., 2].astype(np.uint32))
    return u.view(np.float32)


def points_from_depth(depth, rays, far=np.inf):
    """HxW depth (metres along z) and rays (x/z, y/z per pixel) -> HxWx3 float32 points in
    the optical frame; NaN where nothing was seen (inf depth, beyond ``far``)."""
    z = np.asarray(depth, np.float32)
    bad = ~np.isfinite(z) | (z >= far)
    z = np.where(bad, np.nan, z).astype(np.float32)
    return np.dstack([rays[0] * z, rays[1] * z, z]).astype(np.float32)


def point_cloud2(xyz, rgb=None, stamp=None, frame_id=''):
    """Organized sensor_msgs/PointCloud2 (height x width) with fields x y z (float32) and,
    when ``rgb`` is given, rgb (float32 packed as PCL does); point_step 16 or 12."""
    from sensor_msgs.msg import PointCloud2, PointField
    h, w = xyz.shape[:2]
    n = 4 if rgb is not None else 3
    buf = np.empty((h, w, n), np.float32)
    buf[:, :, :3] = xyz
    if rgb is not None:
        buf[:, :, 3] = pack_rgb(rgb)
    msg = PointCloud2()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = h, w
    names = ['x', 'y', 'z', 'rgb'][:n]
    msg.fields = [PointField(name=nm, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                  for i, nm in enumerate(names)]
    msg.is_bigendian = False
    msg.point_step = 4 * n
    msg.row_step = 4 * n * w
    msg.is_dense = bool(np.all(np.isfinite(xyz)))
    msg.data = buf.tobytes()
    return msg


class SimCamera(object):
    """A camera's frames without ROS: intrinsics (+distortion), the render camera, and the
    messages of one frame. ``pose`` given to ``render`` is the world pose of the camera link.
    """

    def __init__(self, width, height, hfov=math.radians(60), focal_length=0.0, cx=0.0, cy=0.0,
                 distortion=(0.0,) * 5, near=0.02, far=100.0, background=None):
        if not (0 < near < far):
            raise CameraModelError('clip planes must satisfy 0 < near < far, got near=%r far=%r'
                                   % (near, far))
        self.near, self.far = float(near), float(far)
        self.background = tuple(background) if background is not None else None
        self._cx0, self._cy0 = cx, cy
        self._D = tuple(distortion)
        self._set(Intrinsics(width, height, hfov, focal_length, cx, cy, distortion))

    _distorters = {}     # Intrinsics.key() -> Distorter (maps computed once per parameter set)

    def _set(self, intr):
        self.intr = intr
        key = intr.key()
        d = SimCamera._distorters.get(key)
        if d is None:
            d = Distorter(intr)
            if len(SimCamera._distorters) > 16:
                SimCamera._distorters.clear()
            SimCamera._distorters[key] = d
        self.distorter = d

    @property
    def hfov(self):
        return self.intr.hfov

    def set_hfov(self, hfov):
        """New horizontal FOV (radians); the focal length follows (camera_info changes).
        Raises CameraModelError for a bad value (the camera keeps the old one)."""
        try:
            hfov = float(hfov)
        except (TypeError, ValueError):
            raise CameraModelError('hfov must be a number, got %r' % (hfov,))
        intr = Intrinsics(self.intr.width, self.intr.height, hfov, 0.0, self._cx0, self._cy0,
                          self._D)
        self._set(intr)

    def view(self, pose):
        from sim_world.render import CameraView
        w, h, fx, fy, cx, cy = self.distorter.render_view_params
        return CameraView(w, h, self.intr.hfov, pose, near=self.near, far=self.far, cx=cx,
                          cy=cy, background=self.background, fx=fx, fy=fy)

    def render(self, renderer, pose, depth=False):
        """(rgb HxWx3 uint8, depth HxW float32 metres or None) of the published image."""
        bgf = self.background or getattr(renderer, 'background', (0.7, 0.7, 0.75))
        bg = tuple(int(round(255 * c)) for c in bgf[:3])
        if depth:
            rgb, d = renderer.render(self.view(pose), depth=True)
            return self.distorter.apply(rgb, bg), self.distorter.apply_depth(d)
        return self.distorter.apply(renderer.render(self.view(pose)), bg), None

    def submit(self, renderer, pose, done, depth=False):
        """Like ``render``, in the renderer's worker thread (``Renderer.submit``): returns
        at once; ``done(rgb, depth or None)`` is called there with the published image."""
        bgf = self.background or getattr(renderer, 'background', (0.7, 0.7, 0.75))
        bg = tuple(int(round(255 * c)) for c in bgf[:3])
        distorter = self.distorter

        def finish(rgb, d):
            done(distorter.apply(rgb, bg), distorter.apply_depth(d) if depth else None)
        renderer.submit(self.view(pose), finish, depth=depth)

    def camera_info(self, stamp=None, frame_id=''):
        return camera_info(self.intr, stamp, frame_id)

    def image_msg(self, rgb, stamp=None, frame_id='', encoding='rgb8'):
        """sensor_msgs/Image of the rendered rgb in ``encoding`` (rgb8, bgr8, mono8)."""
        import cv2
        from .imageconv import array_to_image
        if encoding == 'bgr8':
            rgb = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
        elif encoding == 'mono8':
            rgb = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        return array_to_image(rgb, encoding, stamp=stamp, frame_id=frame_id)

    def cloud_msg(self, rgb, depth, stamp=None, frame_id='', cutoff=(0.0, float('inf'))):
        """Organized PointCloud2 of the published image's pixels; points nearer than
        cutoff[0] or farther than cutoff[1] (or the far clip) are NaN."""
        d = depth
        if cutoff[0] > 0:
            d = np.where(depth < cutoff[0], np.inf, depth).astype(np.float32)
        xyz = points_from_depth(d, self.distorter.rays, min(self.far, cutoff[1]))
        return point_cloud2(xyz, rgb, stamp, frame_id)

    def depth_msg(self, depth, stamp=None, frame_id=''):
        """sensor_msgs/Image 32FC1 of the depth (metres along the optical axis), NaN where
        nothing was seen (REP 118)."""
        from sensor_msgs.msg import Image
        d = np.where(np.isfinite(depth) & (depth < self.far), depth, np.nan).astype('<f4')
        msg = Image()
        if stamp is not None:
            msg.header.stamp = stamp
        msg.header.frame_id = frame_id
        msg.height, msg.width = d.shape
        msg.encoding = '32FC1'
        msg.is_bigendian = 0
        msg.step = 4 * d.shape[1]
        msg.data = d.tobytes()
        return msg
