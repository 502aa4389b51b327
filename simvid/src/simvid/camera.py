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

It is a sensor of the plugin SDK (``sim_world.plugins.sensor.Sensor``), declared like the
barometer: a Param table, an error model, a rate, outputs and pure message builders; the
base owns the update, subscriber gating, faults and publishing.

- **outputs**: ``image`` (``imageTopicName``, sensor_msgs/Image rgb8 or ``imageFormat``),
  ``camera_info`` (same stamp, every frame), ``points`` (PointCloud2, only while
  subscribed), all stamped with sim time. Renders only while someone subscribes to the
  image, the points or the depth image: a subscriber of ``camera_info`` alone gets it at
  the camera's rate without a frame drawn (Gazebo's camera publishes it only with images; a
  recording of every non-image topic would pay a render per message). Registered as
  ``libgazebo_ros_openni_kinect.so`` / ``libgazebo_ros_depth_camera.so`` it also publishes
  ``depth`` (``depthImageTopicName``, default ``depth/image_raw``: 32FC1, metres along the
  optical axis, NaN where nothing is seen) and ``depth_info``
  (``depthImageCameraInfoTopicName``); ``pointCloudCutoff``/``pointCloudCutoffMax`` limit
  the range of the points. Subscribes ``set_hfov`` (radians) and ``set_update_rate`` (Hz)
  next to the image topic.
- **rate**: the base's timer: ``updateRate`` of the plugin and of its ``<sensor>``, the
  slowest positive one (2011: sensor 30, controller 100 -> 30 Hz); 0 every step.
- **error model**: Gazebo's camera ``<noise>`` (``<sensor><camera><noise><type>gaussian
  </type><mean>0</mean><stddev>0.007</stddev></noise>``; or the error model's rows
  ``gaussianNoise``, ``offset``... on the plugin), on pixel values in 0..1: one draw per
  pixel added to each channel, clamped to 0..1 (``sim_world.plugins.error_models.
  FieldNoise``), from the world's seeded generators. Without it (the default, as Gazebo's
  camera without ``<noise>``) the image is the rendered picture, byte for byte.
- **faults** (the base's gate, ``/gazebo/set_sensor_fault`` with the plugin's name, its
  library name or one of its topics): ``drop`` publishes nothing (no frame drawn);
  ``freeze`` repeats the last frame and camera_info with new stamps; ``noise`` multiplies
  the noise's sigma (refused for a camera without noise).

