"""Radio (thesis 3.3.2, 3.3.8, 3.3.15): the link budget against hand-computed values, WiFi,
cellular, Bluetooth and NFC on the real World (both engines), bad input."""
import logging
import math
import os
import subprocess
import types

import numpy as np
import pytest

from sim_world.sdf import parse_sdf_model
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

from simsensors import radio_budget as rb
from simsensors.bluetooth import BluetoothAdapter
from simsensors.cellular import CellularReceiver
from simsensors.nfc import NfcDevice
from simsensors.wifi import WifiReceiver

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
XACRO = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
F = 2437.0


# -- the budget, by hand -------------------------------------------------------------------
def test_friis_by_hand():
    assert rb.friis_loss(F, 1.0) == pytest.approx(-27.55 + 20 * math.log10(2437), abs=1e-9)
    assert rb.friis_loss(F, 1.0) == pytest.approx(40.187, abs=1e-3)
    assert rb.friis_loss(F, 10.0) == pytest.approx(60.187, abs=1e-3)
    assert rb.friis_loss(F, 10.0) - rb.friis_loss(F, 1.0) == pytest.approx(20.0)


def test_equation_3_3():
    # 20 dBm + 6 dBi - 3 dB - 40.187 (1 m) + 0 - 0 = -17.187 dBm
    p = rb.received_power(20, 6, 3, rb.friis_loss(F, 1), 0, 0, 0, 0)
    assert p == pytest.approx(-17.187, abs=1e-3)
    # the thesis writes losses as negative dB: read as magnitudes
    assert rb.received_power(20, 6, -3, 40, 0, 0, 2, -1) == rb.received_power(20, 6, 3, 40, 0,
                                                                                0, 2, 1)


def test_obstacle_loss_walls():
    assert rb.obstacle_loss([(1.0, 1.2)]) == pytest.approx(22.0)
    assert rb.obstacle_loss([(1.0, 1.2, 'w', 'l', None), (3.0, 3.1, 'v', 'l', None)]) \
        == pytest.approx(33.0)
    assert rb.obstacle_loss([(0, 0.1, 'w', 'l', 'glass')], 110, {'glass': 30}) \
        == pytest.approx(3.0)


def test_link_speed_table_and_sensitivity():
    assert rb.link_speed(-40) == 54
    assert rb.link_speed(-65) == 54
    assert rb.link_speed(-65.5) == 48
    assert rb.link_speed(-75) == 18
    assert rb.link_speed(-82) == 6
    assert rb.link_speed(-85) == 1
    assert rb.link_speed(-90) == 1
    assert rb.link_speed(-90.01) == 0
    assert rb.link_speed(-85, sensitivity=-84) == 0


def test_asu_and_channels():
    assert rb.asu_from_dbm(-113) == 0 and rb.asu_from_dbm(-51) == 31
    assert rb.asu_from_dbm(-20) == 31 and rb.asu_from_dbm(-73) == 20
    assert rb.asu_from_dbm(None) == 99
    assert rb.wifi_frequency(1) == 2412 and rb.wifi_frequency(6) == 2437
    assert rb.wifi_frequency(14) == 2484 and rb.wifi_frequency(36) == 5180
    assert rb.wifi_channel(2462) == 11
    with pytest.raises(ValueError):
        rb.wifi_frequency(15)
    assert rb.valid_bssid('00:1a:2B:3c:4d:01') and not rb.valid_bssid('00:1a:2b:3c:4d')
    assert not rb.valid_bssid('zz:1a:2b:3c:4d:01')


def test_fading_statistics_fixed_seed():
    g = np.random.Generator(np.random.PCG64(7))
    ln = np.array([rb.misc_loss(g, 'lognormal', 4.0) for _ in range(20000)])
    assert abs(ln.mean()) < 0.1 and ln.std() == pytest.approx(4.0, rel=0.03)
    ray = np.array([rb.misc_loss(g, 'rayleigh') for _ in range(20000)])
    # |h|^2 ~ Exp(1): mean of 10^(-L/10) is 1; P(L > 10 dB) = P(|h|^2 < 0.1) = 1 - e^-0.1
    assert np.mean(10 ** (-ray / 10)) == pytest.approx(1.0, rel=0.03)
    assert np.mean(ray > 10) == pytest.approx(1 - math.exp(-0.1), abs=0.01)
    g1, g2 = (np.random.Generator(np.random.PCG64(3)) for _ in range(2))
    assert [rb.misc_loss(g1, 'rayleigh') for _ in range(5)] == \
        [rb.misc_loss(g2, 'rayleigh') for _ in range(5)]
    assert rb.misc_loss(g, 'none', 5) == 0.0


