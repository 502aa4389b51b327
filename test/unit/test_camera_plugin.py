"""The sim camera plugin (libgazebo_ros_camera.so) without a roscore: parameters of both URDF
syntaxes (thesis table 4.1 / Gazebo classic), rate capping, topic names, bad parameters,
frames rendered through a world stand-in, set_hfov / set_update_rate."""
import logging
import math
import threading
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from sim_world import plugins
from sim_world.model import Geometry, Link, Material, Model, PluginSpec, Visual, Joint
from simvid.camera import CameraPlugin
from sim_world.render import Renderer
from sim_world.transforms import Pose

THESIS = '''<camera name="camera_sensor">
  <imageSize>480 800</imageSize>
  <updateRate>30.0</updateRate>
  <gazebo_ros_camera name="controller-name" plugin="libgazebo_ros_camera.so">
    <alwaysOn>true</alwaysOn>
    <updateRate>100.0</updateRate>
    <imageTopicName>/mobile_device/image_raw</imageTopicName>
    <cameraInfoTopicName>/mobile_device/camera_info</cameraInfoTopicName>
    <frameName>mobile_camera_unit</frameName>
  </gazebo_ros_camera>
</camera>'''

CLASSIC = '''<sensor type="camera" name="cam1">
  <update_rate>15</update_rate>
  <camera>
    <horizontal_fov>1.2</horizontal_fov>
    <image><width>64</width><height>48</height><format>R8G8B8</format></image>
    <clip><near>0.05</near><far>50</far></clip>
  </camera>
  <plugin name="camera_controller" filename="libgazebo_ros_camera.so">
    <alwaysOn>true</alwaysOn>
    <updateRate>0.0</updateRate>
    <cameraName>rrbot/camera1</cameraName>
    <imageTopicName>image_raw</imageTopicName>
    <cameraInfoTopicName>camera_info</cameraInfoTopicName>
    <frameName>camera_link_optical</frameName>
    <distortionK1>-0.1</distortionK1>
    <distortionT2>0.001</distortionT2>
  </plugin>
</sensor>'''


class World(object):
    """What a camera uses of sim_world.world.World (sim_world.plugins.WORLD_SEAM), without
    ROS."""
    ros_enabled = False
    parallel_render = False
    log = logging.getLogger('test.camera')

    def __init__(self, models):
        self.lock = threading.RLock()
        self.models = {m.name: m for m in models}
        self.renderer = Renderer()
        for m in models:
            self.renderer.add_model(m)
        self.sim_time = 0.0

    def link_pose(self, model_name, link_name):
        m = self.models[model_name]
        return m.pose * m.link_poses()[link_name]

    def pass_state(self, entity):
        model, link = entity.split('::')
        return self.link_pose(model, link), np.zeros(3), np.zeros(3)

    def rng(self, *keys):
        from sim_world.plugins.sensor import stable_seed
        return np.random.default_rng(stable_seed(1, *keys))

    def ros_now(self):
        return None

    def reschedule(self):
        pass

    def flush(self):
        pass


def _phone(pose=None):
    """The thesis phone in short: a body and a camera link pitched -90 deg (looks down)."""
    body = Link('mobile_device_body', visuals=[Visual(Geometry('box', size=(0.124, 0.063, 0.011)))])
    cam = Link('mobile_camera_unit')
    j = Joint('cam_joint', 'fixed', 'mobile_device_body', 'mobile_camera_unit',
              origin=Pose.from_xyz_rpy((0.04, 0, -0.006), (0, math.pi / 2, 0)))
    return Model('mobile_device', links={body.name: body, cam.name: cam}, joints=[j],
                 pose=pose or Pose((0, 0, 0.5)), robot_namespace='mobile_device')


def _target():
    """A red square on the floor under the phone (seen by its camera)."""
    return Model('target', links={'t': Link('t', visuals=[
        Visual(Geometry('box', size=(0.1, 0.1, 0.01)), material=Material((1, 0, 0, 1), lit=False))])},
        pose=Pose((0.04, 0, 0)))


def _spec(xml, link='mobile_camera_unit'):
    sensor = ET.fromstring(xml)
    plugin = next(c for c in sensor if c.tag in ('plugin', 'gazebo_ros_camera'))
    filename = plugin.get('filename') or plugin.get('plugin')
    return PluginSpec(filename, plugin.get('name'), plugin, sensor, 'camera', link)


