"""The studio's moves and overlays (sim_studio.moves, sim_studio.overlay) without ROS: presets
computed from the office world file (the desk's top by a ray cast, the phone's thickness from
its description), a walk carried out by the runner's own Walk action through a stand-in
service layer and the Mover (sim time from a stand-in clock), its recording as the runner's
walk action that run_scenario --check accepts, bad walks refused before anything moves, the
icons of the office's lights and radios, and the WiFi map by simsensors' power grid."""
import asyncio
import json
import math
import os
import subprocess
import types

import numpy as np
import pytest

from sim_studio import extensions, moves, overlay, protocol
from sim_studio.protocol import ProtocolError, parse
from sim_studio.recorder import check as check_yaml
from sim_studio.server import Studio

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
MODELS = {'mobile_device', 'desk'}

if 'walk' not in protocol.OPS:          # (another test may have loaded every extension)
    extensions.load(['moves', 'overlay'])


@pytest.fixture(scope='module')
def phone_desc():
    from sim_studio import scene
    xml = subprocess.run(['xacro', os.path.join(ROOT, 'sim_world', 'urdf',
                                                'mobile_device.urdf.xacro')],
                         capture_output=True, text=True, check=True).stdout
    return scene.describe_urdf(xml, 'mobile_device')


@pytest.fixture(scope='module')
def office():
    return moves.offline_world(OFFICE)


def test_the_phone_extent_is_its_boxes(phone_desc):
    lo, hi = moves.phone_extent(phone_desc)
    # the body is 0.1239 x 0.065 m (long side along x), a few mm thick around z = 0
    assert np.allclose([hi[0] - lo[0], hi[1] - lo[1]], [0.1239, 0.065], atol=2e-3)
    assert -0.01 < lo[2] < -0.003 and 0.003 < hi[2] < 0.01
    assert np.allclose(moves.phone_extent(None), [[-0.005] * 3, [0.005] * 3])


def test_presets_come_from_the_world(office, phone_desc):
    lo, hi = moves.phone_extent(phone_desc)
    # over the desk: on its top (0.75 m, the top link's box) where the phone is
    p, rpy = moves.preset_pose('flat_on_desk', office, phone_desc, [3.0, -2.0, 1.3], 0.4)
    assert np.allclose(p, [3.0, -2.0, 0.75 - lo[2] + moves.GAP]) and rpy == [0, 0, 0.4]
    p, rpy = moves.preset_pose('face_down', office, phone_desc, [3.0, -2.0, 1.3], 0.4)
    assert np.isclose(p[2], 0.75 + hi[2] + moves.GAP) and rpy == [math.pi, 0, 0.4]
    # elsewhere: the middle of the desk's top
    p, _ = moves.preset_pose('flat_on_desk', office, phone_desc, [0.5, 0.5, 1.0], 0.0)
    assert np.allclose(p[:2], [3.32, -2.10])
    # a standing person's hand and pocket over the floor where the phone is
    p, rpy = moves.preset_pose('held_portrait', office, phone_desc, [1.0, -1.0, 0.3], 1.0)
    assert np.allclose(p, [1.0, -1.0, moves.HAND_HEIGHT]) and rpy[1] < -0.9
    p, rpy = moves.preset_pose('in_pocket', office, phone_desc, [1.0, -1.0, 0.3], 1.0)
    assert np.allclose(p, [1.0, -1.0, moves.POCKET_HEIGHT]) and np.isclose(rpy[1], math.pi / 2)
    with pytest.raises(ValueError, match='no model cupboard'):
        moves.preset_pose('flat_on_desk', office, phone_desc, [3, -2, 1], 0, 'cupboard')


def test_bad_moves_are_refused_by_the_protocol():
    ok = parse(json.dumps({'v': 1, 'op': 'walk', 'model': 'mobile_device',
                           'waypoints': [[0, 0, 1], [1, 2, 1]], 'speed': 1}), MODELS)
    assert ok.fields['waypoints'] == [[0.0, 0.0, 1.0], [1.0, 2.0, 1.0]]
    for bad, words in [
            ({'op': 'preset', 'model': 'mobile_device', 'name': 'on_the_moon'}, 'one of'),
            ({'op': 'preset', 'model': 'nobody', 'name': 'face_down'}, 'no model'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[0, 0, 1]], 'speed': 1},
             '2 to 100'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[0, 0, 1], [1, 1]],
              'speed': 1}, r'waypoints\[1\]'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[0, 0, 1], [1, 1, 1]],
              'speed': 0}, '> 0'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[0, 0, 1], [1, 1, 1]],
              'speed': -2}, '> 0'),
            ({'op': 'radio', 'radio': 'gps', 'enabled': True}, 'one of'),
            ({'op': 'charger', 'plugged': 1}, 'true or false'),
            ({'op': 'wifi_map', 'grid': 0}, '> 0')]:
        with pytest.raises(ProtocolError, match=words):
            parse(json.dumps(dict(bad, v=1)), MODELS)
    with pytest.raises(ProtocolError, match='not a number JSON allows'):
        parse('{"v": 1, "op": "walk", "model": "mobile_device", "waypoints": [[0, 0, 1], '
              '[1, 1, 1]], "speed": NaN}', MODELS)
    assert 'walk' in protocol.WORLD_OPS and 'wifi_map' not in protocol.WORLD_OPS


