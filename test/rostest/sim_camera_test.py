#!/usr/bin/env python3
"""rostest: the sim camera plugin in sim_world (see sim_camera.test)."""
import math
import sys
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Pose as PoseMsg
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from std_msgs.msg import Float64

from mobile_device_sim.srv import SpawnModel
from simvid.imageconv import image_to_rgb
from sim_world.transforms import Pose

# paper top surface (office.world): centre (3.32, -2.10), z = 0.75025 + 0.00025
PAPER = (3.32, -2.10, 0.7505)
HEIGHT = 0.40            # camera above the paper
D = [-0.12, 0.02, 0.0005, -0.0003, 0.0]

CAMERA = '''<?xml version="1.0"?>
<robot name="test_cam">
  <link name="cam_link">
    <inertial><mass value="0.1"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
  </link>
  <gazebo reference="cam_link">
    <gravity>false</gravity>
    <sensor type="camera" name="sensor">
      <update_rate>20</update_rate>
      <camera><horizontal_fov>0.9</horizontal_fov>
        <image><width>160</width><height>120</height></image>
        <clip><near>0.02</near><far>20</far></clip></camera>
      <plugin name="controller" filename="libgazebo_ros_camera.so">
        <robotNamespace>test_cam</robotNamespace>
        <frameName>test_cam_optical</frameName>
        <distortionK1>%g</distortionK1><distortionK2>%g</distortionK2>
        <distortionT1>%g</distortionT1><distortionT2>%g</distortionT2>
        <distortionK3>%g</distortionK3>
      </plugin>
    </sensor>
  </gazebo>
</robot>
''' % tuple(D)