def _load(xml, model=None, world=None, link='mobile_camera_unit'):
    model = model or _phone()
    world = world or World([model, _target()])
    p = CameraPlugin(_spec(xml, link), model, world)
    p.load()
    return p, world


def test_registered_under_the_gazebo_names():
    for name in ('libgazebo_ros_camera.so', 'libgazebo_ros_openni_kinect.so',
                 'libgazebo_ros_depth_camera.so'):
        assert plugins.lookup(name) is CameraPlugin


def test_thesis_parameters():
    p, _ = _load(THESIS)
    i = p.camera.intr
    assert (i.width, i.height) == (480, 800)
    assert p.camera.hfov == pytest.approx(math.radians(60))         # default 60 deg
    assert i.fx == pytest.approx(240 / math.tan(math.radians(30)))
    assert p.update_rate == 30.0                  # sensor 30 Hz, controller's 100 caps nothing
    assert p.image_topic == '/mobile_device/image_raw'
    assert p.info_topic == '/mobile_device/camera_info'
    assert p.points_topic == '/mobile_device/points'                 # in robotNamespace
    assert p.hfov_topic == '/mobile_device/set_hfov'
    assert p.rate_topic == '/mobile_device/set_update_rate'
    assert p.frame_id == 'mobile_camera_unit'


def test_classic_parameters_and_camera_name():
    p, _ = _load(CLASSIC)
    i = p.camera.intr
    assert (i.width, i.height) == (64, 48)
    assert p.camera.hfov == pytest.approx(1.2)
    assert (p.camera.near, p.camera.far) == (0.05, 50.0)
    assert p.update_rate == 15.0
    assert list(i.D) == [-0.1, 0.0, 0.0, 0.001, 0.0]
    assert p.image_topic == '/mobile_device/rrbot/camera1/image_raw'
    assert p.hfov_topic == '/mobile_device/rrbot/camera1/set_hfov'
    assert p.frame_id == 'camera_link_optical'


def _variant(**params):
    root = ET.fromstring(THESIS)
    ctl = root.find('gazebo_ros_camera')
    for k, v in params.items():
        target = root if k in ('imageSize', 'hfov', 'updateRate_sensor') else ctl
        k = 'updateRate' if k == 'updateRate_sensor' else k
        el = target.find(k)
        if el is None:
            el = ET.SubElement(target, k)
        el.text = v
    return ET.tostring(root, encoding='unicode')


def test_table_4_1_parameters():
    p, _ = _load(_variant(hfov='45', Cx='200', Cy='410', focal_length='0',
                          distortion_k1='-0.2', distortion_k2='0.05', distortion_k3='0.01',
                          distortion_t1='0.001', distortion_t2='0.002', robotNamespace='phone',
                          imageTopicName='cam/image_raw', cameraInfoTopicName='cam/camera_info',
                          pointCloudTopicName='cam/points', updateRate='10'))
    i = p.camera.intr
    assert p.camera.hfov == pytest.approx(math.radians(45))       # 2011 <hfov> is degrees
    assert (i.cx, i.cy) == (200.0, 410.0)
    assert list(i.D) == [-0.2, 0.05, 0.001, 0.002, 0.01]
    assert p.update_rate == 10.0                                   # controller caps 30 to 10
    assert (p.image_topic, p.info_topic, p.points_topic) == (
        '/phone/cam/image_raw', '/phone/cam/camera_info', '/phone/cam/points')
    assert p.hfov_topic == '/phone/cam/set_hfov'
    q, _ = _load(_variant(focal_length='300'))
    assert q.camera.intr.fx == 300.0 and q.camera.hfov == pytest.approx(2 * math.atan(240 / 300.0))


