"""URDF/xacro and SDF loading: both Gazebo syntaxes, the thesis phone, clear errors."""
import os

import numpy as np
import pytest

from sim_world.model import ModelError, cuboid_inertia
from sim_world.sdf import load_world_file, parse_sdf_model, parse_world
from sim_world.urdf import load_urdf_file, parse_urdf

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
URDF = os.path.join(ROOT, 'sim_world', 'urdf')


def test_thesis_cuboid_inertia_numbers():
    # thesis equation 3.2 / appendix A, in its axis convention (long edge treated as y)
    ixx, iyy, izz = cuboid_inertia(0.129, 0.063, 0.1239, 0.01088)
    assert ixx == pytest.approx(0.000166, abs=5e-7)
    assert iyy == pytest.approx(0.000044, abs=5e-7)
    assert izz == pytest.approx(0.000208, abs=5e-7)


def test_appendix_a_xacro_loads_unchanged():
    m = load_urdf_file(os.path.join(URDF, 'mobile_device_2011.urdf.xacro'), name='mobile_device')
    assert m.name == 'mobile_device'
    assert list(m.links) == ['mobile_base_link', 'mobile_display', 'mobile_camera',
                             'mobile_camera_unit']
    assert m.root_link == 'mobile_base_link'
    base = m.links['mobile_base_link']
    assert base.inertial.mass == pytest.approx(0.129)
    # the xacro expressions of appendix A, evaluated
    assert base.inertial.inertia[0, 0] == pytest.approx(0.000166298, rel=1e-5)
    assert base.inertial.inertia[1, 1] == pytest.approx(0.0000439393, rel=1e-5)
    assert base.inertial.inertia[2, 2] == pytest.approx(0.000207692, rel=1e-5)
    assert all(not l.gravity for l in m.links.values())           # <turnGravityOff>
    assert base.visuals[0].material.name == 'Gazebo/Black'
    assert list(base.visuals[0].geometry.size) == pytest.approx([0.1239, 0.063, 0.01088])
    cams = [p for p in m.plugins if p.filename == 'libgazebo_ros_camera.so']
    vids = [p for p in m.plugins if p.filename == 'libgazebo_ros_video.so']
    assert len(cams) == 1 and len(vids) == 1
    cam = cams[0]
    assert cam.link == 'mobile_camera_unit' and cam.sensor_type == 'camera'
    assert cam.param('imageSize') == '480 800'
    assert cam.param('imageTopicName') == '/mobile_device/image_raw'
    assert cam.sensor.find('updateRate') is not None or any(
        c.tag.endswith('updateRate') for c in cam.sensor)
    assert vids[0].param('bodyName') == 'mobile_display' and vids[0].link is None
    poses = m.link_poses()
    cu = poses['mobile_camera_unit']
    assert cu.p == pytest.approx([0.032, 0.01, -0.01088 / 2 - 0.0005 / 2])
    # pitched by (about) pi/2: the camera's +x looks along the phone's -z
    assert cu.rotate([1, 0, 0]) == pytest.approx([0, 0, -1], abs=1e-3)


def test_classic_syntax_phone_loads():
    m = load_urdf_file(os.path.join(URDF, 'mobile_device.urdf.xacro'))
    assert m.name == 'mobile_device'
    cam = [p for p in m.plugins if p.filename == 'libgazebo_ros_camera.so'][0]
    assert cam.sensor_type == 'camera' and cam.link == 'mobile_camera_unit'
    assert cam.sensor.find('camera/image/width').text == '480'
    assert cam.param('frameName') == 'mobile_camera_optical_frame'
    vid = [p for p in m.plugins if p.filename == 'libgazebo_ros_video.so'][0]
    assert vid.param('bodyName') == 'mobile_display'
    # the classic model takes the inertia about the box's own axes
    ixx, iyy, izz = cuboid_inertia(0.129, 0.1239, 0.063, 0.01088)
    assert np.diag(m.links['mobile_base_link'].inertial.inertia) == pytest.approx([ixx, iyy, izz])
    assert not m.links['mobile_base_link'].gravity
    assert m.link_poses()['mobile_camera_unit'].rotate([1, 0, 0]) == pytest.approx([0, 0, -1],
                                                                                   abs=1e-6)


def test_both_phones_have_same_frames():
    a = load_urdf_file(os.path.join(URDF, 'mobile_device_2011.urdf.xacro')).link_poses()
    b = load_urdf_file(os.path.join(URDF, 'mobile_device.urdf.xacro')).link_poses()
    # the 2011 phone's frames all exist, at the same places (the new phone adds frames:
    # mobile_device_frame, LEDs, buttons ...)
    assert set(a) <= set(b)
    assert 'mobile_device_frame' in b
    for k in a:
        assert a[k].p == pytest.approx(b[k].p, abs=1e-6)


MINIMAL = '''<robot name="r"><link name="a"><visual><geometry><box size="1 1 1"/></geometry>
</visual></link>%s</robot>'''


@pytest.mark.parametrize('xml, words', [
    ('<robot name="r"><link name="a"></robot>', 'malformed URDF'),
    ('<sdf/>', 'expected <robot>'),
    (MINIMAL % '<joint name="j" type="fixed"><parent link="a"/><child link="nope"/></joint>',
     'unknown child link'),
    (MINIMAL % '<joint name="j" type="hinge"><parent link="a"/><child link="a"/></joint>',
     'unknown type'),
    ('<robot name="r"><link name="a"><visual><geometry><box size="1 x 1"/></geometry></visual>'
     '</link></robot>', 'box size'),
    ('<robot name="r"><link name="a"><visual><geometry><box size="1 -1 1"/></geometry></visual>'
     '</link></robot>', 'positive'),
    (MINIMAL % '<gazebo reference="nope"><material>Gazebo/Red</material></gazebo>',
     'names no link'),
    ('<robot name="r"><link name="a"><inertial><mass value="0"/></inertial></link></robot>',
     'mass must be positive'),
    ('<robot name="r"><link name="a"><inertial><mass value="nan"/></inertial></link></robot>',
     'non-finite'),
    (MINIMAL % '<gazebo><plugin name="p"/></gazebo>', 'names no library'),
    ('', 'empty model'),
])
def test_bad_urdf_is_a_clear_model_error(xml, words):
    with pytest.raises(ModelError) as e:
        parse_urdf(xml)
    assert words in str(e.value)


