#!/usr/bin/env python3
"""Bad input to the video texture: an unknown encoding, a missing file, an unreadable
file, a model whose video plugin lacks bodyName or names a wrong link. Each gets one clear
error line on /rosout, the world keeps running (clock, camera), the display keeps its last
image (the camera filming it still decodes the code), and the broken models still load."""
import os
import sys
import tempfile
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose
from sensor_msgs.msg import Image
from std_msgs.msg import String

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from textvid_common import PAYLOAD, Watch, connected, screen_image  # noqa: E402
from mobile_device_sim.srv import GetModelState, SpawnModel  # noqa: E402

QR_PAYLOAD = 'QR-Code,' + PAYLOAD

# 2011 syntax (thesis appendix A); the first controller has no bodyName, the second names
# a link the model does not have, the model itself is fine.
BROKEN_URDF = '''<?xml version="1.0"?>
<robot name="%(name)s" xmlns:controller="http://playerstage.sourceforge.net/gazebo/xmlschema/#controller">
  <link name="base">
    <inertial><mass value="0.1"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
    <visual><geometry><box size="0.1 0.05 0.01"/></geometry></visual>
  </link>
  <gazebo>
    <controller:gazebo_ros_video name="video" plugin="libgazebo_ros_video.so">
      %(body)s
      <imageTopic>/%(name)s/image_in</imageTopic>
    </controller:gazebo_ros_video>
  </gazebo>
  <gazebo><turnGravityOff>true</turnGravityOff></gazebo>
</robot>'''


class BadInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.w = w = Watch()
        cls.image_in = rospy.Publisher('/phone/image_in', Image, queue_size=10)
        cls.load_file = rospy.Publisher('/phone/load_file', String, queue_size=10)
        w.wait(lambda: w.frame, 90, 'the first image of the screen camera')
        connected(cls.image_in).publish(screen_image('bgr8'))
        w.wait(lambda: w.codes_since(0, QR_PAYLOAD), 30, QR_PAYLOAD + ' on /barcode')
        connected(cls.load_file)

    def still_serving(self, t, what):
        """After wall time t: the clock moves, the camera renders and the display still
        shows the code (fresh /barcode messages; the reader throttles to 2 per second)."""
        w = self.w
        c0 = w.clock
        w.wait(lambda: w.clock > c0, 20, 'sim time to go on after %s' % what)
        w.wait(lambda: len(w.codes_since(t + 0.2, QR_PAYLOAD)) >= 2, 20,
               'the code on /barcode after %s' % what)
        self.assertIn(('QR-Code', PAYLOAD), w.decoded_after(time.time()))

    def one_error(self, t, needle, what):
        w = self.w
        got = w.wait(lambda: w.errors_since(t, needle), 20, 'an error line about ' + what)
        time.sleep(1.0)
        got = w.errors_since(t, needle)
        self.assertEqual(len(got), 1, 'expected one error line about %s: %s' % (what, got))
        return got[0]

    def test_unknown_encoding(self):
        t = time.time()
        bad = Image(height=800, width=480, encoding='16UC1', step=960, data=bytes(960 * 800))
        self.image_in.publish(bad)
        node, text = self.one_error(t, "'16UC1'", 'the 16UC1 image')
        self.assertEqual(node, '/sim_world')
        self.assertIn('phone/mobile_display', text)
        self.assertIn('keeping the last image', text)
        self.still_serving(t, 'the 16UC1 image')

    def test_truncated_image(self):
        t = time.time()
        self.image_in.publish(Image(height=800, width=480, encoding='rgb8', step=1440,
                                    data=bytes(1000)))
        self.one_error(t, '1000 bytes', 'the truncated image')
        self.still_serving(t, 'the truncated image')

    def test_missing_file(self):
        t = time.time()
        path = '/nonexistent/textvid/no_such_picture.png'
        self.load_file.publish(String(data=path))
        node, text = self.one_error(t, path, 'the missing file')
        self.assertIn('does not exist', text)
        self.still_serving(t, 'the missing file')

    def test_unreadable_file(self):
        fd, path = tempfile.mkstemp(suffix='.png')
        os.write(fd, b'\x89PNG but then nothing that a decoder would accept')
        os.close(fd)
        try:
            t = time.time()
            self.load_file.publish(String(data=path))
            node, text = self.one_error(t, path, 'the unreadable file')
            self.assertIn('cannot read', text)
            self.still_serving(t, 'the unreadable file')
        finally:
            os.unlink(path)

    def test_plugin_without_body_name_or_with_a_wrong_one(self):
        rospy.wait_for_service('/gazebo/spawn_urdf_model', 30)
        spawn = rospy.ServiceProxy('/gazebo/spawn_urdf_model', SpawnModel)
        get = rospy.ServiceProxy('/gazebo/get_model_state', GetModelState)
        for name, body, needle in (('nobody', '', 'bodyName'),
                                   ('wrongbody', '<bodyName>screen</bodyName>', "'screen'")):
            t = time.time()
            pose = Pose()
            pose.position.x, pose.position.z = 2.0, 0.5 + len(name) * 0.1
            pose.orientation.w = 1.0
            res = spawn(name, BROKEN_URDF % {'name': name, 'body': body}, '', pose, '')
            self.assertTrue(res.success, res.status_message)
            node, text = self.one_error(t, needle, 'the video plugin of %s' % name)
            self.assertIn(name, text)
            self.assertIn('libgazebo_ros_video.so', text)
            self.assertTrue(get(name, '').success, 'model %s did not load' % name)
            self.still_serving(t, 'spawning %s' % name)


if __name__ == '__main__':
    rospy.init_node('textvid_bad_input_test')
    rostest.rosrun('mobile_device_sim', 'textvid_bad_input', BadInput, sys.argv)