@pytest.mark.parametrize('params,words', [
    (dict(imageSize='abc'), "imageSize must be \"width height\" in whole pixels, 1..8192, got 'abc'"),
    (dict(imageSize='480'), "imageSize must be"),
    (dict(imageSize='-480 800'), "imageSize must be"),
    (dict(hfov='-30'), "hfov must be a number in (0, 180) degrees, got '-30'"),
    (dict(hfov='200'), "hfov must be a number in (0, 180) degrees, got '200'"),
    (dict(hfov='wide'), "hfov must be a number in (0, 180) degrees, got 'wide'"),
    (dict(updateRate='-5'), "updateRate must be a number >= 0, got '-5'"),
    (dict(focal_length='-1'), "focal_length must be a number >= 0, got '-1'"),
    (dict(Cx='left'), "Cx must be a number, got 'left'"),
    (dict(distortion_k1='x'), "distortion_k1 must be a number, got 'x'"),
])
def test_bad_parameters_one_line_and_the_default(params, words, caplog):
    """A bad value: one line 'plugin <file> of model <m>: <param> must be ..., got ...'; the
    camera still loads with that parameter's default."""
    with caplog.at_level(logging.ERROR):
        p, _ = _load(_variant(**params))
    lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(lines) == 1, lines
    assert lines[0].startswith('plugin libgazebo_ros_camera.so of model mobile_device: ')
    assert words in lines[0]
    good, _ = _load(_variant())
    name = list(params)[0]
    if name in ('imageSize', 'hfov', 'focal_length', 'Cx', 'distortion_k1'):
        assert (p.camera.intr.width, p.camera.intr.height) != (0, 0)
    if name == 'updateRate':
        assert p.update_rate == 30.0          # the sensor's rate stays


def test_bad_parameters_through_create_log_one_line_and_load(caplog):
    model = _phone()
    world = World([model])
    spec = _spec(_variant(imageSize='abc'))
    with caplog.at_level(logging.ERROR):
        assert plugins.create(spec, model, world) is not None
    lines = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(lines) == 1 and 'imageSize' in lines[0].getMessage()


def test_frames_show_what_the_phone_sees_and_set_hfov_zooms():
    p, world = _load(_variant(imageSize='120 200'))
    p.update(0.0)
    img, info = p.last_image, p.last_info
    assert (img.width, img.height, img.encoding, img.step) == (120, 200, 'rgb8', 360)
    assert img.header.frame_id == info.header.frame_id == 'mobile_camera_unit'
    assert list(info.K) == pytest.approx([p.camera.intr.fx, 0, 59.5, 0, p.camera.intr.fx, 99.5, 0, 0, 1])
    rgb = np.frombuffer(img.data, np.uint8).reshape(200, 120, 3)
    red = (rgb[:, :, 0] > 200) & (rgb[:, :, 1] < 60)
    # the 10 cm red square 0.494 m under the camera: side = f * 0.1 / 0.489 px
    side = p.camera.intr.fx * 0.1 / (0.5 - 0.006 - 0.005)
    assert abs(np.sqrt(red.sum()) - side) < 2.0
    ys, xs = np.nonzero(red)
    assert abs(xs.mean() - 59.5) < 1 and abs(ys.mean() - 99.5) < 1
    assert p.set_hfov(math.radians(30))
    p.update(0.1)
    fx2 = p.last_info.K[0]
    assert fx2 == pytest.approx(60 / math.tan(math.radians(15)))
    rgb2 = np.frombuffer(p.last_image.data, np.uint8).reshape(200, 120, 3)
    red2 = (rgb2[:, :, 0] > 200) & (rgb2[:, :, 1] < 60)
    assert np.sqrt(red2.sum()) == pytest.approx(np.sqrt(red.sum()) * fx2 / info.K[0], abs=2.0)


def test_bad_run_time_values_are_refused_and_logged(caplog):
    p, _ = _load(THESIS)
    fx = p.camera.intr.fx
    with caplog.at_level(logging.ERROR):
        assert not p.set_hfov(-1.0)
        assert not p.set_hfov(float('nan'))
        assert not p.set_update_rate(-3)
    assert len([r for r in caplog.records if r.levelno >= logging.ERROR]) == 3
    assert 'set_hfov' in caplog.text and 'set_update_rate' in caplog.text
    p._apply_pending(0.0)
    assert p.camera.intr.fx == fx and p.update_rate == 30.0


def test_rate_follows_sim_time_and_set_update_rate():
    p, _ = _load(_variant(imageSize='16 16'))
    assert p.update_rate == 30.0
    dt = 0.001
    fired = [k * dt for k in range(1, 2001) if p.due(k * dt)]   # 2 s of 1 ms world steps
    assert len(fired) in (60, 61)
    assert p.set_update_rate(5.0)
    p._apply_pending(2.0)
    fired = [2.0 + k * dt for k in range(1, 2001) if p.due(2.0 + k * dt)]
    assert len(fired) in (10, 11) and p.update_rate == 5.0