# -- in the world ---------------------------------------------------------------------------
_PHONE = None


def phone_xml(ns='mobile_device'):
    global _PHONE
    if _PHONE is None:
        _PHONE = {}
    if ns not in _PHONE:
        _PHONE[ns] = subprocess.check_output(['xacro', XACRO, 'ns:=%s' % ns]).decode()
    return _PHONE[ns]


def phone(ns='mobile_device'):
    m = parse_urdf(phone_xml(ns))
    m.name = ns
    return m


def ap(name, xyz, bssid, extra=''):
    return parse_sdf_model('''<model name="%s"><static>true</static><pose>%g %g %g 0 0 0</pose>
      <link name="box"/><plugin name="wifi_ap" filename="libgazebo_ros_wifi_ap.so">
      <bssid>%s</bssid><ssid>test</ssid><channel>6</channel><txPower>20</txPower>
      <txGain>6</txGain><txLoss>3</txLoss>%s</plugin></model>''' % ((name,) + tuple(xyz)
                                                                   + (bssid, extra)))


def wall(name, x, thickness, material=None):
    mat = '<material>%s</material>' % material if material else ''
    return parse_sdf_model('''<model name="%s"><static>true</static><pose>%g 0 1.5 0 0 0</pose>
      <link name="l"><collision name="c"><geometry><box><size>%g 20 3</size></box></geometry>
      %s</collision></link></model>''' % (name, x, thickness, mat))


def plugin(world, cls, name='mobile_device'):
    return [p for p in world.plugins[name] if isinstance(p, cls)][0]


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = World(physics=request.param, seed=11)
    yield w
    w.shutdown()


def wifi_at(world, xyz, fading='none'):
    world.add_model(phone(), pose=Pose(xyz))
    w = plugin(world, WifiReceiver)
    w.p.fading = fading
    return w


def level(w, bssid):
    return {tx.id: p for tx, p, _ in w.heard}.get(bssid)


def test_wifi_free_space_and_walls(world):
    """1 m and 10 m free space by hand; a 0.2 m wall adds 22 dB; two walls sum."""
    world.add_model(ap('ap', (0, 0, 10), '00:00:00:00:00:01'))
    w = wifi_at(world, (0, 0, 1))            # phone 9 m below... measured to its body
    world.step(1001)
    body = world.link_pose('mobile_device', w.body).p
    d = np.linalg.norm(body - np.array([0, 0, 10]))
    expect = 23 - rb.friis_loss(2437, d)
    assert level(w, '00:00:00:00:00:01') == pytest.approx(expect, abs=1e-6)
    # phone teleported 1 m / 10 m from the AP along x (gravity pulls; read right after)
    world.set_state('mobile_device', Pose((1, 0, 10)))
    m = w.measure(w.state(), 0)
    d = np.linalg.norm(world.link_pose('mobile_device', w.body).p - [0, 0, 10])
    assert level(w, '00:00:00:00:00:01') == pytest.approx(23 - rb.friis_loss(2437, d), abs=1e-6)
    assert d == pytest.approx(1.0, abs=0.02)
    world.set_state('mobile_device', Pose((10, 0, 10)))
    w.measure(w.state(), 0)
    free10 = level(w, '00:00:00:00:00:01')
    assert free10 == pytest.approx(-37.19, abs=0.05)
    world.add_model(wall('w1', 3.0, 0.2))
    world.set_state('mobile_device', Pose((10, 0, 1.5)))
    world.delete_model('ap')
    world.add_model(ap('ap', (0, 0, 1.5), '00:00:00:00:00:01'))
    # the default, multi-wall: one wall of no known material, head-on
    w.measure(w.state(), 0)
    (_, p1, terms), = w.heard
    assert terms['l_ob'] == pytest.approx(rb.DEFAULT_WALL_LOSS, abs=1e-6)
    # the thesis's model by parameter: 0.2 m x 110 dB/m
    w.p.wallModel = 'per_metre'
    w.measure(w.state(), 0)
    (_, p1, terms), = w.heard
    assert terms['l_ob'] == pytest.approx(22.0, abs=1e-6)
    assert p1 == pytest.approx(23 - terms['l_fs'] - 22.0, abs=1e-9)
    world.add_model(wall('w2', 6.0, 0.3, 'glass'))
    w.p.materialAttenuation = {'glass': 30.0}
    w.measure(w.state(), 0)
    (_, p2, terms), = w.heard
    assert terms['l_ob'] == pytest.approx(22.0 + 9.0, abs=1e-6)
    assert p1 - p2 == pytest.approx(9.0, abs=1e-6)
    w.p.wallModel = 'multiwall'          # glass from the built-in table, 0.3 m thick slab
    w.measure(w.state(), 0)
    (_, p3, terms), = w.heard
    assert terms['l_ob'] == pytest.approx(rb.DEFAULT_WALL_LOSS + rb.WALL_LOSS['glass'],
                                          abs=1e-6)


