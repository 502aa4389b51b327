#!/usr/bin/env python3
"""rostest (radio.test): WiFi roaming between the office's two rooms, NFC between two phones
(the thesis's vCard flow) and with the poster tag, through a real roscore."""
import math
import time
import unittest

import rosgraph
import rospy
import rostest
from std_msgs.msg import Bool, Float64, String

from mobile_device_sim.msg import (CellSignal, NfcIncoming, NfcNotification, NfcOutgoing,
                                   WifiLink, WifiScan)
from common import Recorder, model_state_msg, sim_sleep, start  # noqa: E402

A, B, C = 'mobile_device', 'mobile_device_b', 'mobile_device_c'
AP_OFFICE, AP_WEST = '00:1a:2b:3c:4d:01', '00:1a:2b:3c:4d:02'
VCARD = ('BEGIN:VCARD\nVERSION:2.1\nN:Mustermann;Max\nFN:Max Mustermann\n'
         'TEL;CELL:+49 89 289 00000\nEMAIL:max@example.org\nEND:VCARD')


class Radio(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.get, cls.set = start('radio_test', [A, B, C])
        cls.rec = {}
        for ns in (A, B, C):
            cls.rec[ns] = dict(
                note=Recorder('/%s/nfc/notification' % ns, NfcNotification),
                inc=Recorder('/%s/nfc/incoming' % ns, NfcIncoming))
        cls.scan = Recorder('/%s/wifi/scan' % A, WifiScan)
        cls.link = Recorder('/%s/wifi/link' % A, WifiLink)
        cls.cell = Recorder('/%s/cellular/signal' % A, CellSignal)
        cls.out = dict((ns, rospy.Publisher('/%s/nfc/outgoing' % ns, NfcOutgoing,
                                            queue_size=10)) for ns in (A, B, C))
        sim_sleep(2.0)

    def put(self, model, x, y, z, roll=0.0):
        res = self.set(model_state_msg(model, (x, y, z), (roll, 0.0, 0.0)))
        self.assertTrue(res.success, res.status_message)

    def wait_for(self, what, cond, timeout=30.0):
        deadline = time.time() + timeout
        while time.time() < deadline:
            if cond():
                return
            time.sleep(0.05)
        self.fail('timed out waiting for ' + what)

    def notes(self, ns):
        return [(m.name, m.type, m.status) for m in self.rec[ns]['note'].msgs]

    # -- WiFi ------------------------------------------------------------------------------
    def test_1_wifi_walk_swaps_strongest_and_link(self):
        types = dict(rosgraph.Master('/radio_test').getTopicTypes())
        self.assertEqual(types.get('/%s/wifi/scan' % A), 'mobile_device_sim/WifiScan')
        self.assertEqual(types.get('/%s/wifi/link' % A), 'mobile_device_sim/WifiLink')
        self.assertEqual(types.get('/%s/cellular/signal' % A), 'mobile_device_sim/CellSignal')
        self.put(A, 4.5, -1.0, 1.0)
        sim_sleep(2.5)
        self.assertEqual(self.scan.msgs[-1].access_points[0].bssid, AP_OFFICE)
        self.assertTrue(self.link.msgs[-1].connected)
        self.assertEqual(self.link.msgs[-1].bssid, AP_OFFICE)
        self.assertEqual(self.link.msgs[-1].ssid, 'lmt-office')
        self.assertEqual(self.cell.msgs[-1].cell_id, '262-01-4711-1234')
        # walk: along the north of the office, through the inner door, into the west room
        for x, y in ((3.5, 0.4), (2.5, 0.4), (1.5, 0.45), (0.8, 0.0), (0.7, -2.0),
                     (0.7, -3.5)):
            self.put(A, x, y, 1.0)
            sim_sleep(1.2)
        sim_sleep(1.5)
        s = self.scan.msgs[-1]
        self.assertEqual(s.access_points[0].bssid, AP_WEST, s)
        self.assertGreater(s.access_points[0].level, s.access_points[-1].level)
        lk = self.link.msgs[-1]
        self.assertTrue(lk.connected)
        self.assertEqual(lk.bssid, AP_WEST)
        self.assertGreater(lk.link_speed, 0)

    def test_5_switches_wifi_and_bluetooth(self):
        self.put(A, 4.5, -1.0, 1.0)
        st = Recorder('/%s/bluetooth/heart_rate_belt/state' % A, String)
        hr = Recorder('/%s/bluetooth/heart_rate_belt/heart_rate' % A, Float64)
        self.wait_for('belt connected', lambda: st.msgs and st.msgs[-1].data == 'connected')
        self.wait_for('heart rate', lambda: len(hr.msgs) >= 2)
        self.assertTrue(50 < hr.msgs[-1].data < 100, hr.msgs[-1].data)
        bt = rospy.Publisher('/%s/bluetooth/enable' % A, Bool, queue_size=1, latch=True)
        wifi = rospy.Publisher('/%s/wifi/enable' % A, Bool, queue_size=1, latch=True)
        bt.publish(Bool(data=False))
        wifi.publish(Bool(data=False))
        self.wait_for('belt disabled', lambda: st.msgs[-1].data == 'disabled')
        self.wait_for('wifi off', lambda: not self.link.msgs[-1].enabled)
        n = len(hr.msgs)
        sim_sleep(2.5)
        self.assertEqual(len(hr.msgs), n)
        self.assertFalse(self.link.msgs[-1].connected)
        self.assertEqual(self.scan.msgs[-1].access_points, [])
        # out of reach: the belt's range is 10 m
        bt.publish(Bool(data=True))
        wifi.publish(Bool(data=True))
        self.wait_for('belt back', lambda: st.msgs[-1].data == 'connected')
        self.put(A, 20.0, -2.0, 1.0)
        self.wait_for('belt out of range', lambda: st.msgs[-1].data == 'out_of_range')
        self.put(A, 4.5, -1.0, 1.0)
        self.wait_for('wifi on', lambda: self.link.msgs[-1].connected)

    # -- NFC between two phones ------------------------------------------------------------
    def test_2_nfc_vcard_exchange_face_to_face(self):
        self.put(C, 5.0, -3.5, 1.5)
        self.put(A, 4.0, -4.0, 1.0)
        self.put(B, 4.0, -4.0, 1.03, roll=math.pi)          # face to face, 3 cm
        self.wait_for('A connected to B', lambda: (B, 'active', 'connected') in self.notes(A))
        self.wait_for('B connected to A', lambda: (A, 'active', 'connected') in self.notes(B))
        self.out[A].publish(NfcOutgoing(receiver=B, data=VCARD))
        self.wait_for('vCard at B', lambda: any(m.sender == A and m.data == VCARD
                                                for m in self.rec[B]['inc'].msgs))
        self.out[B].publish(NfcOutgoing(receiver=A, data='OK'))
        self.wait_for('OK at A', lambda: any(m.sender == B and m.data == 'OK'
                                             for m in self.rec[A]['inc'].msgs))
        self.out[B].publish(NfcOutgoing(receiver=A, data=VCARD))     # and the other way
        self.wait_for('vCard at A', lambda: any(m.sender == B and m.data == VCARD
                                                for m in self.rec[A]['inc'].msgs))
        self.out[A].publish(NfcOutgoing(receiver=B, data='OK'))
        self.wait_for('OK at B', lambda: any(m.sender == A and m.data == 'OK'
                                             for m in self.rec[B]['inc'].msgs))
        # 20 cm apart: both told
        self.put(B, 4.0, -4.0, 1.20, roll=math.pi)
        self.wait_for('A disconnected', lambda: self.notes(A)[-1] == (B, 'active',
                                                                      'disconnected'))
        self.wait_for('B disconnected', lambda: self.notes(B)[-1] == (A, 'active',
                                                                      'disconnected'))
        # outgoing without a partner: not delivered
        n = len(self.rec[B]['inc'].msgs)
        self.out[A].publish(NfcOutgoing(receiver=B, data='lost'))
        sim_sleep(0.5)
        self.assertEqual(len(self.rec[B]['inc'].msgs), n)

    def test_3_nfc_back_to_back_does_not_connect(self):
        self.put(B, 4.0, -4.0, 1.5)
        sim_sleep(0.3)
        na, nb = len(self.notes(A)), len(self.notes(B))
        self.put(A, 4.0, -4.0, 1.0, roll=math.pi)            # screen down
        self.put(B, 4.0, -4.0, 1.03)                         # screen up, 3 cm above
        sim_sleep(1.0)
        self.assertEqual(self.notes(A)[na:], [])
        self.assertEqual(self.notes(B)[nb:], [])

    # -- NFC tag -----------------------------------------------------------------------------
    def test_4_poster_read_by_active_not_passive(self):
        self.put(B, 5.0, -4.5, 1.5)
        # the poster hangs on the north wall at (2.2, 0.995, 1.3): screen towards it
        self.put(A, 2.2, 0.97, 1.3, roll=-math.pi / 2)
        self.wait_for('A read the poster', lambda: any(
            m.sender == 'nfc_poster' and m.data == 'U:http://vmi.lmt.ei.tum.de'
            for m in self.rec[A]['inc'].msgs))
        self.assertIn(('nfc_poster', 'passive', 'connected'), self.notes(A))
        self.put(A, 4.0, -1.0, 1.0)
        self.put(C, 2.2, 0.97, 1.3, roll=-math.pi / 2)
        sim_sleep(1.0)
        self.assertEqual(self.notes(C), [])
        self.assertEqual(self.rec[C]['inc'].msgs, [])


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'radio', Radio)
