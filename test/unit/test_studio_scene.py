"""What the studio reads from model descriptions (sim_studio.scene), without ROS: the touch
display's size is the one the running touch plugin uses (the same rows and code), for the
phone as it is and with size parameters; a model without a touch screen has none."""
import subprocess

import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World
from simsensors.touch import TouchScreen

from sim_studio import scene

import worlds


def phone_text(extra=''):
    text = subprocess.check_output(['xacro', worlds.PHONE]).decode()
    if extra:
        text = text.replace('<bodyName>mobile_display</bodyName>',
                            '<bodyName>mobile_display</bodyName>' + extra, 1)
    return text


def running_size(text):
    """(width, height) of the touch plugin of the phone loaded in a World."""
    w = World(physics='ode', seed=1)
    try:
        m = parse_urdf(text, name='mobile_device')
        w.add_model(m, pose=Pose((0, 0, 1)))
        return worlds.plugin_of(w, TouchScreen, 'mobile_device').size
    finally:
        w.shutdown()


@pytest.mark.parametrize('extra', ['', '<textureWidth>480</textureWidth>'
                                       '<textureHeight>800</textureHeight>'])
def test_the_display_size_is_the_touch_plugins(extra):
    text = phone_text(extra)
    d = scene.describe_urdf(text, 'mobile_device')['display']
    assert d['link'] == 'mobile_display'
    assert d['image_topic'] == '/mobile_device/image_raw'
    assert (d['width'], d['height']) == tuple(running_size(text))
    if extra:
        assert (d['width'], d['height']) == (480, 800)


def test_the_touch_plugins_own_size_parameters_win():
    text = phone_text().replace('<topicName>touch</topicName>',
                                '<topicName>touch</topicName>'
                                '<displayWidth>1080</displayWidth>'
                                '<displayHeight>1920</displayHeight>', 1)
    assert '<displayWidth>1080' in text
    d = scene.describe_urdf(text, 'mobile_device')['display']
    assert (d['width'], d['height']) == (1080, 1920) == tuple(running_size(text))


def test_a_model_without_a_touch_screen_has_no_display():
    m = worlds.one_link(box=(0.1, 0.1, 0.1), visual=True)
    assert 'display' not in scene.describe_model(m)
    assert scene.display_of(m) is None


def test_flatten_names_the_fields_of_a_message():
    import genpy
    from sensor_msgs.msg import BatteryState, Imu, NavSatFix
    from sim_studio.device import DeviceWatch, flatten
    m = Imu()
    m.header.stamp = genpy.Time(12, 500000000)
    m.linear_acceleration.z = 9.81
    m.angular_velocity.y = -0.25
    stamp, fields = flatten(m)
    d = dict(fields)
    assert stamp == 12.5
    assert d['linear_acceleration.z'] == 9.81 and d['angular_velocity.y'] == -0.25
    assert not [k for k in d if 'covariance' in k or 'header' in k]
    fix = NavSatFix(latitude=float('nan'), longitude=11.5)
    d = dict(flatten(fix)[1])
    assert d['latitude'] == 'nan' and d['longitude'] == 11.5 and 'status.status' in d
    b = BatteryState(percentage=0.5, present=True, cell_voltage=[3.7] * 10)
    d = dict(flatten(b)[1])
    assert d['present'] == 1.0 and d['cell_voltage[3]'] == 3.7 and 'cell_voltage[4]' not in d
    assert len(flatten(b, limit=3)[1]) == 3
    w = DeviceWatch(None, ['mobile_device'])
    assert w.wanted([('/mobile_device/magnetic', 'sensor_msgs/MagneticField'),
                     ('/mobile_device/image_raw', 'sensor_msgs/Image'),
                     ('/flycam/imu', 'sensor_msgs/Imu')]) == [
        ('/mobile_device/magnetic', 'sensor_msgs/MagneticField')]


def test_meshes_and_textured_shapes_are_served_as_the_renderers_triangles(tmp_path):
    import json
    import struct
    import numpy as np
    import sys
    sys.path.insert(0, worlds.ROOT + '/test')
    from fixtures.studio import pyramid_stl, studio_world
    path = studio_world(tmp_path)
    assets = scene.Assets()
    models = {m['name']: m for m in scene.describe_world_file(path, assets)}
    g = models['studio_pyramid']['links'][0]['visuals'][0]['geometry']
    assert g['kind'] == 'shape' and g['source'] == 'mesh'
    assert np.allclose(g['size'], [0.4, 0.4, 0.5]) and np.allclose(g['center'], [0, 0, 0.25])
    data = assets.shape_bytes(int(g['url'].rsplit('/', 1)[1]))
    n = struct.unpack('<I', data[:4])[0]
    head = json.loads(data[4:4 + n])
    pos = np.frombuffer(data[4 + n:4 + n + 12 * head['count']], '<f4').reshape(-1, 3)
    assert head['count'] == 18 and len(data) == 4 + n + 32 * head['count']
    assert np.isclose(pos[:, 2].max(), 0.5) and np.isclose(pos[:, 0].min(), -0.2)
    assert head['parts'] == [{'first': 0, 'count': 18, 'rgba': [0.9, 0.1, 0.1, 1.0],
                              'texture': None}]
    # the office's QR paper: a box with a texture, served with the renderer's uvs
    paper = [v['geometry'] for m in models.values() for ln in m['links']
             for v in ln['visuals'] if v['geometry'].get('source') == 'box']
    assert len(paper) == 1
    data = assets.shape_bytes(int(paper[0]['url'].rsplit('/', 1)[1]))
    head = json.loads(data[4:4 + struct.unpack('<I', data[:4])[0]])
    url = head['parts'][0]['texture']
    assert url.startswith('/texture/')
    png = assets.texture_png(int(url.rsplit('/', 1)[1]))
    assert png[:8] == b'\x89PNG\r\n\x1a\n'
    with pytest.raises(IndexError):
        assets.shape_bytes(99)
    # a mesh file that is not there: one line, a small box, the rest is described
    bad = tmp_path / 'bad.world'
    bad.write_text(open(path).read().replace(str(tmp_path / 'pyramid.stl'), '/no/such.stl'))
    m = {m['name']: m for m in scene.describe_world_file(str(bad), scene.Assets())}
    g = m['studio_pyramid']['links'][0]['visuals'][0]['geometry']
    assert g['kind'] == 'box' and 'no/such.stl' in g['error']
    assert pyramid_stl