def test_unexpanded_xacro_is_refused():
    xml = ('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
           '<xacro:property name="a" value="1"/><link name="l"/></robot>')
    with pytest.raises(ModelError, match='xacro'):
        parse_urdf(xml)


def test_missing_model_file(tmp_path):
    with pytest.raises(ModelError, match='does not exist'):
        load_urdf_file(str(tmp_path / 'nope.urdf.xacro'))


def test_broken_xacro_file(tmp_path):
    p = tmp_path / 'bad.urdf.xacro'
    p.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                 '<link name="${undefined_thing}"/></robot>')
    with pytest.raises(ModelError, match='xacro could not expand'):
        load_urdf_file(str(p))


def test_office_world():
    w = load_world_file(os.path.join(ROOT, 'sim_world', 'worlds', 'office.world'))
    names = [m.name for m in w.models]
    for n in ('ground_plane', 'desk', 'chair', 'paper'):
        assert n in names
    # everything is static but the east door on its hinge (issue 48)
    assert [m.name for m in w.models if not m.static] == ['east_door']
    paper = [m for m in w.models if m.name == 'paper'][0]
    tex = paper.links['sheet'].visuals[0].material.texture
    assert os.path.isabs(tex) and os.path.isfile(tex), tex
    desk = [m for m in w.models if m.name == 'desk'][0]
    top = desk.pose * desk.link_poses()['top']
    assert top.p[2] + 0.015 == pytest.approx(0.75)
    assert paper.pose.p[2] == pytest.approx(0.75 + 0.00025)
    assert w.max_step_size == pytest.approx(0.001)
    assert len(w.lights) == 2


def test_sdf_link_poses_become_joints():
    m = parse_sdf_model('''<model name="m"><static>true</static><pose>1 2 3 0 0 0</pose>
      <link name="a"><pose>0 0 1 0 0 0</pose></link>
      <link name="b"><pose>0 1 1 0 0 1.5707963</pose></link></model>''')
    assert m.pose.p == pytest.approx([1, 2, 4])
    assert m.link_poses()['b'].p == pytest.approx([0, 1, 0])


@pytest.mark.parametrize('text, words', [
    ('<sdf><world name="w"><model name="m"><link name="a"><pose>1 2</pose></link></model>'
     '</world></sdf>', '<pose>'),
    ('<sdf><world name="w"><model name="m"></model></world></sdf>', 'has no <link>'),
    ('<sdf><world name="w"><include><uri>model://house</uri></include></world></sdf>',
     'model://house'),
    ('<sdf><world', 'malformed world'),
    ('<sdf><world name="w"><model name="m"><link name="a"/></model><model name="m">'
     '<link name="a"/></model></world></sdf>', 'several models named'),
])
def test_bad_world_is_a_clear_error(text, words):
    with pytest.raises(ModelError) as e:
        parse_world(text)
    assert words in str(e.value)


def test_missing_world_file(tmp_path):
    with pytest.raises(ModelError, match='does not exist'):
        load_world_file(str(tmp_path / 'none.world'))


def test_package_and_model_uris_are_found_on_gazebo_model_path(tmp_path, monkeypatch):
    """model://NAME/... and package://NAME/... (no ROS package of that name) are looked up in
    GAZEBO_MODEL_PATH's folders, in order; found nowhere, the old answer (the model file's
    folder), which the loader then reports as missing."""
    from sim_world.model import Model
    (tmp_path / 'a' / 'box' / 'meshes').mkdir(parents=True)
    (tmp_path / 'a' / 'box' / 'meshes' / 'b.dae').write_text('<COLLADA/>')
    (tmp_path / 'b' / 'box' / 'meshes').mkdir(parents=True)
    (tmp_path / 'b' / 'box' / 'meshes' / 'b.dae').write_text('<COLLADA/>')
    (tmp_path / 'b' / 'mypkg_nowhere_else' / 'm').mkdir(parents=True)
    (tmp_path / 'b' / 'mypkg_nowhere_else' / 'm' / 'x.stl').write_text('solid x\nendsolid x\n')
    m = Model('r', base_dir=str(tmp_path / 'urdf'))
    monkeypatch.delenv('GAZEBO_MODEL_PATH', raising=False)
    assert m.resolve_path('model://box/meshes/b.dae') == \
        str(tmp_path / 'urdf' / 'box' / 'meshes' / 'b.dae')
    monkeypatch.setenv('GAZEBO_MODEL_PATH', os.pathsep.join(
        [str(tmp_path / 'nothing'), str(tmp_path / 'a'), str(tmp_path / 'b')]))
    assert m.resolve_path('model://box/meshes/b.dae') == \
        str(tmp_path / 'a' / 'box' / 'meshes' / 'b.dae')
    assert m.resolve_path('package://mypkg_nowhere_else/m/x.stl') == \
        str(tmp_path / 'b' / 'mypkg_nowhere_else' / 'm' / 'x.stl')
    assert m.resolve_path('package://nopkg_at_all/m/x.stl') == \
        str(tmp_path / 'urdf' / 'm' / 'x.stl')