class _Pub(object):
    """A rospy publisher stand-in: ``n`` subscribers, what was published in ``sent``."""
    def __init__(self, n=0):
        self.n, self.sent = n, []

    def get_num_connections(self):
        return self.n

    def publish(self, msg):
        self.sent.append(msg)

    def unregister(self):
        pass


def _fake_pubs(p):
    """Each output of the camera publishes to a _Pub (as with ROS, nobody subscribed):
    {output key: _Pub}."""
    pubs = {}
    for key, o in p.outputs.items():
        o.ros = pubs[key] = _Pub()
    return pubs


def test_renders_only_while_subscribed_and_points_only_for_points_subscribers():
    p, world = _load(_variant(imageSize='32 24'))
    world.ros_now = lambda: None
    pubs = _fake_pubs(p)
    frames0 = world.renderer.frames
    p.update(0.0)
    assert p.frames == 0 and world.renderer.frames == frames0          # nobody looks
    assert pubs['camera_info'].sent == []
    pubs['image'].n = 1                                             # the image
    pubs['camera_info'].n = 1                                       # and its info
    p.update(0.1)
    assert p.frames == 1 and len(pubs['image'].sent) == 1 and len(pubs['camera_info'].sent) == 1
    assert pubs['points'].sent == [] and p.last_cloud is None
    pubs['image'].n = 0
    pubs['points'].n = 1                                            # points only
    p.update(0.2)
    assert p.frames == 2 and len(pubs['points'].sent) == 1
    cloud = pubs['points'].sent[0]
    assert (cloud.width, cloud.height) == (32, 24)
    assert pubs['image'].sent[-1].header.stamp == pubs['camera_info'].sent[-1].header.stamp


def test_a_subscriber_in_this_world_not_connected_yet_makes_the_renderer_ahead(monkeypatch):
    """The phone's display subscribes to its camera in the world's own node; rospy connects
    it a few hundred ms later, after a scenario's first step. will_draw counts it already,
    so the renderer is made in the start-up, not in the timeline's first slice; the frames
    themselves still wait for the connection (wanted)."""
    from sim_world import transport
    p, world = _load(_variant(imageSize='32 24'))
    pubs = _fake_pubs(p)
    here = set()
    monkeypatch.setattr(transport, 'subscribed_here', lambda topic: topic in here)
    assert not p.will_draw()                                  # nobody anywhere
    here.add(p.info_topic)
    assert not p.will_draw()                                  # camera_info needs no frame
    here.add(p.image_topic)
    assert p.will_draw() and p.wanted() == (False, False)     # ahead; no frame yet
    here.clear()
    here.add(p.points_topic)
    assert p.will_draw()


def test_camera_info_alone_is_published_at_every_tick_without_a_frame():
    p, world = _load(_variant(imageSize='32 24'))
    stamps = iter(range(100))
    world.ros_now = lambda: next(stamps)
    pubs = _fake_pubs(p)
    frames0 = world.renderer.frames
    pubs['camera_info'].n = 1                                              # camera_info only
    assert not p.will_draw()                                           # no renderer for it
    for k in range(3):
        p.update(0.1 * k)
    assert p.frames == 0 and world.renderer.frames == frames0          # nothing drawn
    infos = pubs['camera_info'].sent
    assert [m.header.stamp for m in infos] == [0, 1, 2]                # one per tick
    assert (infos[0].width, infos[0].height) == (32, 24) and infos[0].K[0] == p.camera.intr.fx
    assert pubs['image'].sent == [] and p.last_info is infos[-1]
    pubs['image'].n = 1                                             # now the image too
    p.update(0.3)
    assert p.frames == 1 and len(infos) == 4 and len(pubs['image'].sent) == 1
    assert infos[-1].header.stamp == pubs['image'].sent[0].header.stamp


