"""The sim camera plugin (``libgazebo_ros_camera.so``, thesis section 4.1, table 4.1).

Reads both URDF syntaxes::

    <!-- 2011 (thesis appendix A) -->
    <sensor:camera name="camera_sensor">
      <imageSize>480 800</imageSize> <updateRate>30.0</updateRate> <hfov>60</hfov>
      <nearClip>0.02</nearClip> <farClip>100</farClip>
      <controller:gazebo_ros_camera name="c" plugin="libgazebo_ros_camera.so">
        <imageTopicName>/mobile_device/image_raw</imageTopicName> ...
    <!-- Gazebo classic -->
    <sensor type="camera" name="cam"> <update_rate>30</update_rate>
      <camera> <horizontal_fov>1.047</horizontal_fov> <image><width>480</width>
               <height>800</height></image> <clip><near>0.02</near><far>100</far></clip>
      </camera>
      <plugin name="c" filename="libgazebo_ros_camera.so"> <cameraName>cam</cameraName> ...

Publishes ``image_raw`` (rgb8), ``camera_info`` (same stamp, every frame) and ``points``
(PointCloud2, only while subscribed), all stamped with sim time; subscribes ``set_hfov``
(radians) and ``set_update_rate`` (Hz) next to the image topic. Renders only while someone
subscribes. Registered as ``libgazebo_ros_openni_kinect.so`` / ``libgazebo_ros_depth_camera.so``
it also publishes ``depth/image_raw`` (32FC1, metres along the optical axis, NaN where
nothing is seen; ``depthImageTopicName``) and ``depth/camera_info``
(``depthImageCameraInfoTopicName``); ``pointCloudCutoff``/``pointCloudCutoffMax`` limit the
range of the points. The camera looks along the link's +x (z up in the image); points are in the
optical frame (x right, y down, z forward) of ``frameName``.
"""
import logging
import math
import threading

from . import Plugin, PluginError, register
from ..model import _local
from ..camera_model import IMAGE_FORMATS, SimCamera, CameraModelError

__all__ = ['CameraPlugin']

log = logging.getLogger('simvid.plugins.camera')


def _find(elem, *path):
    """Text of the element at ``path`` (local tag names) below ``elem``, or None."""
    cur = elem
    for name in path:
        if cur is None:
            return None
        cur = next((c for c in cur if _local(c.tag) == name), None)
    if cur is None or cur.text is None:
        return None
    return cur.text.strip()


@register('libgazebo_ros_camera.so', 'libgazebo_ros_openni_kinect.so',
          'libgazebo_ros_depth_camera.so')