def test_wifi_sensitivity_link_and_enable(world):
    world.add_model(ap('near', (2, 0, 1), '00:00:00:00:00:01'))
    world.add_model(ap('far', (6000, 0, 1), '00:00:00:00:00:02'))
    w = wifi_at(world, (0, 0, 1))
    world.step(1001)
    assert [a.bssid for a in w.last_msg.access_points] == ['00:00:00:00:00:01']  # far < -90
    assert level(w, '00:00:00:00:00:02') is None
    lk = w.last_link
    assert lk.connected and lk.bssid == '00:00:00:00:00:01' and lk.ssid == 'test'
    assert lk.link_speed == 54 and lk.frequency == 2437 and lk.rssi > -65
    assert world.power.flag('mobile_device', 'wifi') is True
    assert world.power.draws('mobile_device')['wifi'] == pytest.approx(0.25)
    w.set_enabled(False)
    world.step(1000)
    assert not w.last_msg.enabled and not w.last_msg.access_points
    assert not w.last_link.connected and not w.last_link.enabled
    assert world.power.flag('mobile_device', 'wifi') is False
    assert world.power.draws('mobile_device')['wifi'] == 0.0


def test_office_two_rooms_swap_strongest(world):
    world.load_world_file(OFFICE)
    w = wifi_at(world, (4.5, -1.0, 1.0))
    world.step(1001)
    assert w.last_msg.access_points[0].bssid == '00:1a:2b:3c:4d:01'
    assert w.last_link.bssid == '00:1a:2b:3c:4d:01'
    # the west room behind the inner wall
    world.set_state('mobile_device', Pose((0.7, -3.5, 1.0)))
    world.step(1000)
    assert w.last_msg.access_points[0].bssid == '00:1a:2b:3c:4d:02'
    assert w.last_link.bssid == '00:1a:2b:3c:4d:02'
    c = plugin(world, CellularReceiver)
    assert c.last_msg.cell_id == '262-01-4711-1234'
    assert 0 <= c.last_msg.asu <= 31 and c.last_msg.dbm == pytest.approx(
        -113 + 2 * c.last_msg.asu, abs=2)


def test_same_seed_same_scans():
    out = []
    for _ in range(2):
        wd = World(physics='ode', seed=5)
        try:
            wd.load_world_file(OFFICE)
            wd.add_model(phone(), pose=Pose((4.5, -1.0, 1.0)))
            w = plugin(wd, WifiReceiver)
            levels = []
            for _ in range(3):
                wd.step(1000)
                levels.append([(a.bssid, a.level) for a in w.last_msg.access_points])
            out.append(levels)
        finally:
            wd.shutdown()
    assert out[0] == out[1]


def test_cellular_none_heard(world):
    world.add_model(phone(), pose=Pose((0, 0, 1)))
    c = plugin(world, CellularReceiver)
    world.step(1001)
    assert c.last_msg.asu == 99 and c.last_msg.cell_id == '' and math.isnan(c.last_msg.dbm)