def test_depth_camera_info_alone_draws_nothing():
    root = ET.fromstring(_variant(imageSize='40 30', depthImageTopicName='depth/image_raw'))
    root.find('gazebo_ros_camera').set('plugin', 'libgazebo_ros_openni_kinect.so')
    p, world = _load(ET.tostring(root, encoding='unicode'))
    world.ros_now = lambda: None
    pubs = _fake_pubs(p)
    frames0 = world.renderer.frames
    pubs['depth_info'].n = 1
    p.update(0.0)
    assert p.frames == 0 and world.renderer.frames == frames0
    assert len(pubs['depth_info'].sent) == 1 and pubs['camera_info'].sent == []
    pubs['image'].n = 1                      # a frame without depth: its depth info too
    p.update(0.1)
    assert p.frames == 1 and pubs['depth'].sent == [] and len(pubs['depth_info'].sent) == 2


def test_depth_camera_publishes_depth_image_and_cutoffs(caplog):
    xml = _variant(imageSize='40 30', depthImageTopicName='depth/image_raw',
                   pointCloudCutoff='0.1', pointCloudCutoffMax='0.45')
    root = ET.fromstring(xml)
    root.find('gazebo_ros_camera').set('plugin', 'libgazebo_ros_openni_kinect.so')
    p, world = _load(ET.tostring(root, encoding='unicode'))
    assert p.depth_topic == '/mobile_device/depth/image_raw'
    assert p.depth_info_topic == '/mobile_device/depth/camera_info'
    assert p.cutoff == (0.1, 0.45)
    world.ros_now = lambda: None
    pubs = _fake_pubs(p)
    pubs['depth'].n = 1
    p.update(0.0)
    d = pubs['depth'].sent[0]
    assert (d.encoding, d.width, d.height, d.step) == ('32FC1', 40, 30, 160)
    z = np.frombuffer(d.data, '<f4').reshape(30, 40)
    # the red square 0.489 m under the camera fills the centre of the image
    assert abs(z[15, 20] - 0.489) < 0.002
    assert pubs['points'].sent == []                     # nobody asked for points
    pubs['points'].n = 1
    p.update(0.1)
    pts = np.frombuffer(pubs['points'].sent[0].data, np.float32).reshape(30, 40, 4)
    assert np.isnan(pts[:, :, 2]).all()                     # everything beyond 0.45 m: cut
    # a plain camera has no depth topic unless it names one
    q, _ = _load(_variant(imageSize='8 6'))
    assert q.depth_topic is None
    with caplog.at_level(logging.ERROR):
        r, _ = _load(_variant(pointCloudCutoff='1', pointCloudCutoffMax='0.5'))
    assert 'pointCloudCutoffMax must be more than pointCloudCutoff' in caplog.text
    assert r.cutoff == (1.0, float('inf'))


@pytest.mark.parametrize('fmt,encoding,channels', [('R8G8B8', 'rgb8', 3), ('B8G8R8', 'bgr8', 3),
                                                    ('L8', 'mono8', 1)])
def test_image_format(fmt, encoding, channels, caplog):
    root = ET.fromstring(CLASSIC)
    root.find('camera').find('image').find('format').text = fmt
    p, _ = _load(ET.tostring(root, encoding='unicode'))
    assert p.encoding == encoding
    p.update(0.0)
    img = p.last_image
    assert img.encoding == encoding and img.step == 64 * channels
    from simvid.imageconv import image_to_rgb
    rgb = image_to_rgb(img)
    if channels == 3:
        assert np.array_equal(rgb, p.last_rgb)        # same picture whatever the order
    root.find('camera').find('image').find('format').text = 'BAYER_RGGB8'
    with caplog.at_level(logging.ERROR):
        q, _ = _load(ET.tostring(root, encoding='unicode'))
    assert "imageFormat must be one of" in caplog.text and 'BAYER_RGGB8' in caplog.text
    assert q.encoding == 'rgb8'