class CameraPlugin(Plugin):
    """See module doc. ``self.camera`` is the ROS-free ``SimCamera``."""

    DEFAULT_HFOV = math.radians(60.0)

    def __init__(self, spec, model, world):
        Plugin.__init__(self, spec, model, world)
        self.link = spec.link
        self._lock = threading.Lock()
        self._pending_hfov = None
        self.frames = 0
        self.last_image = None       # last published sensor_msgs/Image (also without ROS)
        self.last_info = None
        self.last_cloud = None
        self.force_render = False    # render without subscribers (tests, benchmarks)
        self._pubs = {}
        self._subs = []

    # -- parameters --------------------------------------------------------------------------
    def _number(self, text, what, positive=False, allow_zero=True):
        try:
            v = float(text)
        except (TypeError, ValueError):
            raise PluginError('%s: %s must be a number, got %r' % (self.label, what, text))
        if not math.isfinite(v) or (positive and (v < 0 or (v == 0 and not allow_zero))):
            raise PluginError('%s: %s must be a %snumber, got %r'
                              % (self.label, what, 'positive ' if positive else 'finite ', text))
        return v

    @property
    def label(self):
        return '%s (model %s, link %s)' % (self.spec.filename, self.model.name, self.link)

    def _sensor(self, *path):
        return _find(self.spec.sensor, *path) if self.spec.sensor is not None else None

    def _read_size(self):
        size = self.param('imageSize')
        if size is not None:
            parts = size.replace(',', ' ').split()
            try:
                w, h = (int(float(p)) for p in parts)
                if w != float(parts[0]) or h != float(parts[1]):
                    raise ValueError
            except ValueError:
                raise PluginError('%s: <imageSize> must be "width height" in pixels, got %r'
                                  % (self.label, size))
        else:
            ws = self._sensor('camera', 'image', 'width') or self.param('width')
            hs = self._sensor('camera', 'image', 'height') or self.param('height')
            w = self._number(ws, '<image><width>', positive=True) if ws is not None else 320
            h = self._number(hs, '<image><height>', positive=True) if hs is not None else 240
            if w != int(w) or h != int(h):
                raise PluginError('%s: image width/height must be whole pixels, got %r x %r'
                                  % (self.label, ws, hs))
            w, h = int(w), int(h)
        if not (0 < w <= 8192 and 0 < h <= 8192):
            raise PluginError('%s: image size must be 1..8192 pixels, got %dx%d'
                              % (self.label, w, h))
        return w, h

    def _read_hfov(self):
        deg = self.param('hfov')
        if deg is not None:           # 2011: degrees
            hfov = math.radians(self._number(deg, '<hfov> (degrees)'))
            what = '<hfov> %s degrees' % deg
        else:
            rad = self._sensor('camera', 'horizontal_fov') or self.param('horizontal_fov')
            if rad is None:
                return self.DEFAULT_HFOV
            hfov = self._number(rad, '<horizontal_fov> (radians)')
            what = '<horizontal_fov> %s radians' % rad
        if not (0.0 < hfov < math.pi):
            raise PluginError('%s: %s is outside (0, 180) degrees' % (self.label, what))
        return hfov

    def _read_rate(self):
        rates = []
        for text, what in ((self._sensor('update_rate'), '<update_rate>'),
                           (self.spec.sensor is not None and _find(self.spec.sensor,
                                                                    'updateRate'), '<updateRate>'),
                           (_find(self.spec.element, 'updateRate')
                            if self.spec.element is not None else None, 'plugin <updateRate>')):
            if text:
                r = self._number(text, what, positive=True)
                if r > 0:
                    rates.append(r)
        return min(rates) if rates else 0.0

    def _read_clip(self):
        near = self._sensor('camera', 'clip', 'near') or self.param('nearClip')
        far = self._sensor('camera', 'clip', 'far') or self.param('farClip')
        near = self._number(near, 'near clip', positive=True, allow_zero=False) \
            if near is not None else 0.02
        far = self._number(far, 'far clip', positive=True, allow_zero=False) \
            if far is not None else 100.0
        if not near < far:
            raise PluginError('%s: near clip %g must be less than far clip %g'
                              % (self.label, near, far))
        return near, far

    def _read_distortion(self):
        out = []
        for n in ('k1', 'k2', 't1', 't2', 'k3'):
            text = self.param('distortion_' + n, 'distortion' + n.upper())
            if text is None:
                text = self._sensor('camera', 'distortion', {'t1': 'p1', 't2': 'p2'}.get(n, n))
            out.append(self._number(text, '<distortion_%s>' % n) if text is not None else 0.0)
        return out

    def load(self):
        self.link = self.spec.link or self.model.root_link
        if self.link not in self.model.links:
            raise PluginError('%s: camera link %r is not a link of the model'
                              % (self.label, self.link))
        w, h = self._read_size()
        hfov = self._read_hfov()
        near, far = self._read_clip()
        f = self._number(self.param('focal_length', 'focalLength', default='0'),
                         '<focal_length>', positive=True)
        cx = self._number(self.param('Cx', default='0'), '<Cx>')
        cy = self._number(self.param('Cy', default='0'), '<Cy>')
        dist = self._read_distortion()
        try:
            self.camera = SimCamera(w, h, hfov, f, cx, cy, dist, near, far)
        except CameraModelError as e:
            raise PluginError('%s: %s' % (self.label, e))
        self.update_rate = self._read_rate()
        self.frame_id = self.param('frameName') or self.link
        fmt = self._sensor('camera', 'image', 'format') or self.param('imageFormat')
        if fmt is None:
            self.encoding = 'rgb8'
        elif fmt.strip() in IMAGE_FORMATS:
            self.encoding = IMAGE_FORMATS[fmt.strip()]
        else:
            raise PluginError('%s: image format %r is not supported (use one of %s)'
                              % (self.label, fmt, ', '.join(sorted(IMAGE_FORMATS))))
        cam_name = (self.param('cameraName') or '').strip('/')

        def topic(names, default):
            t = self.param(*names, default=default)
            if cam_name and not t.startswith('/'):
                t = cam_name + '/' + t
            return self.resolve(t)
        self.image_topic = topic(('imageTopicName',), 'image_raw')
        self.info_topic = topic(('cameraInfoTopicName',), 'camera_info')
        self.points_topic = topic(('pointCloudTopicName',), 'points')
        # depth cameras (openni_kinect / depth_camera names, or any camera that names a
        # depthImageTopicName): 32FC1 depth in metres along the optical axis + its info
        depth_default = 'depth/image_raw' if self._is_depth_camera() else None
        d = self.param('depthImageTopicName', default=depth_default)
        self.depth_topic = topic(('depthImageTopicName',), d) if d else None
        self.depth_info_topic = topic(('depthImageCameraInfoTopicName',),
                                      'depth/camera_info') if d else None
        lo = self._number(self.param('pointCloudCutoff', default='0'), '<pointCloudCutoff>',
                          positive=True)
        hi = self._number(self.param('pointCloudCutoffMax', default='0'),
                          '<pointCloudCutoffMax>', positive=True)
        if hi and hi <= lo:
            raise PluginError('%s: <pointCloudCutoffMax> %g must be more than <pointCloudCutoff>'
                              ' %g' % (self.label, hi, lo))
        self.cutoff = (lo, hi or float('inf'))
        base = self.image_topic.rsplit('/', 1)[0]
        self.hfov_topic = base + '/set_hfov'
        self.rate_topic = base + '/set_update_rate'
        if getattr(self.world, 'ros_enabled', False):
            self._make_ros()

    def _is_depth_camera(self):
        name = self.spec.filename or ''
        return 'openni_kinect' in name or 'depth_camera' in name

    def _make_ros(self):
        import rospy
        from sensor_msgs.msg import Image, CameraInfo, PointCloud2
        from std_msgs.msg import Float64
        self._pubs = {
            'image': rospy.Publisher(self.image_topic, Image, queue_size=10),
            'info': rospy.Publisher(self.info_topic, CameraInfo, queue_size=10),
            'points': rospy.Publisher(self.points_topic, PointCloud2, queue_size=2),
        }
        if self.depth_topic:
            self._pubs['depth'] = rospy.Publisher(self.depth_topic, Image, queue_size=2)
            self._pubs['depth_info'] = rospy.Publisher(self.depth_info_topic, CameraInfo,
                                                       queue_size=2)
        self._subs = [rospy.Subscriber(self.hfov_topic, Float64, self._on_hfov, queue_size=10),
                      rospy.Subscriber(self.rate_topic, Float64, self._on_rate, queue_size=10)]
        rospy.loginfo('camera %s: %dx%d, hfov %.1f deg (f = %.2f px), %s Hz sim time, '
                      'image %s, info %s, points %s', self.label, self.camera.intr.width,
                      self.camera.intr.height, math.degrees(self.camera.hfov),
                      self.camera.intr.fx, self.update_rate or 'every step',
                      self.image_topic, self.info_topic, self.points_topic)

    def _error(self, text):
        if self._pubs:
            import rospy
            rospy.logerr(text)
        else:
            log.error(text)

    # -- run-time changes (rospy threads; applied in the world thread) ------------------------
    def _on_hfov(self, msg):
        self.set_hfov(msg.data)

    def _on_rate(self, msg):
        self.set_update_rate(msg.data)

    def set_hfov(self, hfov):
        """Queue a new horizontal FOV (radians); bad values get one error line."""
        try:
            hfov = float(hfov)
        except (TypeError, ValueError):
            hfov = float('nan')
        if not (0.0 < hfov < math.pi):
            self._error('%s: set_hfov %r ignored: the horizontal field of view must be '
                        'between 0 and pi radians' % (self.label, hfov))
            return False
        with self._lock:
            self._pending_hfov = hfov
        return True

    def set_update_rate(self, rate):
        """New rate in Hz of sim time (0 = every world step); negative/NaN are refused."""
        try:
            rate = float(rate)
        except (TypeError, ValueError):
            rate = float('nan')
        if not (math.isfinite(rate) and rate >= 0):
            self._error('%s: set_update_rate %r ignored: the rate must be a number >= 0 Hz'
                        % (self.label, rate))
            return False
        # effective at once (the next frame one new period after the last one), not after
        # the old period has run out
        self.set_update_rate_now(rate)
        return True

    def _apply_pending(self, sim_time):
        with self._lock:
            hfov, self._pending_hfov = self._pending_hfov, None
        if hfov is not None:
            try:
                self.camera.set_hfov(hfov)
            except CameraModelError as e:
                self._error('%s: set_hfov ignored: %s' % (self.label, e))

    # -- frames ------------------------------------------------------------------------------
    def wanted(self):
        """(anything wanted, depth wanted) by subscribers: the image, camera_info, points or
        (depth cameras) the depth image or its info."""
        if not self._pubs:
            return True, self.force_render

        def subs(*keys):
            return any(k in self._pubs and self._pubs[k].get_num_connections() > 0
                       for k in keys)
        depth = subs('points', 'depth', 'depth_info')
        img = subs('image', 'info')
        return img or depth or self.force_render, depth

    def update(self, sim_time):
        self._apply_pending(sim_time)
        want, want_depth = self.wanted()
        if not want:
            return
        pose = self.world.link_pose(self.model.name, self.link)
        rgb, depth = self.camera.render(self.world.renderer, pose, depth=want_depth)
        stamp = self.world.ros_now() if self._pubs else None
        img = self.camera.image_msg(rgb, stamp, self.frame_id, self.encoding)
        info = self.camera.camera_info(stamp, self.frame_id)
        cloud = depth_img = None
        pubs = self._pubs
        if want_depth:
            if not pubs or pubs['points'].get_num_connections() > 0:
                cloud = self.camera.cloud_msg(rgb, depth, stamp, self.frame_id, self.cutoff)
            if 'depth' in pubs and (pubs['depth'].get_num_connections() > 0
                                    or pubs['depth_info'].get_num_connections() > 0):
                depth_img = self.camera.depth_msg(depth, stamp, self.frame_id)
        self.frames += 1
        self.last_image, self.last_info, self.last_cloud = img, info, cloud
        self.last_depth = depth_img
        self.last_rgb = rgb
        if pubs:
            pubs['image'].publish(img)
            pubs['info'].publish(info)
            if cloud is not None:
                pubs['points'].publish(cloud)
            if depth_img is not None:
                pubs['depth'].publish(depth_img)
                pubs['depth_info'].publish(info)

    def shutdown(self):
        for s in self._subs:
            s.unregister()
        for p in self._pubs.values():
            p.unregister()
        self._subs, self._pubs = [], {}