def test_bad_bssid_one_line_and_ap_works(world, caplog):
    with caplog.at_level(logging.ERROR):
        world.add_model(ap('bad', (2, 0, 1), '00:1a:2b:3c:4d'))
    lines = [r.getMessage() for r in caplog.records if 'bssid' in r.getMessage()]
    assert len(lines) == 1 and 'bad' in lines[0] and '00:1a:2b:3c:4d' in lines[0]
    w = wifi_at(world, (0, 0, 1))
    world.step(1001)
    assert len(w.last_msg.access_points) == 1
    assert rb.valid_bssid(w.last_msg.access_points[0].bssid)


# -- Bluetooth ------------------------------------------------------------------------------
def belt(xyz, rng='10'):
    return parse_sdf_model('''<model name="belt"><static>true</static><pose>%g %g %g 0 0 0</pose>
      <link name="b"/><plugin name="hr" filename="libgazebo_ros_bluetooth_device.so">
      <deviceName>heart_rate_belt</deviceName><range>%s</range><heartRate>72</heartRate>
      </plugin></model>''' % (tuple(xyz) + (rng,)))


def test_bluetooth_range_and_switch(world):
    world.add_model(belt((3, 0, 1)))
    world.add_model(phone(), pose=Pose((0, 0, 1)))
    bt = plugin(world, BluetoothAdapter)
    world.step(2001)
    st, v = bt.last_value['heart_rate_belt']
    assert st == 'connected' and 65 < v < 79
    e = bt.devices['heart_rate_belt']
    assert e['state_pub'].last.data == 'connected' and e['data_pub'].count >= 2
    n = e['data_pub'].count
    world.set_state('mobile_device', Pose((15, 0, 1)))
    world.step(1000)
    assert bt.last_value['heart_rate_belt'] == ('out_of_range', None)
    assert e['state_pub'].last.data == 'out_of_range' and e['data_pub'].count == n
    world.set_state('mobile_device', Pose((1, 0, 1)))
    bt.set_enabled(False)
    world.step(1000)
    assert e['state_pub'].last.data == 'disabled' and e['data_pub'].count == n
    assert world.power.flag('mobile_device', 'bluetooth') is False
    bt.set_enabled(True)
    world.step(1000)
    assert e['state_pub'].last.data == 'connected' and e['data_pub'].count == n + 1


def test_bluetooth_negative_range(world, caplog):
    with caplog.at_level(logging.ERROR):
        world.add_model(belt((3, 0, 1), '-2'))
    lines = [r.getMessage() for r in caplog.records if 'range' in r.getMessage()]
    assert len(lines) == 1 and '-2' in lines[0] and 'belt' in lines[0]
    world.add_model(phone(), pose=Pose((0, 0, 1)))       # the default range (10 m) serves
    bt = plugin(world, BluetoothAdapter)
    world.step(1001)
    assert bt.last_value['heart_rate_belt'][0] == 'connected'


# -- NFC ------------------------------------------------------------------------------------
VCARD = 'BEGIN:VCARD\nVERSION:2.1\nN:Mustermann;Max\nTEL:+49 89 289 00000\nEND:VCARD'


class Out(object):
    def __init__(self, receiver, data):
        self.receiver, self.data = receiver, data


def two_phones(world, gap, back_to_back=False, mode_b='active'):
    """Phone A face up at z = 1; phone B above it at z = 1 + gap, screen down (face to face)
    or screen up (A's back... B above A's screen, both facing up: B's back faces A)."""
    world.add_model(phone('mobile_device'), pose=Pose((0, 0, 1)))
    rpy = (0, 0, 0) if back_to_back else (math.pi, 0, 0)
    world.add_model(phone('mobile_device_b'), pose=Pose.from_xyz_rpy((0, 0, 1 + gap), rpy))
    a, b = plugin(world, NfcDevice, 'mobile_device'), plugin(world, NfcDevice, 'mobile_device_b')
    if back_to_back:      # both look along +z of their own frame: A up, B down (rolled)
        world.set_state('mobile_device', Pose.from_xyz_rpy((0, 0, 1), (math.pi, 0, 0)))
    b.mode = mode_b
    return a, b