class SimCamera(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('sim_camera_test')
        cls.errors = []
        # every node publishes its log lines on /rosout (rosout itself may not run)
        rospy.Subscriber('/rosout', Log, cls._log, queue_size=100)
        rospy.wait_for_service('/gazebo/spawn_urdf_model', timeout=60)
        spawn = rospy.ServiceProxy('/gazebo/spawn_urdf_model', SpawnModel)
        pose = Pose.from_xyz_rpy((PAPER[0], PAPER[1], PAPER[2] + HEIGHT), (0, math.pi / 2, 0))
        res = spawn(model_name='test_cam', model_xml=CAMERA, robot_namespace='',
                    initial_pose=pose.to_msg(PoseMsg()), reference_frame='world')
        assert res.success, res.status_message
        cls.images, cls.infos = [], []
        rospy.Subscriber('/test_cam/image_raw', Image, cls.images.append, queue_size=100)
        rospy.Subscriber('/test_cam/camera_info', CameraInfo, cls.infos.append, queue_size=100)

    @classmethod
    def _log(cls, msg):
        if msg.level >= Log.ERROR and msg.name == '/sim_world':
            cls.errors.append(msg.msg)

    def frames(self, n, timeout=60):
        start = len(self.images)
        deadline = time.time() + timeout
        while len(self.images) < start + n and time.time() < deadline:
            time.sleep(0.05)
        self.assertGreaterEqual(len(self.images), start + n, 'camera stopped publishing')
        return self.images[start:start + n]

    def test_1_info_matches_image_and_urdf(self):
        imgs = self.frames(5)
        # camera_info comes on its own connection: the last images' may land a moment after
        # them (a fresh clone of 2026-12-06 saw the fifth image before its info)
        deadline = time.time() + 10
        while time.time() < deadline and not all(
                im.header.stamp in {i.header.stamp for i in list(self.infos)} for im in imgs):
            time.sleep(0.05)
        infos = {i.header.stamp: i for i in list(self.infos)}
        f = 160 / (2 * math.tan(0.45))
        for im in imgs:
            self.assertEqual((im.width, im.height, im.encoding), (160, 120, 'rgb8'))
            self.assertEqual(im.header.frame_id, 'test_cam_optical')
            self.assertIn(im.header.stamp, infos)
            info = infos[im.header.stamp]
            self.assertEqual(list(info.D), D)
            self.assertAlmostEqual(info.K[0], f, places=3)
            self.assertAlmostEqual(info.K[2], 79.5, places=6)
        # 20 Hz of sim time: stamps 0.05 s apart (rounded to the 1 ms physics step)
        st = [im.header.stamp.to_sec() for im in imgs]
        for a, b in zip(st, st[1:]):
            self.assertAlmostEqual(b - a, 0.05, delta=0.0011)

    def test_2_points_follow_the_image(self):
        cloud = rospy.wait_for_message('/test_cam/points', PointCloud2, timeout=60)
        self.assertEqual((cloud.width, cloud.height, cloud.point_step), (160, 120, 16))
        self.assertEqual([f.name for f in cloud.fields], ['x', 'y', 'z', 'rgb'])
        self.assertEqual(cloud.header.frame_id, 'test_cam_optical')
        pts = np.frombuffer(cloud.data, np.float32).reshape(120, 160, 4)
        # the paper/desk plane is HEIGHT under the camera, seen straight down
        z = pts[50:70, 70:90, 2]
        self.assertTrue(np.all(np.abs(z - HEIGHT) < 0.005), z)
        # x grows to the right, y downwards (optical frame)
        self.assertGreater(pts[60, 150, 0], 0.0)
        self.assertLess(pts[60, 10, 0], 0.0)
        self.assertGreater(pts[110, 80, 1], 0.0)
        # the colours are those of the image with the same stamp
        # (the image and the cloud come over two connections: the image of that stamp may
        # arrive after the cloud, more so on a loaded machine)
        img, deadline = None, time.time() + 10
        while img is None and time.time() < deadline:
            img = next((i for i in reversed(self.images)
                        if i.header.stamp == cloud.header.stamp), None)
            if img is None:
                time.sleep(0.02)
        self.assertIsNotNone(img, 'no image stamped %s' % cloud.header.stamp.to_sec())
        rgb = image_to_rgb(img)
        packed = pts[:, :, 3].copy().view(np.uint32)
        self.assertTrue(np.array_equal((packed >> 16) & 255, rgb[:, :, 0]))
        self.assertTrue(np.array_equal(packed & 255, rgb[:, :, 2]))

    def test_3_set_update_rate_in_sim_time(self):
        pub = rospy.Publisher('/test_cam/set_update_rate', Float64, queue_size=1, latch=True)
        pub.publish(Float64(10.0))
        deadline = time.time() + 60
        while time.time() < deadline:
            imgs = self.frames(4)
            st = [im.header.stamp.to_sec() for im in imgs]
            if all(abs((b - a) - 0.1) < 0.0011 for a, b in zip(st, st[1:])):
                break
        else:
            self.fail('stamps never 0.1 s apart after set_update_rate 10: %s' % st)
        pub.publish(Float64(20.0))

    def test_4_bad_values_are_refused_and_camera_keeps_publishing(self):
        before = self.frames(1)[0]
        f0 = [i for i in self.infos if i.header.stamp == before.header.stamp][0].K[0]
        n_err = len(self.errors)
        hfov = rospy.Publisher('/test_cam/set_hfov', Float64, queue_size=1, latch=True)
        rate = rospy.Publisher('/test_cam/set_update_rate', Float64, queue_size=1, latch=True)
        time.sleep(1.0)
        hfov.publish(Float64(-1.0))
        rate.publish(Float64(-5.0))
        deadline = time.time() + 30
        while len(self.errors) < n_err + 2 and time.time() < deadline:
            time.sleep(0.1)
        new = self.errors[n_err:]
        self.assertTrue(any('set_hfov' in e for e in new), new)
        self.assertTrue(any('set_update_rate' in e for e in new), new)
        later = self.frames(3)
        info = [i for i in self.infos if i.header.stamp == later[-1].header.stamp][0]
        self.assertAlmostEqual(info.K[0], f0, places=6)
        # and a good value after the bad ones still works
        hfov.publish(Float64(0.5))
        deadline = time.time() + 30
        f1 = 160 / (2 * math.tan(0.25))
        while time.time() < deadline:
            self.frames(1)
            if abs(self.infos[-1].K[0] - f1) < 1e-3:
                break
        self.assertAlmostEqual(self.infos[-1].K[0], f1, places=3)

    def test_5_faults_through_set_sensor_fault(self):
        """/gazebo/set_sensor_fault finds the camera by its library name or a topic:
        drop silences image and camera_info, freeze repeats the last frame with new stamps,
        noise is refused (no <noise>), none brings it back."""
        from mobile_device_sim.srv import SetSensorFault
        rospy.wait_for_service('/gazebo/set_sensor_fault', timeout=30)
        fault = rospy.ServiceProxy('/gazebo/set_sensor_fault', SetSensorFault)
        self.frames(1)
        res = fault(model_name='test_cam', sensor='libgazebo_ros_camera.so', fault='drop')
        self.assertTrue(res.success, res.status_message)
        time.sleep(1.0)                           # frames in flight arrive
        n_img, n_info = len(self.images), len(self.infos)
        time.sleep(2.0)
        self.assertEqual((len(self.images), len(self.infos)), (n_img, n_info))
        res = fault(model_name='test_cam', sensor='/test_cam/camera_info', fault='freeze')
        self.assertTrue(res.success, res.status_message)
        imgs = self.frames(4)
        self.assertEqual(len({bytes(i.data) for i in imgs}), 1)
        st = [i.header.stamp.to_sec() for i in imgs]
        self.assertEqual(st, sorted(set(st)))
        res = fault(model_name='test_cam', sensor='image_raw', fault='noise', value=3.0)
        self.assertFalse(res.success)
        self.assertIn('no noise', res.status_message)
        res = fault(model_name='test_cam', sensor='controller', fault='none')
        self.assertTrue(res.success, res.status_message)
        self.frames(2)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'sim_camera', SimCamera, sys.argv)
