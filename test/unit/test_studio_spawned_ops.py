"""Models spawned after the studio started (sim_studio.spawned), without a roscore: the
description the world's /gazebo/get_model_description answers read with the world's own
loaders (scene.description_model, describe_model), the icons of its NFC tag and access point,
and the watch over /gazebo/model_states adding, refusing and dropping models (a stand-in
world answers the service)."""
import asyncio
import json
from types import SimpleNamespace

import pytest

from sim_studio import scene, spawned
from sim_studio.server import Studio
from sim_studio.world import WorldError

CRATE = '''<sdf version="1.6"><model name="anything"><pose>0 0 0.1 0 0 0</pose>
  <link name="body"><inertial><mass>1</mass></inertial>
    <visual name="v"><geometry><box><size>0.2 0.3 0.4</size></box></geometry>
      <material><diffuse>0.1 0.9 0.2 1</diffuse></material></visual></link>
  <plugin name="tag" filename="libgazebo_ros_nfc_tag.so"><data>T:hello</data>
    <range>0.04</range></plugin>
  <plugin name="ap" filename="libgazebo_ros_wifi_ap.so"><ssid>crate_net</ssid>
    <bssid>02:00:00:00:00:42</bssid><channel>6</channel></plugin>
</model></sdf>'''
ROBOT = '''<robot name="r"><link name="base"><inertial><mass value="0.1"/>
  <inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
  <visual><geometry><cylinder radius="0.05" length="0.2"/></geometry>
  <material name="m"><color rgba="0.9 0.1 0.1 1"/></material></visual></link></robot>'''


def test_an_sdf_description_is_drawn_as_the_world_file_models_are():
    d = scene.describe_model(scene.description_model('sdf', CRATE, 'crate', '', None))
    assert d['name'] == 'crate'
    (link,) = d['links']
    (v,) = link['visuals']
    assert v['geometry'] == {'kind': 'box', 'size': [0.2, 0.3, 0.4]}
    assert v['rgba'] == pytest.approx([0.1, 0.9, 0.2, 1])
    assert scene.describe_sdf(CRATE, 'crate')['links'] == d['links']


def test_a_urdf_description_in_its_namespace():
    m = scene.description_model('urdf', ROBOT, 'bot', '/bot', None)
    assert m.name == 'bot' and m.robot_namespace == 'bot'
    (v,) = scene.describe_model(m)['links'][0]['visuals']
    assert v['geometry']['kind'] == 'cylinder'


def test_unreadable_descriptions_raise_naming_what():
    from sim_world.model import ModelError
    with pytest.raises(ValueError, match="'json'"):
        scene.description_model('json', '{}', 'x')
    with pytest.raises(ModelError):
        scene.description_model('sdf', '<sdf><model name="x"></model></sdf>', 'x')


def test_icons_of_a_described_model_by_its_own_plugins():
    m = scene.description_model('sdf', CRATE, 'crate', '', None)
    by = {(ic['kind'], ic['model']): ic for ic in spawned.model_icons(m)}
    assert set(by) == {('nfc', 'crate'), ('wifi', 'crate')}
    assert by[('nfc', 'crate')]['data'] == 'T:hello'
    assert by[('wifi', 'crate')]['id'] == '02:00:00:00:00:42'
    assert by[('wifi', 'crate')]['offset'] == pytest.approx([0, 0, 0], abs=1e-9)
    assert spawned.model_icons(scene.description_model('urdf', ROBOT, 'bot')) == []


class World(object):
    """Stand-in: the names of /gazebo/model_states and the description service."""

    def __init__(self):
        self.names = {'desk'}
        self.descriptions = {}
        self.asked = []
        self.articulated = {}
        self.clock = 0.0

    def model_names(self):
        return set(self.names)

    def poses(self):
        return {n: [1.0, 2.0, 0.5, 0, 0, 0, 1] for n in self.names}

    def link_poses(self):
        return {}

    def rtf(self):
        return 1.0

    def model_description(self, name):
        self.asked.append(name)
        if name not in self.descriptions:
            raise WorldError('/gazebo/get_model_description: GetModelDescription: no model '
                             'named %r' % name)
        fmt, xml = self.descriptions[name]
        return SimpleNamespace(success=True, format=fmt, xml=xml, robot_namespace='',
                               base_dir='')


class Client(object):
    def __init__(self):
        self.got = {}

    def put(self, kind, payload):
        self.got[kind] = json.loads(payload)