# -- a walk carried out by the runner's Walk through stand-in services ----------------------------
class Services(object):
    """/gazebo/get_model_state and /gazebo/set_model_state of a stand-in world."""

    def __init__(self, world):
        self.world = world

    def __call__(self, name, typ):
        def call(*args):
            if name == '/gazebo/get_model_state':
                p = self.world.pose
                return types.SimpleNamespace(
                    success=True, pose=types.SimpleNamespace(
                        position=types.SimpleNamespace(x=p[0], y=p[1], z=p[2]),
                        orientation=types.SimpleNamespace(x=0, y=0, z=0, w=1)))
            if name == '/gazebo/set_model_state':
                s = args[0]
                self.world.pose = [s.pose.position.x, s.pose.position.y, s.pose.position.z]
                self.world.sets.append((self.world.clock, list(self.world.pose),
                                        s.twist.linear.x))
                return types.SimpleNamespace(success=True, status_message='')
            raise AssertionError(name)
        return call


class World(object):
    def __init__(self):
        self.clock = 10.0
        self.pose = [1.0, 1.0, 1.2]
        self.sets = []
        self.proxy = Services(self)

    def model_names(self):
        return set(MODELS)

    def get_pose(self, model):
        return list(self.pose), [0, 0, 0, 1]

    def set_pose(self, model, position, rpy):
        self.pose = list(position)
        self.sets.append((self.clock, list(position), None))


def run(coro):
    return asyncio.run(coro)


def test_a_walk_is_the_runners_walk_in_sim_time_and_is_recorded():
    w = World()
    s = Studio(w, [{'name': 'mobile_device', 'links': []}])
    s.recorder.start(w.clock)

    async def go():
        return await s.handle_text(json.dumps({
            'v': 1, 'op': 'walk', 'model': 'mobile_device',
            'waypoints': [[2.0, 1.0, 1.2], [2.0, 2.5, 1.2]], 'speed': 1.25}))
    rep = run(go())
    assert rep['ok'], rep
    assert rep['end'] == pytest.approx(10.0 + 2.5 / 1.25, abs=0.05) and rep['length'] == 2.5
    mover = s._moves.mover
    assert w.sets == [] and mover.pending() == rep['steps'] > 40     # nothing before its time
    w.clock = 11.0                       # half way: the latest due pose only
    assert mover.run_due() == 1
    assert len(w.sets) == 1 and np.allclose(w.sets[-1][1][:2], [2.0, 1.25], atol=0.06)
    assert w.sets[-1][1][2] > 1.2 - 1e-9 and w.sets[-1][2] == 0.0    # the walking bounce
    w.clock = 13.0
    mover.run_due()
    assert np.allclose(w.pose, [2.0, 2.5, 1.2]) and mover.pending() == 0
    text = s.recorder.yaml()
    assert '{id: a1, at: 0, action: walk, model: mobile_device, waypoints: [[2, 1, 1.2], ' \
        '[2, 2.5, 1.2]], speed: 1.25}' in text
    assert 'action: log' in text and 'duration: 3' in text          # it lasts the walk
    assert check_yaml(text) == []


def test_a_walk_too_long_and_a_new_walk_replace_nothing_or_the_last():
    w = World()
    s = Studio(w, [])

    def walk(speed, to=(2.0, 2.5, 1.2)):
        return run(s.handle_text(json.dumps({'v': 1, 'op': 'walk', 'model': 'mobile_device',
                                             'waypoints': [[2.0, 1.0, 1.2], list(to)],
                                             'speed': speed})))
    rep = walk(0.001)
    assert not rep['ok'] and 'more than 600' in rep['error']
    assert getattr(s, '_moves', None) is None or s._moves.mover.pending() == 0
    first = walk(1.0)
    second = walk(1.0, (0.0, 0.0, 1.2))
    assert first['ok'] and second['ok']
    assert s._moves.mover.pending() == second['steps']              # the first is gone
    w.clock = 100.0
    s._moves.mover.run_due()
    assert np.allclose(w.pose, [0.0, 0.0, 1.2])


