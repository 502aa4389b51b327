"""Issue 46: the phone's description is namespace-free and safe as a YAML scalar, and a spawn's
robot namespace follows gazebo_ros's rule (sim_world.spawn.fill_robot_namespace: every plugin
naming no <robotNamespace> of its own gets the spawn's; a plugin's own wins). No roscore: the
clash refusal and `rosparam set` itself are tested through ROS in
test/test_spawn_namespace_ros.py."""
import os
import subprocess

import pytest
import yaml

from sim_world.spawn import fill_robot_namespace, spawn_xml
from sim_world.urdf import parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
URDF = os.path.join(ROOT, 'sim_world', 'urdf')


def xacro(name, *args):
    return subprocess.run(['xacro', os.path.join(URDF, name)] + list(args), check=True,
                          capture_output=True, text=True).stdout


def plugin_namespaces(model):
    return {(s.filename, s.name): s.param('robotNamespace') for s in model.plugins}


@pytest.mark.parametrize('name', ['mobile_device.urdf.xacro', 'flycam.urdf.xacro',
                                  'mobile_device_2011.urdf.xacro'])
def test_generated_urdf_is_one_yaml_string(name):
    """`rosparam set robot_description "$(xacro FILE)"` parses the value as YAML: it must be
    one plain string (no ': ' nor ' #' anywhere, comments included), whose folded lines
    are the same robot."""
    text = xacro(name)
    value = yaml.safe_load(text)
    assert isinstance(value, str)
    bad = [ln for ln in text.splitlines() if ': ' in ln or ' #' in ln or ln.endswith(':')]
    assert bad == []
    a, b = parse_urdf(text, name='a'), parse_urdf(value, name='a')
    assert sorted(a.links) == sorted(b.links)
    assert [(s.filename, s.name) for s in a.plugins] == [(s.filename, s.name) for s in b.plugins]
    assert plugin_namespaces(a) == plugin_namespaces(b)


def test_phone_names_no_namespace_unless_ns_is_given():
    free = parse_urdf(xacro('mobile_device.urdf.xacro'), name='p')
    assert len(free.plugins) >= 20
    assert set(plugin_namespaces(free).values()) == {None}
    cam = [s for s in free.plugins if s.filename == 'libgazebo_ros_camera.so'][0]
    assert cam.param('imageTopicName') == 'image_raw'         # relative: in the namespace
    disp = [s for s in free.plugins if s.filename == 'libgazebo_ros_video.so'][0]
    assert disp.param('imageTopic') == 'image_raw'
    named = parse_urdf(xacro('mobile_device.urdf.xacro', 'ns:=phone_b'), name='p')
    assert set(plugin_namespaces(named).values()) == {'phone_b'}


def test_thesis_phone_keeps_its_absolute_names():
    """Appendix A's file names /mobile_device/... itself; a spawn namespace fills only the
    plugins without one (its camera and display topics stay absolute)."""
    m = parse_urdf(xacro('mobile_device_2011.urdf.xacro'), name='thesis')
    topics = [s.param('imageTopicName', 'imageTopic') for s in m.plugins]
    assert '/mobile_device/image_raw' in topics


ROBOT = '''<robot name="r"><link name="base"><inertial><mass value="0.1"/>
  <inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
  <gazebo><plugin name="free" filename="libgazebo_ros_imu.so"><bodyName>base</bodyName>
    <topicName>imu</topicName></plugin>
  <plugin name="own" filename="libgazebo_ros_magnetic.so"><bodyName>base</bodyName>
    <robotNamespace>/xarm</robotNamespace><topicName>magnetic</topicName></plugin>
  <plugin name="global" filename="libgazebo_ros_air_pressure.so"><bodyName>base</bodyName>
    <robotNamespace></robotNamespace><topicName>pressure</topicName></plugin></gazebo>
</robot>'''


def test_fill_rule_as_gazebo_ros():
    m = parse_urdf(ROBOT, name='r')
    assert fill_robot_namespace(m, '/phone2') == 1
    ns = {s.name: s.param('robotNamespace') for s in m.plugins}
    assert ns == {'free': '/phone2', 'own': '/xarm', 'global': '/'}
    m2 = parse_urdf(ROBOT, name='r')
    assert fill_robot_namespace(m2, '') == 0 and fill_robot_namespace(m2, '/') == 0
    assert {s.name: s.param('robotNamespace') for s in m2.plugins}['free'] is None


@pytest.fixture
def world():
    w = World(physics='ode', seed=1)
    yield w
    w.shutdown()


def topics(world, model):
    return {p.spec.name: p.topic for p in world.plugins[model]}


def test_spawn_namespace_reaches_the_plugins(world):
    ok, msg = spawn_xml(world, 'urdf', 'a', ROBOT, '/phone2')
    assert ok, msg
    assert topics(world, 'a') == {'free': '/phone2/imu', 'own': '/xarm/magnetic',
                                  'global': '/pressure'}
    ok, msg = spawn_xml(world, 'urdf', 'b', ROBOT, '')
    assert ok, msg
    assert topics(world, 'b') == {'free': '/imu', 'own': '/xarm/magnetic', 'global': '/pressure'}


def test_two_phones_from_one_description(world):
    text = xacro('mobile_device.urdf.xacro')
    for name, ns in (('mobile_device', '/mobile_device'), ('phone2', '/phone2')):
        ok, msg = spawn_xml(world, 'urdf', name, text, ns)
        assert ok, msg
    for name in ('mobile_device', 'phone2'):
        names = set()
        for p in world.plugins[name]:
            names |= p.ros_names()
            if hasattr(p, 'image_topic'):
                names.add(p.image_topic)
        assert '/%s/imu_sensor_data' % name in names
        assert '/%s/image_raw' % name in names
        assert all(n.startswith('/%s/' % name) for n in names), names
    disp = [p for p in world.plugins['phone2'] if p.spec.filename == 'libgazebo_ros_video.so']
    assert disp[0].image_topic == '/phone2/image_raw'      # its own camera's preview


def test_frames_follow_the_tf_prefix(world):
    """A phone spawned in /phone2 publishes tf frames phone2/<link> (gazebo_api.tf_frame), and
    its sensors' and camera's frame_id are those frames too (gazebo_ros's plugins resolve
    frameName with tf_prefix); without a namespace they stay plain."""
    text = xacro('mobile_device.urdf.xacro')
    for name, ns in (('plain', ''), ('phone2', '/phone2')):
        ok, msg = spawn_xml(world, 'urdf', name, text, ns)
        assert ok, msg
    frames = {n: {p.spec.name: p.frame_id for p in world.plugins[n] if hasattr(p, 'frame_id')}
              for n in ('plain', 'phone2')}
    assert frames['plain']['imu_controller'] == 'mobile_device_frame'
    assert frames['plain']['camera_controller'] == 'mobile_camera_optical_frame'
    assert frames['phone2'] == {k: 'phone2/' + v for k, v in frames['plain'].items()}