def test_rate_change_applies_at_once_on_the_world():
    """Regression (issue 9): a camera at 0.5 Hz told set_update_rate 30 at t = 0.1 s used to
    keep its 0.5 Hz schedule until t = 2 s (the new rate only took effect in the next
    update()). Now the next frame comes one new period later."""
    from sim_world.urdf import parse_urdf
    from sim_world.world import World as RealWorld
    urdf = '''<robot name="cam"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff>
        <sensor type="camera" name="c"><update_rate>0.5</update_rate>
          <camera><image><width>8</width><height>8</height></image></camera>
          <plugin name="cc" filename="libgazebo_ros_camera.so"/></sensor></gazebo></robot>'''
    w = RealWorld(seed=1)
    try:
        w.add_model(parse_urdf(urdf), pose=Pose((0, 0, 1)))
        cam = w.plugins['cam'][0]
        w.step(100)                       # t = 0.1 s: one frame at t = 0.001
        before = cam.frames
        assert before == 1
        assert cam.set_update_rate(30.0)
        w.step(100)                       # to t = 0.2 s
        # the last frame was more than one new period ago: frames at t = 0.101 (at once),
        # then every 1/30 s: 0.134, 0.167, 0.200 (the old code: none before t = 2 s)
        assert cam.frames - before == 4
        assert cam.update_rate == 30.0
    finally:
        w.shutdown()


# -- the camera on the sensor base: noise, faults, the fault service's lookup -------------------
def _noisy_urdf(noise='', rate=20, size=(32, 24), name='cam', plugin_params=''):
    """A camera on one link, looking at the office's empty wall colour (the background):
    ``noise``: the body of the sensor's <camera><noise> (Gazebo's SDF 1.4+ syntax)."""
    n = '<noise>%s</noise>' % noise if noise else ''
    return '''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff>
        <sensor type="camera" name="c"><update_rate>%g</update_rate>
          <camera><image><width>%d</width><height>%d</height></image>%s</camera>
          <plugin name="cc" filename="libgazebo_ros_camera.so">%s</plugin></sensor></gazebo>
      </robot>''' % (name, rate, size[0], size[1], n, plugin_params)


def _camera_world(urdf, seed=1, parallel=False):
    from sim_world.urdf import parse_urdf
    from sim_world.world import World as RealWorld
    w = RealWorld(seed=seed)
    w.parallel_render = parallel
    w.add_model(parse_urdf(urdf), pose=Pose((0, 0, 1)))
    return w, w.plugins['cam'][0]


def _frames(urdf, steps=200, seed=1, parallel=False, fault=None, at=0):
    """[(stamp, rgb bytes)] of each image the camera published; ``fault``: (kind, value)
    set after ``at`` steps."""
    w, cam = _camera_world(urdf, seed, parallel)
    got = []
    try:
        out = cam.outputs['image']
        orig = out.publish

        def rec(msg):
            got.append((msg.header.stamp.to_nsec(), bytes(msg.data)))
            orig(msg)
        out.publish = rec
        w.step(at)
        if fault:
            cam.set_fault(*fault)
        w.step(steps - at)
        return got, cam
    finally:
        w.shutdown()


def test_no_noise_by_default_the_image_is_the_rendered_picture_byte_for_byte():
    """No <noise> (as Gazebo's camera without it), or a zero one: the published pixels are
    the renderer's, unchanged."""
    w, cam = _camera_world(_noisy_urdf())
    try:
        w.step(1)
        clean = cam.camera.render(w.renderer, w.link_pose('cam', 'base'))[0]
        assert bytes(cam.last_image.data) == clean.tobytes() and cam.last_rgb is not None
        assert not cam.has_noise()
        with pytest.raises(ValueError) as e:
            cam.set_fault('noise', 10.0)
        assert 'no noise' in str(e.value) and 'CameraPlugin' in str(e.value)
    finally:
        w.shutdown()
    zero, _ = _frames(_noisy_urdf('<type>gaussian</type><mean>0</mean><stddev>0</stddev>'), 60)
    plain, _ = _frames(_noisy_urdf(), 60)
    assert zero == plain and len(plain) == 2           # t = 0.001, 0.05 s (20 Hz)


NOISE = '<type>gaussian</type><mean>0.0</mean><stddev>0.02</stddev>'


