"""Video texture: a virtual display on a link of a model (thesis section 4.3, appendix A).

URDF (both syntaxes of ``sim_world.plugins`` load it)::

    <gazebo>
      <controller:gazebo_ros_video name="gazebo_ros_video_controller"
                                   plugin="libgazebo_ros_video.so">
        <bodyName>mobile_display</bodyName>              <!-- mandatory, a link of THIS model -->
        <imageTopic>/mobile_device/image_in</imageTopic> <!-- default /monitor/image_in -->
        <imageLoad>/mobile_device/load_file</imageLoad>  <!-- default /monitor/load_file -->
        <face>front</face>    <!-- front (= +z of the link), back (= -z), +x -x +y -y, all -->
        <textureWidth>480</textureWidth>   <!-- default: 512 px on the face's long side, -->
        <textureHeight>800</textureHeight> <!-- the face's aspect on the other -->
        <updateRate>60</updateRate>        <!-- Hz (sim time) of texture updates; 0 = every step -->
      </controller:gazebo_ros_video>
    </gazebo>

The display is blue until the first image arrives. Then it shows the last image received on
``imageTopic`` (sensor_msgs/Image: rgb8, rgba8, bgra8, bgr8, mono8 and their OpenCV names
8UC1/3/4, 8SC1/3/4 as in the thesis's table 4.3) or the last file named on ``imageLoad``
(std_msgs/String with an absolute path, ``file://`` or ``package://`` URL; relative
paths are relative to sim_world's working directory; every format OpenCV reads), scaled to the fixed texture size and
drawn unlit, so it glows in the dark. An image with another encoding, or a file that is
missing or unreadable, is reported in one log line and the display keeps its last image.

Unlike Gazebo's plugin it draws on one face of the link's box (``face``), not on all of them,
and any number of displays in one world work, each with its own topics.

Threads: images arrive in rospy callback threads. ``VideoTexture`` (no ROS in it, so unit
tests use it directly) converts and scales them there and keeps the result under a lock;
the plugin's ``update()``, which the World calls from its render loop where the GL context
is current, hands the newest image to ``world.renderer.set_dynamic_texture``.
"""
import logging
import os
import threading

import numpy as np

from simvid.imageconv import CHANNELS, UnsupportedEncoding, image_to_array
from sim_world.logonce import LogOnce
from sim_world.plugins import Plugin, PluginError, register
from sim_world.plugins.params import Param

__all__ = ['VideoTexture', 'VideoPlugin', 'ENCODINGS', 'FACES', 'BLUE', 'DEFAULT_SIZE']

log = logging.getLogger('textvid.video')

#: encodings the display accepts (thesis table 4.3; the 8UC/8SC names are OpenCV's)
ENCODINGS = ('rgb8', 'rgba8', 'bgra8', 'bgr8', 'mono8',
             '8UC1', '8UC3', '8UC4', '8SC1', '8SC3', '8SC4')
#: faces of the link's box the texture can be drawn on ('front' is +z of the link, 'back' -z)
FACES = ('front', 'back', '+x', '-x', '+y', '-y', '+z', '-z', 'all')
BLUE = (0, 0, 255)
DEFAULT_SIZE = (512, 512)   # texture width, height of VideoTexture when none is given
LONG_SIDE = 512             # the plugin's default: this many pixels on the face's long side
MIN_SIDE = 16
DEFAULT_RATE = 60.0         # Hz of sim time at which new images are handed to the renderer
MAX_SIZE = 4096