def test_the_watch_adds_refuses_and_drops_models():
    w = World()
    st = Studio(w, [{'name': 'desk', 'static': True, 'links': [], 'pose': None}])
    lines = []
    st.log = lines.append
    c = Client()
    st.clients.append(c)

    async def run():
        assert await spawned.tick(st) == []                 # the start: nothing new
        w.names |= {'crate', 'ghost'}
        w.descriptions['crate'] = ('sdf', CRATE)
        assert await spawned.tick(st) == ['crate', 'ghost']
        assert await spawned.tick(st) == []                 # asked once each
        return st.scene()
    sc = asyncio.run(run())
    crate = next(m for m in sc['models'] if m['name'] == 'crate')
    assert crate['links'][0]['visuals'][0]['geometry']['kind'] == 'box'
    assert crate['links'][0]['world_pose']['position'] == pytest.approx([1, 2, 0.5])
    ghost = next(m for m in sc['models'] if m['name'] == 'ghost')
    assert ghost['links'] == []                              # the page's box
    assert len(lines) == 1 and 'ghost' in lines[0] and 'no model named' in lines[0]
    assert w.asked == ['crate', 'ghost']
    assert c.got['scene_models']['models'] == ['crate', 'desk']
    v = c.got['scene_models']['version']
    # its icons, where the model is now (not where its file put it)
    ics = spawned.icons(st, [{'kind': 'light', 'model': None, 'position': [0, 0, 3]}])
    nfc = next(ic for ic in ics if ic['kind'] == 'nfc')
    assert nfc['model'] == 'crate' and nfc['position'] == pytest.approx([1, 2, 0.5])
    # deleted: gone from the scene and the icons; spawned again: asked again
    w.names -= {'crate', 'desk'}
    asyncio.run(spawned.tick(st))
    assert [m['name'] for m in st.scene_models] == []
    assert c.got['scene_models']['version'] == v + 1
    assert [ic['kind'] for ic in spawned.icons(st, [])] == []
    w.names.add('crate')
    assert asyncio.run(spawned.tick(st)) == ['crate']
    assert [m['name'] for m in st.scene_models] == ['crate']


def test_a_phone_spawned_later_joins_the_device_panel():
    from sim_studio.device import DeviceWatch
    rospy = SimpleNamespace(get_published_topics=lambda: [
        ('/phone3/imu_sensor_data', 'sensor_msgs/Imu'), ('/phone3/image_raw', 'sensor_msgs/Image'),
        ('/mobile_device/fix', 'sensor_msgs/NavSatFix'), ('/clock', 'rosgraph_msgs/Clock')])
    studio = SimpleNamespace(device=None, world=SimpleNamespace(rospy=rospy))
    spawned.watch_phone(studio, 'phone3')            # no phone at start: the panel is made
    assert studio.device.wanted(rospy.get_published_topics()) == [
        ('/phone3/imu_sensor_data', 'sensor_msgs/Imu')]
    studio.device = DeviceWatch(rospy, ['mobile_device'])
    spawned.watch_phone(studio, '/phone3')
    spawned.watch_phone(studio, 'phone3')            # once
    assert studio.device.namespaces == ['/mobile_device/', '/phone3/']
    assert [t for t, _ in studio.device.wanted(rospy.get_published_topics())] == [
        '/mobile_device/fix', '/phone3/imu_sensor_data']


def test_the_display_stream_subscribes_a_later_phones_display():
    w = World()
    watched = []
    w.watch_images = watched.append
    w.image_seqs, w.camera_topic = {}, '/mobile_device/image_raw'
    st = Studio(w, [{'name': 'mobile_device', 'links': [], 'pose': None,
                     'display': {'image_topic': '/mobile_device/image_raw'}}])

    async def run():
        loop = asyncio.get_event_loop()
        await st._stream_displays(loop, 1.0)
        st.scene_models.append({'name': 'phone3', 'links': [], 'pose': None,
                                'display': {'image_topic': '/phone3/screen'}})
        await st._stream_displays(loop, 2.0)
        await st._stream_displays(loop, 3.0)
    asyncio.run(run())
    assert watched == [['/mobile_device/image_raw'], ['/phone3/screen']]


def test_attach_hooks_the_icons_into_world_info_once():
    studio = SimpleNamespace()
    spawned.attach(studio)
    spawned.attach(studio)
    assert studio.icon_hooks == [spawned.icons]