def test_a_preset_is_one_set_pose_recorded_as_set_model_state(phone_desc):
    w = World()
    w.pose = [3.0, -2.0, 1.3]
    s = Studio(w, [phone_desc])
    s.world_file = OFFICE
    s.recorder.start(w.clock)
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'preset', 'model': 'mobile_device',
                                        'name': 'flat_on_desk'})))
    assert rep['ok'], rep
    assert np.allclose(w.pose[:2], [3.0, -2.0]) and 0.75 < w.pose[2] < 0.77
    assert rep['recorded']['action'] == 'set_model_state'
    bad = run(s.handle_text(json.dumps({'v': 1, 'op': 'preset', 'model': 'mobile_device',
                                        'name': 'flat_on_desk', 'surface': 'cupboard'})))
    assert not bad['ok'] and 'no model cupboard' in bad['error'] and len(w.sets) == 1


def test_icons_are_the_worlds_lights_and_radios(office):
    info = overlay.world_info(office)
    by = {(i['kind'], i['id']): i for i in info['icons']}
    assert by[('wifi', '00:1a:2b:3c:4d:01')]['position'] == [5.6, 0.7, 2.2]
    assert by[('wifi', '00:1a:2b:3c:4d:01')]['model'] == 'ap_office'
    assert by[('wifi', '00:1a:2b:3c:4d:02')]['offset'] == [0.0, 0.0, 0.0]
    assert by[('bluetooth', 'heart_rate_belt')]['position'] == [3.32, -2.85, 0.49]
    assert by[('nfc', 'nfc_poster')]['data'].startswith('U:http')
    assert by[('light', 'desk_lamp')]['light'] == 'point'
    assert ('cell', '262-01-4711-1234') in by
    x0, x1, y0, y1 = info['bounds']               # the office, not the far cell tower
    assert -2 < x0 < 0.5 and 6 < x1 < 9 and -7 < y0 < -4 and 1 < y1 < 3


def test_the_wifi_map_is_the_radio_budgets():
    from simsensors import radio_budget as rb
    w = moves.offline_world(OFFICE)
    xs, ys = np.array([1.0, 5.0]), np.array([-4.0, 0.5])
    grid, solid, aps = overlay.strongest_grid(w, xs, ys, 1.0)
    assert aps == ['00:1a:2b:3c:4d:01', '00:1a:2b:3c:4d:02']
    for i, y in enumerate(ys):
        for j, x in enumerate(xs):
            want = max(rb.budget_to(t, [x, y, 1.0], segment_intervals=w.segment_intervals)[0]
                       for t in w.transmitters('wifi'))
            assert grid[i, j] == pytest.approx(want, abs=1e-9)
    one, _, _ = overlay.strongest_grid(w, xs, ys, 1.0, '00:1A:2B:3C:4D:02')
    assert np.all(one <= grid + 1e-12) and np.any(one < grid)
    with pytest.raises(ValueError, match='no access point with BSSID'):
        overlay.strongest_grid(w, xs, ys, 1.0, '00:00:00:00:00:00')
    png = overlay.map_png(grid, solid)
    import cv2
    img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    assert img.shape == (2, 2, 4)
    # wifi_map's colours, north up: the image's row 0 is the grid's last row (y = 0.5)
    t = np.clip((grid - overlay.LO) / (overlay.HI - overlay.LO), 0, 1)
    jet = cv2.applyColorMap((t * 255).astype(np.uint8), cv2.COLORMAP_JET)
    assert np.array_equal(img[:, :, :3], jet[::-1]) and np.all(img[:, :, 3] == 190)


def test_the_speaker_level_is_rms_in_dbfs():
    assert overlay.rms_dbfs([0.5, -0.5]) == pytest.approx(20 * math.log10(0.5))
    assert overlay.rms_dbfs([]) == -math.inf and overlay.rms_dbfs([0, 0]) == -math.inf


def test_radio_and_charger_are_the_runners_actions_and_are_recorded():
    from testing_instance.run.actions import Hands
    w = World()
    s = Studio(w, [])
    sent = []
    hands = Hands(types.SimpleNamespace(phones=[{'ns': 'mobile_device'}]), None, None)
    hands.publish = lambda topic, msg: sent.append((topic, msg.data))
    moves._state(s).hands = hands
    s.recorder.start(w.clock)
    for body in ({'op': 'radio', 'radio': 'wifi', 'enabled': False},
                 {'op': 'radio', 'radio': 'nfc', 'enabled': False},
                 {'op': 'charger', 'plugged': True, 'model': 'mobile_device'}):
        rep = run(s.handle_text(json.dumps(dict(body, v=1))))
        assert rep['ok'], rep
    assert sent == [('/mobile_device/wifi/enable', False), ('/mobile_device/nfc/enable', False),
                    ('/mobile_device/charger', True)]
    text = s.recorder.yaml()
    assert 'action: radio, ns: mobile_device, radio: wifi, enabled: false' in text, text
    assert 'action: radio, ns: mobile_device, radio: nfc, enabled: false' in text, text
    assert 'action: charger, ns: mobile_device, plugged: true' in text
    assert check_yaml(text) == []