def test_nfc_face_to_face_vcard_both_ways(world):
    a, b = two_phones(world, 0.03)
    assert a.name == 'mobile_device' and b.name == 'mobile_device_b'
    assert a.topic == '/mobile_device/nfc/notification'
    assert b.incoming_pub.topic == '/mobile_device_b/nfc/incoming'
    world.step(101)
    assert a.notifications[-1][1:] == ('mobile_device_b', 'active', 'connected')
    assert b.notifications[-1][1:] == ('mobile_device', 'active', 'connected')
    assert (a.last_msg.name, a.last_msg.type, a.last_msg.status) == \
        ('mobile_device_b', 'active', 'connected')
    a.on_outgoing(Out('mobile_device_b', VCARD))
    assert b.incoming_pub.last.sender == 'mobile_device' and b.incoming_pub.last.data == VCARD
    b.on_outgoing(Out('mobile_device', 'OK'))
    assert a.incoming_pub.last.sender == 'mobile_device_b' and a.incoming_pub.last.data == 'OK'
    b.on_outgoing(Out('', VCARD))                       # the only partner
    assert a.incoming_pub.last.data == VCARD
    # apart to 20 cm: disconnected, both told
    world.set_state('mobile_device_b', Pose.from_xyz_rpy(
        world.model_state('mobile_device')[0].p + [0, 0, 0.20], (math.pi, 0, 0)))
    world.set_state('mobile_device', Pose(world.model_state('mobile_device')[0].p))
    world.step(100)
    assert a.notifications[-1][1:] == ('mobile_device_b', 'active', 'disconnected')
    assert b.notifications[-1][1:] == ('mobile_device', 'active', 'disconnected')


def test_nfc_switch_off_disconnects_and_stops_reading(world, caplog):
    """nfc/enable false: both sides told disconnected at once, nothing connects, is read or
    sent while off (one warning line); on again: connected at the next evaluation; the
    power bus sees flag nfc."""
    a, b = two_phones(world, 0.03)
    assert a.topic == '/mobile_device/nfc/notification' and a.enabled
    assert world.power.flag('mobile_device', 'nfc') is True
    world.step(101)
    assert a.notifications[-1][3] == 'connected'
    a._on_enable(types.SimpleNamespace(data=False))
    assert not a.enabled and world.power.flag('mobile_device', 'nfc') is False
    assert a.notifications[-1][1:] == ('mobile_device_b', 'active', 'disconnected')
    assert b.notifications[-1][1:] == ('mobile_device', 'active', 'disconnected')
    na, nb = len(a.notifications), len(b.notifications)
    world.step(300)
    assert len(a.notifications) == na and len(b.notifications) == nb     # stays apart
    n = b.incoming_pub.count
    with caplog.at_level(logging.WARNING):
        assert a.on_outgoing(Out('mobile_device_b', VCARD)) is None
    assert b.incoming_pub.count == n
    assert sum('switched off' in r.getMessage() for r in caplog.records) == 1
    a.set_enabled(True)
    world.step(101)
    assert a.notifications[-1][3] == 'connected' and b.notifications[-1][3] == 'connected'
    a.on_outgoing(Out('mobile_device_b', VCARD))
    assert b.incoming_pub.last.data == VCARD


def test_nfc_off_at_start_reads_no_tag(world):
    world.add_model(tag((0, 0, 1.025)))
    world.add_model(phone(), pose=Pose((0, 0, 1)))
    a = plugin(world, NfcDevice)
    a.set_enabled(False)
    world.step(11)
    assert not a.notifications and not a.received
    a.set_enabled(True)
    world.step(100)
    assert a.received and a.received[-1][1:] == ('poster', 'U:http://vmi.lmt.ei.tum.de')


def test_nfc_outgoing_without_partner_warns(world, caplog):
    a, b = two_phones(world, 0.20)
    world.step(101)
    assert not a.notifications
    n = b.incoming_pub.count
    with caplog.at_level(logging.WARNING):
        assert a.on_outgoing(Out('mobile_device_b', VCARD)) is None
    lines = [r.getMessage() for r in caplog.records if 'not delivered' in r.getMessage()]
    assert len(lines) == 1 and 'mobile_device_b' in lines[0]
    assert b.incoming_pub.count == n


def test_nfc_back_to_back_no_connection(world):
    a, b = two_phones(world, 0.03, back_to_back=True)
    world.step(301)
    assert not a.notifications and not b.notifications


def test_nfc_passive_needs_an_active_partner(world):
    a, b = two_phones(world, 0.03, mode_b='passive')
    world.step(101)
    assert a.notifications[-1][1:] == ('mobile_device_b', 'passive', 'connected')
    a.mode = 'passive'
    world.step(100)
    assert a.notifications[-1][3] == 'disconnected'


