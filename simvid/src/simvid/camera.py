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
subscribes to the image, the points or the depth image: a subscriber of ``camera_info``
alone gets it at the camera's rate without a frame drawn (Gazebo's camera publishes it only
with images; a recording of every non-image topic would pay a render per message).
Registered as ``libgazebo_ros_openni_kinect.so`` / ``libgazebo_ros_depth_camera.so``
it also publishes ``depth/image_raw`` (32FC1, metres along the optical axis, NaN where
nothing is seen; ``depthImageTopicName``) and ``depth/camera_info``
(``depthImageCameraInfoTopicName``); ``pointCloudCutoff``/``pointCloudCutoffMax`` limit the
range of the points. The camera looks along the link's +x (z up in the image); points are in the
optical frame (x right, y down, z forward) of ``frameName``.
"""
import math
import threading

from sim_world.plugins import Plugin, PluginError, register
from sim_world import fastpub
from .camera_model import IMAGE_FORMATS, SimCamera, CameraModelError
from sim_world.plugins.params import Param, parse_all

__all__ = ['CameraPlugin']

def _image_size(text):
    parts = text.replace(',', ' ').split()
    w, h = (int(p) for p in parts)
    if not (0 < w <= 8192 and 0 < h <= 8192):
        raise ValueError
    return w, h


_image_size.what = '"width height" in whole pixels, 1..8192'
_PIXELS = (1, 8192)

RATE_ROW = Param('updateRate', float, 0.0, aliases=('update_rate',), unit='Hz', check='>=0',
                 doc='Hz of sim time (0: every step); given on the plugin and on its sensor '
                     '(2011: sensor 30, controller 100) the slowest wins')

#: the camera's parameters, both URDF syntaxes (thesis table 4.1 and Gazebo classic's SDF)
CAMERA_PARAMS = [
    Param('imageSize', _image_size, None, unit='px', doc='2011: "width height"'),
    Param('width', int, 320, unit='px', check=_PIXELS, paths=[('camera', 'image', 'width')]),
    Param('height', int, 240, unit='px', check=_PIXELS, paths=[('camera', 'image', 'height')]),
    Param('hfov', float, None, unit='deg', check=lambda v: 0 < v < 180,
          check_text='in (0, 180) degrees', doc='2011'),
    Param('horizontal_fov', float, None, unit='rad', check=lambda v: 0 < v < math.pi,
          check_text='in (0, pi) radians', paths=[('camera', 'horizontal_fov')]),
    Param('nearClip', float, 0.02, unit='m', check='>0', paths=[('camera', 'clip', 'near')]),
    Param('farClip', float, 100.0, unit='m', check='>0', paths=[('camera', 'clip', 'far')]),
    Param('focal_length', float, 0.0, aliases=('focalLength',), unit='px', check='>=0'),
    Param('Cx', float, 0.0, unit='px'),
    Param('Cy', float, 0.0, unit='px'),
    Param('imageFormat', tuple(sorted(IMAGE_FORMATS)), None,
          paths=[('camera', 'image', 'format')]),
    Param('pointCloudCutoff', float, 0.0, unit='m', check='>=0'),
    Param('pointCloudCutoffMax', float, 0.0, unit='m', check='>=0'),
] + [Param('distortion_' + n, float, 0.0, aliases=('distortion' + n.upper(),),
           paths=[('camera', 'distortion', {'t1': 'p1', 't2': 'p2'}.get(n, n))])
     for n in ('k1', 'k2', 't1', 't2', 'k3')] + [
    Param('robotNamespace', str, None, aliases=('robot_namespace',),
          doc="topics' namespace (default the model's)"),
    Param('cameraName', str, '', doc='relative topics go below this name'),
    Param('frameName', str, None, doc='frame_id of the images (default the camera link)'),
    Param('imageTopicName', str, 'image_raw', doc='sensor_msgs/Image, rgb8 (imageFormat)'),
    Param('cameraInfoTopicName', str, 'camera_info', doc='sensor_msgs/CameraInfo'),
    Param('pointCloudTopicName', str, 'points', doc='sensor_msgs/PointCloud2 (while subscribed)'),
    Param('depthImageTopicName', str, None,
          doc='32FC1 depth in m (default depth/image_raw for the depth camera names, else none)'),
    Param('depthImageCameraInfoTopicName', str, 'depth/camera_info'),
]


@register('libgazebo_ros_camera.so', 'libgazebo_ros_openni_kinect.so',
          'libgazebo_ros_depth_camera.so')
class CameraPlugin(Plugin):
    """The sim camera (thesis 4.1, table 4.1): image_raw, camera_info, points, depth.

    See the module doc. ``self.camera`` is the ROS-free ``SimCamera``."""

    DEFAULT_HFOV = math.radians(60.0)
    PARAMS = CAMERA_PARAMS + [RATE_ROW]

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

    # -- parameters (declared rows, sim_world.plugins.params) -----------------------------------
    def _read_rate(self):
        """The slowest positive rate the plugin and its sensor give (2011: sensor 30,
        controller 100 -> 30 Hz); 0 = every step."""
        rates = [r for r in parse_all(self.spec, RATE_ROW, self.label, self.world.log) if r > 0]
        return min(rates) if rates else 0.0

    def load(self):
        self.link = self.spec.link or self.model.root_link
        if self.link not in self.model.links:
            raise PluginError('%s: camera link %r is not a link of the model'
                              % (self.label, self.link))
        p = self.p = self.parse(CAMERA_PARAMS)
        w, h = p.imageSize if p.imageSize is not None else (p.width, p.height)
        if p.hfov is not None:             # 2011: degrees
            hfov = math.radians(p.hfov)
        elif p.horizontal_fov is not None:
            hfov = p.horizontal_fov
        else:
            hfov = self.DEFAULT_HFOV
        near, far = p.nearClip, p.farClip
        if not near < far:
            self._error('%s: nearClip must be less than farClip, got %g and %g; using 0.02 and '
                        '100' % (self.label, near, far))
            near, far = 0.02, 100.0
        dist = [getattr(p, 'distortion_' + n) for n in ('k1', 'k2', 't1', 't2', 'k3')]
        try:
            self.camera = SimCamera(w, h, hfov, p.focal_length, p.Cx, p.Cy, dist, near, far)
        except CameraModelError as e:
            raise PluginError('%s: %s' % (self.label, e))
        self.update_rate = self._read_rate()
        self.frame_id = p.frameName or self.link
        self.encoding = IMAGE_FORMATS[p.imageFormat] if p.imageFormat else 'rgb8'
        cam_name = p.cameraName.strip('/')

        def topic(t):
            if cam_name and not t.startswith('/'):
                t = cam_name + '/' + t
            return self.resolve(t)
        self.image_topic = topic(p.imageTopicName)
        self.info_topic = topic(p.cameraInfoTopicName)
        self.points_topic = topic(p.pointCloudTopicName)
        # depth cameras (openni_kinect / depth_camera names, or any camera that names a
        # depthImageTopicName): 32FC1 depth in metres along the optical axis + its info
        d = p.depthImageTopicName or ('depth/image_raw' if self._is_depth_camera() else None)
        self.depth_topic = topic(d) if d else None
        self.depth_info_topic = topic(p.depthImageCameraInfoTopicName) if d else None
        lo, hi = p.pointCloudCutoff, p.pointCloudCutoffMax
        if hi and hi <= lo:
            self._error('%s: pointCloudCutoffMax must be more than pointCloudCutoff, got %g and '
                        '%g; no maximum' % (self.label, hi, lo))
            hi = 0.0
        self.cutoff = (lo, hi or float('inf'))
        base = self.image_topic.rsplit('/', 1)[0]
        self.hfov_topic = base + '/set_hfov'
        self.rate_topic = base + '/set_update_rate'
        if self.world.ros_enabled:
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
        for pub in self._pubs.values():     # no GIL yield per frame (sim_world.fastpub)
            fastpub.no_yield(pub)
        self._subs = [rospy.Subscriber(self.hfov_topic, Float64, self._on_hfov, queue_size=10),
                      rospy.Subscriber(self.rate_topic, Float64, self._on_rate, queue_size=10)]
        rospy.loginfo('camera %s: %dx%d, hfov %.1f deg (f = %.2f px), %s Hz sim time, '
                      'image %s, info %s, points %s', self.label, self.camera.intr.width,
                      self.camera.intr.height, math.degrees(self.camera.hfov),
                      self.camera.intr.fx, self.update_rate or 'every step',
                      self.image_topic, self.info_topic, self.points_topic)

    def _error(self, text):
        self.world.log.error('%s', text)

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
    def will_draw(self):
        """A subscriber needs frames (``wanted``), or a plugin of this same world subscribes
        to the image (the phone's display showing its camera) and its connection, which
        rospy makes asynchronously, is not in yet: the renderer is made before the first
        step all the same, not inside the first slice of a scenario's timeline."""
        if self.wanted()[0]:
            return True
        if not self._pubs:
            return False
        from sim_world.fastpub import subscribed_here
        return any(subscribed_here(t) for t in (self.image_topic, self.points_topic,
                                                self.depth_topic) if t)

    def _subscribed(self, *keys):
        return any(k in self._pubs and self._pubs[k].get_num_connections() > 0 for k in keys)

    def wanted(self):
        """(a frame wanted, depth wanted): does a subscriber need a rendered frame: the image,
        the points or (depth cameras) the depth image. camera_info alone is no reason to
        render (:meth:`info_wanted`): it does not depend on the pixels."""
        if not self._pubs:
            return True, self.force_render
        depth = self._subscribed('points', 'depth')
        return self._subscribed('image') or depth or self.force_render, depth

    def info_wanted(self):
        """(camera_info wanted, depth camera_info wanted) by subscribers (without ROS: the
        camera_info, kept in ``last_info``)."""
        if not self._pubs:
            return True, False
        return self._subscribed('info'), self._subscribed('depth_info')

    def update(self, sim_time):
        self._apply_pending(sim_time)
        want, want_depth = self.wanted()
        if not want:
            # only the camera_info (a recording of every non-image topic, an image_proc
            # waiting for its image): at the camera's rate, without a frame drawn, so a
            # lockstep slice has no frame in flight to wait for
            self._publish_info()
            return
        pose = self.world.link_pose(self.model.name, self.link)
        stamp = self.world.ros_now() if self._pubs else None
        renderer = self.world.renderer
        if self.world.parallel_render:
            # rendered and published by the renderer's worker thread while the world steps
            # on; the frame shows the scene of this tick, stamped with this tick's time
            self.camera.submit(renderer, pose,
                               lambda rgb, depth: self._deliver(rgb, depth, stamp, want_depth),
                               depth=want_depth)
            return
        rgb, depth = self.camera.render(renderer, pose, depth=want_depth)
        self._deliver(rgb, depth, stamp, want_depth)

    def _publish_info(self):
        """A tick without a frame: the camera_info (and the depth camera's) alone."""
        info, depth_info = self.info_wanted()
        if not (info or depth_info):
            return
        stamp = self.world.ros_now() if self._pubs else None
        msg = self.last_info = self.camera.camera_info(stamp, self.frame_id)
        if info and self._pubs:
            self._pubs['info'].publish(msg)
        if depth_info:
            self._pubs['depth_info'].publish(msg)

    def _deliver(self, rgb, depth, stamp, want_depth):
        """The messages of one rendered frame, published."""
        img = self.camera.image_msg(rgb, stamp, self.frame_id, self.encoding)
        info = self.camera.camera_info(stamp, self.frame_id)
        cloud = depth_img = None
        pubs = self._pubs
        if want_depth:
            if not pubs or pubs['points'].get_num_connections() > 0:
                cloud = self.camera.cloud_msg(rgb, depth, stamp, self.frame_id, self.cutoff)
            if self._subscribed('depth'):
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
            if depth_img is not None or self._subscribed('depth_info'):
                pubs['depth_info'].publish(info)

    def shutdown(self):
        self.world.flush()
        for s in self._subs:
            s.unregister()
        for p in self._pubs.values():
            p.unregister()
        self._subs, self._pubs = [], {}
