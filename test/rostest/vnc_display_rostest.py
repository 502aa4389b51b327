#!/usr/bin/env python3
"""rostest: a real VNC screen on the phone's virtual display, seen by a sim camera.

The test starts Xtigervnc (640x320, the display's aspect), shows a QR code on it, and
waits until barcode_reader, fed by the camera filming the phone's display, decodes that
code; then the VNC screen changes to another code and the new payload must follow."""
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from std_msgs.msg import String

from simvid import qrassets
from vnc_image_client.testserver import XVncServer

PKG = 'mobile_device_sim'
W, H = 640, 320


def screen_with_qr(data):
    qr = qrassets.qr_image(data, module_px=8)
    rgb = np.full((H, W, 3), 255, np.uint8)
    h, w = qr.shape
    top, left = (H - h) // 2, (W - w) // 2
    rgb[top:top + h, left:left + w] = qr[:, :, None]
    return rgb


class VncOnDisplay(unittest.TestCase):
    def setUp(self):
        rospy.init_node('vnc_display_rostest')
        self.lock = threading.Lock()
        self.codes = []
        rospy.Subscriber('/barcode', String, self._code, queue_size=100)
        self.server = XVncServer(W, H, port=int(rospy.get_param('~port'))).start()

    def tearDown(self):
        self.server.cleanup()

    def _code(self, m):
        with self.lock:
            self.codes.append((time.time(), m.data))

    def wait_code(self, text, since, timeout):
        deadline = time.time() + timeout
        while time.time() < deadline:
            with self.lock:
                seen = [c for t, c in self.codes if t >= since]
            if text in seen:
                return seen
            time.sleep(0.1)
        self.fail('%r not on /barcode within %.0f s (seen: %r)' % (text, timeout, seen[-5:]))

    def test_vnc_screen_seen_by_camera(self):
        t0 = time.time()
        self.server.show(screen_with_qr('vnc screen one'))
        self.wait_code('QR-Code,vnc screen one', t0, 120)
        t1 = time.time()
        self.server.show(screen_with_qr('vnc screen two'))
        seen = self.wait_code('QR-Code,vnc screen two', t1, 60)
        # once the new screen is decoded, the old one is gone
        time.sleep(2.0)
        with self.lock:
            later = [c for t, c in self.codes if t > time.time() - 1.0]
        self.assertNotIn('QR-Code,vnc screen one', later)
        self.assertIn('QR-Code,vnc screen two', seen)


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vnc_display_rostest', VncOnDisplay)