def test_gazebo_camera_noise_on_pixel_values_seeded():
    """<noise> gaussian, stddev 0.02 of the 0..1 pixel value: one draw per pixel added to
    each channel; the same seed gives the same frames, another seed others, and frames
    rendered in the renderer's worker thread get the noise of their tick."""
    plain, _ = _frames(_noisy_urdf(), 200)
    noisy, cam = _frames(_noisy_urdf(NOISE), 200)
    assert cam.has_noise() and len(noisy) == len(plain) == 5
    a = np.frombuffer(plain[0][1], np.uint8).reshape(24, 32, 3).astype(float)
    b = np.frombuffer(noisy[0][1], np.uint8).reshape(24, 32, 3).astype(float)
    d = (b - a) / 255.0
    assert abs(d.std() - 0.02) < 0.004 and abs(d.mean()) < 0.004
    # the same draw on every channel of a pixel (up to rounding)
    assert np.abs(d[:, :, 0] - d[:, :, 1]).max() <= 1.0 / 255 + 1e-9
    assert len(set(f for _, f in noisy)) == len(noisy)        # a new draw every frame
    assert _frames(_noisy_urdf(NOISE), 200)[0] == noisy         # same seed, same frames
    assert _frames(_noisy_urdf(NOISE), 200, seed=2)[0] != noisy
    assert _frames(_noisy_urdf(NOISE), 200, parallel=True)[0] == noisy


def test_noise_mean_shifts_and_clamps():
    got, _ = _frames(_noisy_urdf('<type>gaussian</type><mean>0.5</mean><stddev>0</stddev>'),
                     60)
    rgb = np.frombuffer(got[0][1], np.uint8)
    assert (rgb == 255).all()                      # background ~0.7 + 0.5: clamped to 1


def test_faults_through_the_base_gate():
    """drop: no image, no camera_info, no frame drawn; freeze: the last frame again with
    new stamps; noise x5: five times the sigma."""
    base, _ = _frames(_noisy_urdf(NOISE), 300)
    k = len([t for t, _ in base if t <= 100000000])      # frames up to the fault (t = 0.1 s)
    dropped, cam = _frames(_noisy_urdf(NOISE), 300, fault=('drop', 0.0), at=100)
    assert k == 3 and dropped == base[:k] and cam.frames == k
    frozen, _ = _frames(_noisy_urdf(NOISE), 300, fault=('freeze', 0.0), at=100)
    assert len(frozen) == len(base) == 7
    assert [f for _, f in frozen[k:]] == [base[k - 1][1]] * (7 - k)   # the last frame again
    assert [t for t, _ in frozen] == [t for t, _ in base]            # with new stamps
    loud, _ = _frames(_noisy_urdf(NOISE), 300, fault=('noise', 5.0), at=100)
    plain, _ = _frames(_noisy_urdf(), 300)
    a = np.frombuffer(plain[-1][1], np.uint8).astype(float)
    b = np.frombuffer(loud[-1][1], np.uint8).astype(float)
    assert abs(((b - a) / 255.0).std() - 0.1) < 0.02
    assert loud[:k] == base[:k]


def test_freeze_and_drop_silence_camera_info_too():
    w, cam = _camera_world(_noisy_urdf())
    try:
        infos = []
        out = cam.outputs['camera_info']
        orig = out.publish
        out.publish = lambda m: (infos.append(m.header.stamp.to_nsec()), orig(m))
        w.step(100)
        n = len(infos)
        cam.set_fault('drop')
        w.step(100)
        assert len(infos) == n == 3                    # t = 0.001, 0.05, 0.1 s
        cam.set_fault('freeze')
        w.step(100)
        assert len(infos) == 5 and infos[-1] > infos[-2]           # repeated, new stamps
        cam.set_fault('none')
        w.step(100)
        assert len(infos) == 7
    finally:
        w.shutdown()


@pytest.mark.parametrize('key', ['cc', 'libgazebo_ros_camera.so', 'image_raw',
                                 '/cam/camera_info', 'cam/image_raw'])
def test_the_fault_service_finds_the_camera(key):
    """/gazebo/set_sensor_fault and the scenario's fault action look the sensor up with
    world.find_plugins and set the fault with inject_fault: the camera by its plugin name,
    its library name or either of its topics."""
    from sim_world.plugins.sensor import inject_fault
    w, cam = _camera_world(_noisy_urdf(plugin_params='<robotNamespace>cam</robotNamespace>'))
    try:
        assert cam.image_topic == '/cam/image_raw'
        found = w.find_plugins('cam', key)
        assert found == [cam]
        inject_fault(found, 'freeze')
        assert cam.fault == 'freeze'
        with pytest.raises(ValueError) as e:
            inject_fault(found, 'noise', 2.0)             # no noise to scale: refused
        assert 'no noise' in str(e.value) and cam.fault == 'freeze'
    finally:
        w.shutdown()
