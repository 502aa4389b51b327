"""Video projector of thesis section 3.4.1 (code snippet 3.4.1): ``libgazebo_ros_projector.so``.

Gazebo classic's projector takes only a texture file; the thesis asks for an image topic.
Here the picture is a file (``textureName``) or whatever arrives on ``textureTopicName``
(default ``projector/image``, sensor_msgs/Image: rgb8, bgr8, rgba8, bgra8, mono8), switched
by ``projectorTopicName`` (default ``projector/enable``, std_msgs/Bool). The renderer projects
it from ``bodyName`` (looking along the link's +x, z up, as a camera link) with horizontal
field of view ``fov`` (rad; the vertical one follows the image's aspect) between
``nearClipDist`` and ``farClipDist`` onto every surface in the frustum (projective texturing:
a point light of ``brightness`` at 1 m, 1/d^2 and cosine falloff, times the picture and the
surface colour, added to the lit colour), so every camera in the world sees it.
``filterTextureName`` (snippet's filter): a grey image multiplied into the picture (a
vignette/mask). ``alwaysOn`` false: starts switched off. The battery sees ``power`` W while on.
Updates (new image, on/off, the link's pose is followed at every render) at ``updateRate``.

Bad input (unreadable texture file, unsupported encoding, wrong data size): one error line
naming it; the projector keeps its last good picture; the world keeps running.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.device import Actuator
from sim_world.transforms import Pose

__all__ = ['Projector', 'image_from_msg', 'pixel_ray', 'pixel_on_plane', 'world_to_pixel']

ENCODINGS = ('rgb8', 'bgr8', 'rgba8', 'bgra8', 'mono8')


def _focal(width, fov):
    return width / (2.0 * math.tan(fov / 2.0))


def pixel_ray(pose, fov, width, height, u, v):
    """World direction (unit) of image point (u, v) (OpenCV pixels: centres at integers;
    the image's top-left corner is (-0.5, -0.5)) of a projector at ``pose`` (link: x forward,
    y left, z up)."""
    f = _focal(width, fov)
    cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    d_link = np.array([1.0, -(u - cx) / f, -(v - cy) / f])
    d = pose.rotate(d_link)
    return d / np.linalg.norm(d)


def pixel_on_plane(pose, fov, width, height, u, v, plane_point, plane_normal):
    """Where image point (u, v) lands on a plane (None when it does not go that way)."""
    d = pixel_ray(pose, fov, width, height, u, v)
    n = np.asarray(plane_normal, float)
    den = d.dot(n)
    if abs(den) < 1e-12:
        return None
    s = (np.asarray(plane_point, float) - pose.p).dot(n) / den
    return pose.p + s * d if s > 0 else None


def world_to_pixel(pose, fov, width, height, point):
    """(u, v, depth) of a world point in the projector's image (depth along +x)."""
    pc = pose.inverse() * Pose(np.asarray(point, float))
    x, y, z = pc.p
    f = _focal(width, fov)
    return f * -y / x + (width - 1) / 2.0, f * -z / x + (height - 1) / 2.0, x


def image_from_msg(msg):
    """HxWx3 uint8 RGB of a sensor_msgs/Image; ValueError naming what is wrong."""
    enc = msg.encoding.lower()
    if enc not in ENCODINGS:
        raise ValueError('encoding %r is not supported (use %s)' % (msg.encoding,
                                                                   ', '.join(ENCODINGS)))
    ch = {'mono8': 1, 'rgb8': 3, 'bgr8': 3}.get(enc, 4)
    w, h, step = int(msg.width), int(msg.height), int(msg.step)
    data = np.frombuffer(bytes(msg.data), np.uint8)
    if w < 1 or h < 1 or step < w * ch or len(data) < step * h:
        raise ValueError('%dx%d %s image needs %d bytes with step %d, got %d'
                         % (w, h, enc, step * h, step, len(data)))
    img = data[:step * h].reshape(h, step)[:, :w * ch].reshape(h, w, ch)
    if ch == 1:
        return np.repeat(img, 3, axis=2)
    img = img[:, :, :3]
    return np.ascontiguousarray(img[:, :, ::-1] if enc.startswith('bgr') else img)


def _read_image(path):
    import cv2
    img = cv2.imread(path, cv2.IMREAD_COLOR) if path else None
    if img is None:
        raise ValueError('cannot read image file %r' % path)
    return np.ascontiguousarray(img[:, :, ::-1])


