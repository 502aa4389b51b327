#!/usr/bin/env python3
"""rostest: the pcl2image node. A coloured point lands on the pixel the pinhole model
predicts; a plane fills its projected rectangle; an unsupported cloud gives one clear
/rosout error and the node keeps rendering the next good cloud; a geometry_msgs/Pose on
~viewpoint moves the virtual camera and re-renders."""
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Pose
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import Image, PointCloud2, PointField

from kinect4skype.cloud import arrays_to_cloud

PKG = 'mobile_device_sim'
W, H = 160, 120
F = W / (2 * math.tan(math.radians(60) / 2))
CX, CY = (W - 1) / 2.0, (H - 1) / 2.0


def px(x, y, z):
    return int(round(F * x / z + CX)), int(round(F * y / z + CY))


class Pcl2ImageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('pcl2image_rostest')
        cls.lock = threading.Lock()
        cls.images = []
        cls.logs = []
        cls.sub = rospy.Subscriber('/test_cloud_image', Image, cls._img, queue_size=10)
        rospy.Subscriber('/rosout', Log, cls._log, queue_size=100)
        cls.pub = rospy.Publisher('/test_cloud', PointCloud2, queue_size=1, latch=True)
        cls.vp = rospy.Publisher('/pcl2image/viewpoint', Pose, queue_size=1, latch=True)
        deadline = time.monotonic() + 30
        while (cls.pub.get_num_connections() == 0 or cls.sub.get_num_connections() == 0) \
                and time.monotonic() < deadline:
            time.sleep(0.1)

    @classmethod
    def _img(cls, m):
        with cls.lock:
            cls.images.append(m)

    @classmethod
    def _log(cls, m):
        with cls.lock:
            cls.logs.append(m)

    def send(self, msg, timeout=10.0):
        with self.lock:
            n = len(self.images)
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = 'test_optical'
        self.pub.publish(msg)
        return self.wait_image(n, timeout)

    def wait_image(self, n, timeout=10.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with self.lock:
                if len(self.images) > n:
                    m = self.images[-1]
                    self.assertEqual((m.encoding, m.width, m.height), ('rgb8', W, H))
                    return np.frombuffer(m.data, np.uint8).reshape(H, W, 3)
            time.sleep(0.02)
        return None

    def test_1_point_on_expected_pixel(self):
        img = self.send(arrays_to_cloud(np.array([[0.3, 0.2, 1.5]], np.float32),
                                        np.array([[250, 20, 120]], np.uint8)))
        self.assertIsNotNone(img, 'no image from pcl2image')
        u, v = px(0.3, 0.2, 1.5)
        hits = np.argwhere(img.any(axis=2))
        self.assertEqual([tuple(h) for h in hits], [(v, u)])
        self.assertEqual(img[v, u].tolist(), [250, 20, 120])
        with self.lock:
            self.assertEqual(self.images[-1].header.frame_id, 'test_optical')

    def test_2_plane_fills_region(self):
        xs, ys = np.meshgrid(np.arange(-0.4, 0.4001, 0.0015), np.arange(-0.3, 0.3001, 0.0015))
        xyz = np.c_[xs.ravel(), ys.ravel(), np.full(xs.size, 2.0)].astype(np.float32)
        img = self.send(arrays_to_cloud(xyz))          # no rgb: depth colour map
        self.assertIsNotNone(img)
        (u0, v0), (u1, v1) = px(-0.4, -0.3, 2.0), px(0.4, 0.3, 2.0)
        filled = img.any(axis=2)
        self.assertTrue(filled[v0 + 1:v1, u0 + 1:u1].all())
        out = filled.copy()
        out[v0 - 1:v1 + 2, u0 - 1:u1 + 2] = False
        self.assertFalse(out.any())

    def test_3_unsupported_cloud_reported_node_keeps_running(self):
        bad = PointCloud2()
        bad.height, bad.width, bad.point_step, bad.row_step = 1, 2, 8, 16
        bad.fields = [PointField(name='x', offset=0, datatype=PointField.FLOAT32, count=1),
                      PointField(name='intensity', offset=4, datatype=PointField.FLOAT32, count=1)]
        bad.data = b'\0' * 16
        for _ in range(3):
            self.assertIsNone(self.send(bad, timeout=1.0))
        time.sleep(0.5)
        with self.lock:
            errs = [l for l in self.logs if l.name == '/pcl2image' and l.level == Log.ERROR]
        self.assertEqual(len(errs), 1, [e.msg for e in errs])
        self.assertIn('no y/z field', errs[0].msg)
        img = self.send(arrays_to_cloud(np.array([[0.0, 0.0, 1.0]], np.float32),
                                        np.array([[1, 255, 1]], np.uint8)))
        self.assertIsNotNone(img, 'pcl2image stopped after a bad cloud')
        self.assertEqual(img[int(round(CY)), int(round(CX))].tolist(), [1, 255, 1])

    def test_4_viewpoint_topic(self):
        img = self.send(arrays_to_cloud(np.array([[0.0, 0.0, 2.0]], np.float32),
                                        np.array([[200, 200, 0]], np.uint8)))
        self.assertIsNotNone(img)
        with self.lock:
            n = len(self.images)
        p = Pose()
        p.position.y = 0.4            # camera 0.4 m down (optical y): the point moves up
        p.orientation.w = 1.0
        self.vp.publish(p)
        img = self.wait_image(n)
        self.assertIsNotNone(img, 'no re-render after a viewpoint change')
        u, v = px(0.0, -0.4, 2.0)
        self.assertEqual(img[v, u].tolist(), [200, 200, 0])


if __name__ == '__main__':
    rostest.rosrun(PKG, 'pcl2image_rostest', Pcl2ImageTest)