Frames render in the renderer's worker thread while the world steps on
(``world.parallel_render``): ``measure`` returns a ``Pending`` that the frame resolves
there, and the base publishes its messages then, stamped with the tick's sim time. The
camera looks along the link's +x (z up in the image); points are in the optical frame (x
right, y down, z forward) of ``frameName``.
"""
import math
import threading

from sim_world.plugins import PluginError, register
from sim_world import transport
from sim_world.plugins.error_models import FieldNoise
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Pending, Sensor
from .camera_model import IMAGE_FORMATS, SimCamera, CameraModelError

__all__ = ['CameraPlugin', 'Frame']

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
                     '(2011: sensor 30, controller 100) the slowest wins (the sensor base)')

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


class Frame(object):
    """What the camera measured at one tick: ``rgb`` (HxWx3 uint8, its noise applied) or
    None (nobody wants a frame: the camera_info alone), ``depth`` (HxW float32 metres) or
    None."""
    __slots__ = ('rgb', 'depth')

    def __init__(self, rgb=None, depth=None):
        self.rgb, self.depth = rgb, depth


class _Ticket(Pending):
    """A frame on its way from the renderer, with the noise of its tick."""
    __slots__ = ('noise',)

    def __init__(self, noise):
        Pending.__init__(self)
        self.noise = noise


@register('libgazebo_ros_camera.so', 'libgazebo_ros_openni_kinect.so',
          'libgazebo_ros_depth_camera.so')
class CameraPlugin(Sensor):
    """The sim camera (thesis 4.1, table 4.1): image_raw, camera_info, points, depth.

    See the module doc. ``self.camera`` is the ROS-free ``SimCamera``."""

    DEFAULT_HFOV = math.radians(60.0)
    DEFAULT_RATE = 0.0
    DEFAULT_TOPIC = 'image_raw'
    #: images are big: a short queue (a slow subscriber loses the oldest frames)
    QUEUE_SIZE = 10
    #: Gazebo's camera <noise> (pixel values 0..1); none by default
    ERRORS = {'': dict(dims=1, sdf=(('camera', 'noise'), ('noise',)))}
    PARAMS = CAMERA_PARAMS + [RATE_ROW]

    @classmethod
    def base_rows(cls):
        # the camera's topics are its own rows (imageTopicName ...), not topicName
        return [r for r in super(CameraPlugin, cls).base_rows() if r.name != 'topicName']

    def __init__(self, spec, model, world):
        Sensor.__init__(self, spec, model, world)
        self.link = spec.link
        self._lock = threading.Lock()
        self._pending_hfov = None
        self._seed = 0
        self.frames = 0
        self.last_image = None       # last published sensor_msgs/Image (also without ROS)
        self.last_info = None
        self.last_cloud = None
        self.last_depth = None
        self.last_rgb = None
        self.force_render = False    # render (depth too) without subscribers (tests, benches)

    # -- parameters (declared rows; the base read the common ones) ---------------------------
    def setup(self):
        from sensor_msgs.msg import CameraInfo, Image, PointCloud2
        from std_msgs.msg import Float64
        p = self.p
        self.link = self.body
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
        self.frame_id = self.tf_frame(p.frameName or self.link)
        self.encoding = IMAGE_FORMATS[p.imageFormat] if p.imageFormat else 'rgb8'
        cam_name = p.cameraName.strip('/')

        def topic(t):
            if cam_name and not t.startswith('/'):
                t = cam_name + '/' + t
            return self.resolve(t)
        self.image_topic = self.topic = topic(p.imageTopicName)
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
        # the outputs, in the order a frame publishes them
        self.output('image', Image, topic=self.image_topic)
        self.output('camera_info', CameraInfo, topic=self.info_topic, noisy=False)
        self.output('points', PointCloud2, topic=self.points_topic, queue_size=2)
        if self.depth_topic:
            self.output('depth', Image, topic=self.depth_topic, queue_size=2, noisy=False)
            self.output('depth_info', CameraInfo, topic=self.depth_info_topic, queue_size=2,
                        noisy=False)
        self.subscribe(self.hfov_topic, Float64, self._on_hfov)
        self.subscribe(self.rate_topic, Float64, self._on_rate)
        if self.ros:
            import rospy
            rospy.loginfo('camera %s: %dx%d, hfov %.1f deg (f = %.2f px), %s Hz sim time, '
                          'image %s, info %s, points %s', self.label, self.camera.intr.width,
                          self.camera.intr.height, math.degrees(self.camera.hfov),
                          self.camera.intr.fx, self.update_rate or 'every step',
                          self.image_topic, self.info_topic, self.points_topic)

    def _is_depth_camera(self):
        name = self.spec.filename or ''
        return 'openni_kinect' in name or 'depth_camera' in name

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

    # -- who wants what ------------------------------------------------------------------------
    def will_draw(self):
        """A subscriber needs frames (``wanted``), or a plugin of this same world subscribes
        to the image (the phone's display showing its camera) and its connection, which
        rospy makes asynchronously, is not in yet: the renderer is made before the first
        step all the same, not inside the first slice of a scenario's timeline."""
        if self.wanted()[0]:
            return True
        if self.outputs['image'].ros is None:
            return False
        return any(transport.subscribed_here(t) for t in (self.image_topic, self.points_topic,
                                                            self.depth_topic) if t)

    def _subscribed(self, *keys):
        outs = self.outputs
        return any(k in outs and outs[k].ros is not None and
                   outs[k].ros.get_num_connections() > 0 for k in keys)

    def subscribed(self):
        return self.force_render or Sensor.subscribed(self)

    def wanted(self):
        """(a frame wanted, depth wanted): does a subscriber need a rendered frame: the image,
        the points or (depth cameras) the depth image. camera_info alone is no reason to
        render (:meth:`info_wanted`): it does not depend on the pixels. Without ROS: a
        frame, and depth with ``force_render``."""
        if self.outputs['image'].ros is None:
            return True, self.force_render
        depth = self._subscribed('points', 'depth')
        return (self._subscribed('image') or depth or self.force or self.force_render,
                depth)

    def info_wanted(self):
        """(camera_info wanted, depth camera_info wanted) by subscribers (without ROS: the
        camera_info, kept in ``last_info``)."""
        if self.outputs['image'].ros is None:
            return True, False
        return self._subscribed('camera_info'), self._subscribed('depth_info')

    # -- the measurement: a frame of the link's view --------------------------------------------
    def tick(self, sim_time, dt):
        self._apply_pending(sim_time)
        if not self.errors[''].identity:       # one seed per tick, listened to or not
            self._seed = int(self.rng.integers(1 << 62))

    def measure(self, state, dt):
        """The frame of this tick: rendered here, or in the renderer's worker thread (a
        ``Pending`` the frame resolves); a Frame without pixels when only the camera_info
        is wanted; None under a ``drop`` fault (nothing to publish, nothing drawn)."""
        if self.fault == 'drop':
            return None
        want, want_depth = self.wanted()
        if not want:
            # only the camera_info (a recording of every non-image topic, an image_proc
            # waiting for its image): at the camera's rate, without a frame drawn, so a
            # lockstep slice has no frame in flight to wait for
            return Frame()
        ticket = _Ticket(FieldNoise(self.errors[''], self._seed))
        renderer = self.world.renderer
        if self.world.parallel_render:
            # rendered by the renderer's worker thread while the world steps on; the frame
            # shows the scene of this tick, published with this tick's stamp
            self.camera.submit(renderer, state.body_pose,
                               lambda rgb, depth: self._deliver(rgb, depth, ticket,
                                                                want_depth),
                               depth=want_depth)
            return ticket
        rgb, depth = self.camera.render(renderer, state.body_pose, depth=want_depth)
        self._deliver(rgb, depth, ticket, want_depth)
        return ticket

    def _deliver(self, rgb, depth, ticket, want_depth):
        """A rendered frame (in whichever thread rendered it): its tick's noise, then the
        base publishes it."""
        rgb = ticket.noise.apply_uint8(rgb)
        self.frames += 1
        self.last_rgb = rgb
        ticket.resolve(Frame(rgb, depth if want_depth else None))

    def messages(self, frame, stamp):
        """The messages of one tick, built when they pass the gate: image, camera_info,
        points, depth, depth camera_info (those of a frame without pixels: the infos)."""
        cam, fid = self.camera, self.frame_id
        info = []

        def camera_info():
            if not info:
                info.append(cam.camera_info(stamp, fid))
                self.last_info = info[0]
            return info[0]
        if frame.rgb is None:
            want_info, want_depth_info = self.info_wanted()
            out = [('camera_info', camera_info)] if want_info else []
            if want_depth_info and self.depth_topic:
                out.append(('depth_info', camera_info))
            return out
        out = [('image', lambda: self._image(frame, stamp)), ('camera_info', camera_info)]
        if frame.depth is not None:
            out.append(('points', lambda: self._cloud(frame, stamp)))
            if self.depth_topic:
                out.append(('depth', lambda: self._depth(frame, stamp)))
        if self.depth_topic and (frame.depth is not None or self._subscribed('depth_info')):
            out.append(('depth_info', camera_info))
        return out

    def _image(self, frame, stamp):
        m = self.last_image = self.camera.image_msg(frame.rgb, stamp, self.frame_id,
                                                    self.encoding)
        return m

    def _cloud(self, frame, stamp):
        m = self.last_cloud = self.camera.cloud_msg(frame.rgb, frame.depth, stamp,
                                                    self.frame_id, self.cutoff)
        return m

    def _depth(self, frame, stamp):
        m = self.last_depth = self.camera.depth_msg(frame.depth, stamp, self.frame_id)
        return m

    def shutdown(self):
        self.world.flush()
        Sensor.shutdown(self)