def tag(xyz, data='U:http://vmi.lmt.ei.tum.de', extra=''):
    d = '<data>%s</data>' % data if data is not None else ''
    return parse_sdf_model('''<model name="poster"><static>true</static><pose>%g %g %g 0 0 0</pose>
      <link name="p"/><plugin name="tag" filename="libgazebo_ros_nfc_tag.so">%s%s
      </plugin></model>''' % (tuple(xyz) + (d, extra)))


@pytest.mark.parametrize('mode', ['active', 'passive'])
def test_nfc_tag_read_by_active_only(world, mode):
    world.add_model(tag((0, 0, 1.025)))
    world.add_model(phone(), pose=Pose((0, 0, 1)))
    a = plugin(world, NfcDevice)
    a.mode = mode
    world.step(11)          # 10 ms: the phone fell 0.5 mm
    if mode == 'active':
        assert a.notifications == [(pytest.approx(0.0, abs=0.2), 'poster', 'passive',
                                    'connected')]
        assert a.received[-1][1:] == ('poster', 'U:http://vmi.lmt.ei.tum.de')
        assert a.incoming_pub.last.data == 'U:http://vmi.lmt.ei.tum.de'
    else:
        assert not a.notifications and not a.received


def test_nfc_bad_input(world, caplog):
    with caplog.at_level(logging.ERROR):
        world.add_model(tag((0, 0, 1.025), data=None))
        world.add_model(parse_sdf_model('''<model name="t2"><static>true</static>
          <pose>5 0 1 0 0 0</pose><link name="p"/>
          <plugin name="tag" filename="libgazebo_ros_nfc_tag.so"><data>x</data>
          <range>-0.03</range><direction>sideways</direction></plugin></model>'''))
    msgs = [r.getMessage() for r in caplog.records]
    assert sum('has no data' in m and 'poster' in m for m in msgs) == 1
    assert sum('range' in m and '-0.03' in m for m in msgs) == 1
    assert sum('direction' in m and 'sideways' in m for m in msgs) == 1
    t2 = world.plugins['t2'][0]
    assert t2.range == 0.04 and t2.direction == 'omni'
    world.add_model(phone(), pose=Pose((0, 0, 1)))
    world.step(11)
    a = plugin(world, NfcDevice)
    assert not a.notifications                      # the tag without data is not there


def test_nfc_partner_deleted_is_disconnected(world):
    a, b = two_phones(world, 0.03)
    world.step(101)
    assert a.notifications[-1][3] == 'connected'
    world.delete_model('mobile_device_b')
    assert a.notifications[-1][1:] == ('mobile_device_b', 'active', 'disconnected')
    world.step(200)
    assert a.notifications[-1][3] == 'disconnected'
    assert a.on_outgoing(Out('mobile_device_b', 'x')) is None


def test_transmitters_leave_with_their_model(world):
    world.add_model(ap('ap', (2, 0, 1), '00:00:00:00:00:01'))
    assert [t.id for t in world.environment.transmitters] == ['00:00:00:00:00:01']
    world.delete_model('ap')
    assert world.environment.transmitters == []


def test_wifi_roaming_hysteresis_and_ssid(world):
    world.add_model(ap('ap1', (0, 0, 30), '00:00:00:00:00:01'))
    world.add_model(ap('ap2', (10, 0, 30), '00:00:00:00:00:02'))
    w = wifi_at(world, (4.0, 0, 30))            # nearer ap1 (the phone floats: gravity off)
    world.step(1001)
    assert w.last_link.bssid == '00:00:00:00:00:01'
    world.set_state('mobile_device', Pose((5.5, 0, 30)))   # ap2 now 1.6 dB stronger: stay
    world.step(1000)
    assert w.last_msg.access_points[0].bssid == '00:00:00:00:00:02'
    assert w.last_link.bssid == '00:00:00:00:00:01'
    world.set_state('mobile_device', Pose((7.5, 0, 30)))   # 9.5 dB stronger: roam
    world.step(1000)
    assert w.last_link.bssid == '00:00:00:00:00:02'
    w.p.ssid = 'other'                                      # a network nobody offers
    world.step(1000)
    assert not w.last_link.connected and w.last_link.enabled
    assert len(w.last_msg.access_points) == 2
