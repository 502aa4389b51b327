#!/usr/bin/env python3
"""rostest: kinect4skype.launch's chain. The flycam's sim camera cloud rendered by pcl2image
from the camera's own viewpoint reproduces the camera's image (same pinhole model, dense
cloud), and the world's video texture (the phone display) subscribes to the result."""
import unittest

import numpy as np
import rosgraph
import rospy
import rostest
from sensor_msgs.msg import Image

from simvid.imageconv import image_to_rgb

PKG = 'mobile_device_sim'


class Chain(unittest.TestCase):
    def test_chain(self):
        rospy.init_node('pcl2image_chain_rostest')
        rendered = rospy.wait_for_message('/kinect4skype/image', Image, 150)
        for _ in range(3):   # let the world settle (the phone is spawned after the world)
            rendered = rospy.wait_for_message('/kinect4skype/image', Image, 30)
        cam = rospy.wait_for_message('/flycam/image_raw', Image, 30)
        a, b = image_to_rgb(rendered).astype(int), image_to_rgb(cam).astype(int)
        self.assertEqual(a.shape, b.shape)
        self.assertEqual(rendered.header.frame_id, 'flycam_optical_frame')
        drawn = a.any(axis=2)
        self.assertGreater(drawn.mean(), 0.95, 'the room cloud should cover the image')
        diff = np.abs(a - b).mean(axis=2)
        close = (diff[drawn] < 30).mean()
        self.assertGreater(close, 0.9, 'render differs from the camera image '
                                       '(%.3f of pixels close)' % close)
        state = rosgraph.Master(rospy.get_name()).getSystemState()
        subs = dict((t, n) for t, n in state[1])
        self.assertIn('/sim_world', subs.get('/kinect4skype/image', []))


if __name__ == '__main__':
    rostest.rosrun(PKG, 'pcl2image_chain_rostest', Chain)
