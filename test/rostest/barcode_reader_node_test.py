#!/usr/bin/env python3
"""The barcode_reader node on its own (no world): ~image_topic and ~barcode_topic,
the 'QR-Code,<data>' and 'EAN-13,<data>' forms, ~throttle_repeated_barcodes, and a bad
encoding reported once on /rosout while the node keeps decoding."""
import os
import sys
import threading
import time
import unittest

import cv2
import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import Image
from std_msgs.msg import String

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'unit'))
from test_barcode import ean13_image  # noqa: E402
from simvid import qrassets  # noqa: E402
from simvid.imageconv import array_to_image  # noqa: E402

URL = 'QR-Code,' + qrassets.DEMO_URL


class BarcodeReaderNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.codes, cls.default_topic, cls.errors = [], [], []
        rospy.Subscriber('/codes', String, lambda m: cls._add(cls.codes, m.data))
        rospy.Subscriber('/barcode', String, lambda m: cls._add(cls.default_topic, m.data))
        rospy.Subscriber('/rosout', Log, cls._log, queue_size=100)
        cls.pub = rospy.Publisher('/cam/image', Image, queue_size=1)
        deadline = time.time() + 30
        while cls.pub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        paper = cv2.imread(os.path.join(qrassets.MEDIA_DIR, qrassets.PAPER_FILE))
        cls.paper = array_to_image(cv2.resize(paper, (420, 594)), 'bgr8')

    @classmethod
    def _add(cls, where, text):
        with cls.lock:
            where.append((time.time(), text))

    @classmethod
    def _log(cls, msg):
        if msg.level >= Log.ERROR and msg.name == '/barcode_reader':
            cls._add(cls.errors, msg.msg)

    def since(self, where, t, text=None):
        with self.lock:
            return [c for tt, c in where if tt >= t and (text is None or c == text)]

    def stream(self, msg, seconds, hz=10.0):
        end = time.time() + seconds
        while time.time() < end:
            self.pub.publish(msg)
            time.sleep(1.0 / hz)

    def test_1_qr_code_on_the_configured_topic_throttled(self):
        t = time.time()
        self.stream(self.paper, 3.4)        # 34 frames, throttle 1 s
        time.sleep(0.5)
        got = self.since(self.codes, t)
        self.assertTrue(got, 'nothing decoded')
        self.assertEqual(set(got), {URL})
        self.assertGreaterEqual(len(got), 2, got)    # published again after the window
        self.assertLessEqual(len(got), 5, got)       # but not once per frame
        self.assertEqual(self.since(self.default_topic, 0), [], '~barcode_topic ignored')

    def test_2_ean13(self):
        code, img = ean13_image('590123412345', module=3)
        t = time.time()
        self.stream(array_to_image(img, 'rgb8'), 1.0)
        time.sleep(0.5)
        self.assertIn('EAN-13,' + code, self.since(self.codes, t))

    def test_3_bad_encoding_once_then_decodes_again(self):
        t = time.time()
        bad = Image(height=10, width=10, encoding='yuv444_weird', step=30, data=bytes(300))
        self.stream(bad, 1.0)
        time.sleep(0.5)
        errors = self.since(self.errors, t)
        self.assertEqual(len(errors), 1, errors)
        self.assertIn('yuv444_weird', errors[0])
        t2 = time.time() + 1.1                  # past the throttle window of earlier codes
        time.sleep(1.2)
        self.stream(self.paper, 1.0)
        time.sleep(0.5)
        self.assertIn(URL, self.since(self.codes, t2))


if __name__ == '__main__':
    rospy.init_node('barcode_reader_node_test')
    rostest.rosrun('mobile_device_sim', 'barcode_reader_node', BarcodeReaderNode, sys.argv)