class VideoTexture(object):
    """The image a display shows: blue at first, then the last good image, always
    ``height x width x 3`` uint8 RGB at the texture's fixed size.

    ``set_image_msg``/``set_array``/``load_file`` may be called from any thread; they
    return True when the display changed and False (after one log line through
    ``logger``) when the input was rejected, in which case the last image stays.
    ``take()`` returns the new image once after each change (None otherwise).
    """

    def __init__(self, width=DEFAULT_SIZE[0], height=DEFAULT_SIZE[1], name='video texture',
                 logger=None):
        width, height = int(width), int(height)
        if not (0 < width <= MAX_SIZE and 0 < height <= MAX_SIZE):
            raise ValueError('texture size must be 1..%d pixels, got %dx%d'
                             % (MAX_SIZE, width, height))
        self.width, self.height = width, height
        self.name = name
        self.logger = logger or log.error
        self._lock = threading.Lock()
        self._image = np.empty((height, width, 3), np.uint8)
        self._image[:] = BLUE
        self._dirty = True        # the blue start picture is to be shown, too
        self.source = 'default'   # 'default', 'topic' or 'file:<path>'
        self.frames = 0           # images accepted
        self.errors = 0           # inputs rejected
        self.last_error = None

    # -- reading ---------------------------------------------------------------------------
    @property
    def image(self):
        """The image shown now (a copy)."""
        with self._lock:
            return self._image.copy()

    def take(self):
        """The image to upload if it changed since the last call, else None."""
        with self._lock:
            if not self._dirty:
                return None
            self._dirty = False
            return self._image

    # -- input -----------------------------------------------------------------------------
    def _error(self, text):
        self.errors += 1
        self.last_error = text
        self.logger('%s: %s; keeping the last image' % (self.name, text))
        return False

    def scale(self, img):
        """HxW(xC) uint8 -> the texture's size, same channels. Enlarging and moderate
        shrinking interpolate linearly; a shrink by more than 2 first averages whole blocks
        of pixels (OpenCV's fast integer-factor area path), so nothing aliases."""
        import cv2
        img = np.ascontiguousarray(img)
        h, w = img.shape[:2]
        if (h, w) == (self.height, self.width):
            return img.copy()
        kx, ky = w // self.width, h // self.height
        if kx >= 2 or ky >= 2:
            kx, ky = max(kx, 1), max(ky, 1)
            img = cv2.resize(img, (w // kx, h // ky), interpolation=cv2.INTER_AREA)
            if img.shape[:2] == (self.height, self.width):
                return img
        return cv2.resize(img, (self.width, self.height), interpolation=cv2.INTER_LINEAR)

    _TO_RGB = {'bgr8': 'COLOR_BGR2RGB', 'rgba8': 'COLOR_RGBA2RGB', 'bgra8': 'COLOR_BGRA2RGB',
               'mono8': 'COLOR_GRAY2RGB'}

    def _set(self, arr, norm, source):
        import cv2
        small = self.scale(arr)              # scale first: fewer pixels to convert
        if small.ndim == 3 and small.shape[2] == 1:
            small = small[:, :, 0]
        if norm == 'rgb8':
            rgb = small
        else:
            rgb = cv2.cvtColor(small, getattr(cv2, self._TO_RGB[norm]))
        with self._lock:
            self._image = rgb
            self._dirty = True
            self.source = source
            self.frames += 1
        return True

    def set_array(self, arr, encoding='rgb8', source='array'):
        """Show an HxW(xC) uint8 array in ``encoding`` (one of ENCODINGS)."""
        if encoding not in ENCODINGS:
            return self._error('unsupported image encoding %r (supported: %s)'
                               % (encoding, ', '.join(ENCODINGS[:5])))
        arr = np.asarray(arr)
        if arr.dtype != np.uint8 or arr.ndim not in (2, 3) or 0 in arr.shape[:2]:
            return self._error('image must be a non-empty 8-bit array, got %s %s'
                               % (arr.dtype, arr.shape))
        channels = 1 if arr.ndim == 2 else arr.shape[2]
        if channels != CHANNELS[encoding]:
            return self._error('image with %d channels cannot be %r' % (channels, encoding))
        norm = {'8UC1': 'mono8', '8SC1': 'mono8', '8UC3': 'bgr8', '8SC3': 'bgr8',
                '8UC4': 'bgra8', '8SC4': 'bgra8'}.get(encoding, encoding)
        return self._set(arr, norm, source)

    def set_image_msg(self, msg):
        """Show a sensor_msgs/Image."""
        enc = getattr(msg, 'encoding', None)
        if enc not in ENCODINGS:
            return self._error('unsupported image encoding %r on the image topic (supported: '
                               '%s)' % (enc, ', '.join(ENCODINGS[:5])))
        try:
            arr, norm = image_to_array(msg)
        except UnsupportedEncoding as e:
            return self._error('bad image on the image topic: %s' % e)
        return self.set_array(arr, norm, source='topic')

    def load_file(self, path):
        """Show the image file ``path`` (any format cv2.imread reads)."""
        path = (path or '').strip()
        if not path:
            return self._error('empty image file path')
        path = os.path.expanduser(path)
        if path.startswith('file://'):
            path = path[len('file://'):]
        if not os.path.isfile(path):
            return self._error('image file %r does not exist' % path)
        import cv2
        img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        if img is None or img.size == 0:
            return self._error('cannot read image file %r (not an image format OpenCV '
                               'reads, or damaged)' % path)
        if img.dtype == np.uint16:     # 16-bit PNG/TIFF: the same brightness in 8 bit
            img = (img >> 8).astype(np.uint8)
        elif img.dtype != np.uint8:    # float (EXR, 32-bit TIFF), 8-bit signed: stretch
            img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
        if img.ndim == 2 or img.shape[2] == 1:
            enc = 'mono8'
        elif img.shape[2] in (3, 4):
            enc = 'bgr8' if img.shape[2] == 3 else 'bgra8'
        else:
            return self._error('image file %r has an unsupported layout %s'
                               % (path, img.shape))
        return self.set_array(img, enc, source='file:' + path)


@register('libgazebo_ros_video.so', 'libgazebo_ros_video_plugin.so')
class VideoPlugin(Plugin):
    """``libgazebo_ros_video.so``: a VideoTexture drawn on a face of a link's box."""

    PARAMS = [
        Param('bodyName', str, None, doc='the link whose box shows the video (required)'),
        Param('face', FACES, 'front'),
        Param('updateRate', float, DEFAULT_RATE, unit='Hz', check=(0.0, 1e6)),
        Param('imageTopic', str, '/monitor/image_in'),
        Param('imageLoad', str, '/monitor/load_file'),
        Param('textureWidth', int, None, unit='px', check=(1, MAX_SIZE)),
        Param('textureHeight', int, None, unit='px', check=(1, MAX_SIZE)),
    ]

    def load(self):
        p = self.p = self.parse(self.PARAMS)
        body = p.bodyName
        if not body:
            raise PluginError('parameter <bodyName> is missing: it must name the link of '
                              'model %r that shows the video (links: %s)'
                              % (self.model.name, ', '.join(self.model.links)))
        if body not in self.model.links:
            raise PluginError('<bodyName> %r is not a link of model %r (links: %s)'
                              % (body, self.model.name, ', '.join(self.model.links)))
        boxes = [v for v in self.model.links[body].visuals if v.geometry.kind == 'box']
        if not boxes:
            raise PluginError('link %r of model %r has no box visual to show the video on'
                              % (body, self.model.name))
        self.body = body
        self.face = p.face
        self.size = self._texture_size(boxes[0].geometry.size)
        self.update_rate = p.updateRate
        self.image_topic = self.resolve(p.imageTopic)
        self.load_topic = self.resolve(p.imageLoad)
        label = 'video texture %s/%s' % (self.model.name, body)
        self.texture = VideoTexture(self.size[0], self.size[1], name=label,
                                    logger=self._log_error)
        self._render_failed = LogOnce(say=self._log_error)   # a broken GL stays broken: once
        self._uploaded = False
        self._subs = []
        if self.world.ros_enabled:
            import rospy
            from sensor_msgs.msg import Image
            from std_msgs.msg import String
            self._subs = [
                rospy.Subscriber(self.image_topic, Image, self.on_image, queue_size=1,
                                 buff_size=2 ** 24),
                rospy.Subscriber(self.load_topic, String, self.on_load_file, queue_size=10),
            ]
            rospy.loginfo('%s: image topic %s, file topic %s, face %s, texture %dx%d',
                          label, self.image_topic, self.load_topic, self.face, *self.size)

    def face_extent(self, box_size):
        """(width, height) in metres of the face the texture is drawn on; the renderer
        puts the image's top edge along x on the z faces and towards +z on the others."""
        sx, sy, sz = (float(v) for v in box_size)
        face = {'front': '+z', 'back': '-z', 'all': '+z'}.get(self.face, self.face)
        return {'z': (sy, sx), 'x': (sy, sz), 'y': (sx, sz)}[face[1]]

    def _texture_size(self, box_size):
        """Texture (width, height): <textureWidth>/<textureHeight> when given, else
        LONG_SIDE pixels on the long side of the face and its aspect ratio on the other
        (so the display's pixels are square)."""
        fw, fh = self.face_extent(box_size)
        w, h = self.p.textureWidth, self.p.textureHeight
        if w is not None and h is not None:
            return w, h
        if w is None and h is None:
            if fw >= fh:
                w, h = LONG_SIDE, LONG_SIDE * fh / fw
            else:
                w, h = LONG_SIDE * fw / fh, LONG_SIDE
        elif w is None:
            w = h * fw / fh
        else:
            h = w * fh / fw
        clamp = lambda v: int(min(MAX_SIZE, max(MIN_SIDE, round(v))))  # noqa: E731
        return clamp(w), clamp(h)

    def _log_error(self, text):
        if self.world.ros_enabled:
            import rospy
            rospy.logerr(text)
        else:
            log.error(text)

    # -- ROS callbacks (rospy threads) -----------------------------------------------------
    def on_image(self, msg):
        self.texture.set_image_msg(msg)

    def on_load_file(self, msg):
        path = (msg.data or '').strip()
        if path.startswith(('package://', 'model://')):
            path = self.model.resolve_path(path)
        self.texture.load_file(path)

    # -- render thread ---------------------------------------------------------------------
    def update(self, sim_time):
        if self.world.renderer_if_created is None:
            # No renderer yet: nobody looks. Creating one here would make every world with
            # a display pay for a GL context; the image waits until a camera creates it.
            return
        img = self.texture.take()
        if img is None:
            return
        try:
            self.world.renderer.set_dynamic_texture(self.model.name, self.body, img,
                                                    face=self.face)
            self._uploaded = True
        except Exception as e:  # noqa: BLE001 - a GL problem must not stop the world loop
            self._render_failed('%s: cannot update the texture: %s' % (self.texture.name, e),
                                key='render')

    def texture_size(self, link):
        return (self.texture.width, self.texture.height) if link == self.body else None

    def renderer_created(self, renderer):
        # a camera just created the renderer: show the waiting image in its first frame
        self.update(self.world.sim_time)

    def reset(self):
        # the display keeps showing its picture across /gazebo/reset_world, like a screen
        Plugin.reset(self)

    def shutdown(self):
        for s in self._subs:
            s.unregister()
        self._subs = []
        if not self._uploaded:
            return
        try:
            self.world.renderer.set_dynamic_texture(self.model.name, self.body, None,
                                                    face=self.face)
        except Exception:  # noqa: BLE001 - the world may be going down with its renderer
            pass
