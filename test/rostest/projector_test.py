#!/usr/bin/env python3
"""rostest: a picture on the phone's projector/image seen by the flycam (projector.test)."""
import subprocess
import time
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Image
from geometry_msgs.msg import Point, Pose, Quaternion, Twist

from mobile_device_sim.msg import ModelState
from mobile_device_sim.srv import SetModelState


def quat(roll, pitch, yaw):
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return Quaternion(x=sr * cp * cy - cr * sp * sy, y=cr * sp * cy + sr * cp * sy,
                      z=cr * cp * sy - sr * sp * cy, w=cr * cp * cy + sr * sp * sy)


def frame_after(sim_dt, timeout=120):
    """The first flycam frame stamped at least sim_dt after now (HxWx3 int)."""
    t_min = rospy.get_time() + sim_dt
    deadline = time.time() + timeout
    while time.time() < deadline:
        m = rospy.wait_for_message('/flycam/image_raw', Image, timeout=timeout)
        if m.header.stamp.to_sec() >= t_min:
            img = np.frombuffer(m.data, np.uint8).reshape(m.height, m.step)
            img = img[:, :m.width * 3].reshape(m.height, m.width, 3).astype(int)
            return img[:, :, ::-1] if m.encoding == 'bgr8' else img
    raise AssertionError('no flycam frame')


class ProjectorTest(unittest.TestCase):
    def test_picture_on_and_off_in_the_flycam(self):
        rospy.init_node('projector_test')
        pub = rospy.Publisher('/mobile_device/projector/image', Image, queue_size=1,
                              latch=True)
        deadline = time.time() + 60
        while time.time() < deadline and pub.get_num_connections() == 0:
            time.sleep(0.1)
        # held 0.2 m over the desk (the phone floats), top edge tilted down toward the paper
        rospy.wait_for_service('/gazebo/set_model_state', timeout=60)
        r = rospy.ServiceProxy('/gazebo/set_model_state', SetModelState)(ModelState(
            model_name='mobile_device', reference_frame='world', twist=Twist(),
            pose=Pose(position=Point(x=3.288, y=-2.11, z=1.2), orientation=quat(0, 1.2, 1.15))))
        self.assertTrue(r.success, r.status_message)
        off0 = frame_after(0.5)
        green = np.zeros((120, 160, 3), np.uint8)
        green[:, :, 1] = 255
        pub.publish(Image(height=120, width=160, encoding='rgb8', step=480,
                          data=green.tobytes()))
        on = frame_after(0.5)
        d = on - off0
        lit = (d[:, :, 1] > 30) & (np.abs(d[:, :, 0]) < 10)
        rospy.loginfo('projector: %d flycam pixels turned green', lit.sum())
        self.assertGreater(lit.sum(), 100)
        out = subprocess.run(['rostopic', 'pub', '-1', '/mobile_device/projector/enable',
                              'std_msgs/Bool', 'data: false'], timeout=60)
        self.assertEqual(out.returncode, 0)
        off = frame_after(0.5)
        self.assertLess(((off - off0)[:, :, 1] > 30).sum(), 5)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'projector', ProjectorTest)