@register('libgazebo_ros_projector.so', 'libprojector.so')
class Projector(Actuator):
    DEFAULT_TOPIC = 'projector/image'
    DEFAULT_RATE = 15.0
    PARAMS = [
        Param('textureName', str, '', doc='image file projected at start'),
        Param('filterTextureName', str, '', doc='grey mask multiplied into the picture'),
        Param('textureTopicName', str, 'projector/image', doc='sensor_msgs/Image in'),
        Param('projectorTopicName', str, 'projector/enable', doc='std_msgs/Bool on/off in'),
        Param('fov', float, math.pi / 4, unit='rad', check=(1e-3, 3.1)),
        Param('nearClipDist', float, 0.1, unit='m', check='>0'),
        Param('farClipDist', float, 10.0, unit='m', check='>0'),
        Param('brightness', float, 1.0, check='>=0', doc='added light at 1 m (1 = white)'),
        Param('power', float, 1.5, unit='W', check='>=0', doc='draw while on'),
        Param('alwaysOn', bool, True, doc='on from the start'),
    ]

    def setup(self):
        p = self.p
        self.image = None
        self.enabled = bool(p.alwaysOn)
        self.filter = None
        self.shown = None            # (enabled, id(image)) pushed to the renderer
        if p.farClipDist <= p.nearClipDist:
            self.log_error('%s: farClipDist %g must be > nearClipDist %g; using %g'
                           % (self.label, p.farClipDist, p.nearClipDist, p.nearClipDist * 100))
            p.farClipDist = p.nearClipDist * 100
        if p.filterTextureName:
            try:
                f = _read_image(p.filterTextureName)
                self.filter = f.mean(axis=2) / 255.0
            except ValueError as e:
                self.log_error('%s: filterTextureName: %s; no filter' % (self.label, e))
        if p.textureName:
            try:
                self.set_image(_read_image(p.textureName))
            except ValueError as e:
                self.log_error('%s: textureName: %s; nothing projected until an image '
                               'arrives' % (self.label, e))
        if self.ros:
            from sensor_msgs.msg import Image
            from std_msgs.msg import Bool
            self.subscribe(p.textureTopicName, Image, self._on_image, queue_size=2)
            self.subscribe(p.projectorTopicName, Bool, lambda m: self.enable(m.data))

    # -- commands (any thread) ---------------------------------------------------------------
    def _on_image(self, msg):
        try:
            rgb = image_from_msg(msg)
        except ValueError as e:
            self.log_error('%s: %s: %s; keeps the last picture'
                           % (self.label, self.p.textureTopicName, e))
            return
        self.set_image(rgb)

    def set_image(self, rgb):
        rgb = np.asarray(rgb, np.uint8)
        if self.filter is not None:
            import cv2
            m = cv2.resize(self.filter, (rgb.shape[1], rgb.shape[0]))
            rgb = (rgb * m[:, :, None]).astype(np.uint8)
        self.queue(('image', rgb))
        return True

    def enable(self, on):
        self.queue(('enable', bool(on)))

    # -- schedule ----------------------------------------------------------------------------
    def act(self, sim_time, commands):
        for kind, v in commands:       # ('image', rgb) | ('enable', bool), in order
            if kind == 'image':
                self.image = v
            else:
                self.enabled = v
        on = self.enabled and self.image is not None
        self.last_value = on
        self.power('projector', self.p.power if on else 0.0)
        key = (on, id(self.image))
        if key != self.shown:
            self._paint()

    def _paint(self):
        on = self.enabled and self.image is not None
        image = self.image if on else None
        try:
            if self.paint(lambda r: r.set_projector(
                    (self.model.name, self.spec.name), self.model.name, self.body, self.p.fov,
                    self.p.nearClipDist, self.p.farClipDist, image, self.p.brightness)):
                self.shown = (on, id(self.image))
        except Exception as e:  # noqa: BLE001
            self.log_error('%s: cannot project: %s' % (self.label, e))

    def renderer_created(self, renderer):
        self._paint()

    def shutdown(self):
        self.paint(lambda r: r.remove_projector((self.model.name, self.spec.name)))
        self.power('projector', 0.0)
        Actuator.shutdown(self)
