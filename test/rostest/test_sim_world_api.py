#!/usr/bin/env python3
"""rostest: the Gazebo-compatible API of sim_world, with a real roscore.

Run by sim_world_ode.test and sim_world_bullet.test (param ~physics names the engine).
"""
import math
import os
import subprocess
import sys
import time
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Pose as PoseMsg
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, Joy
from std_srvs.srv import Empty

from mobile_device_sim.msg import ModelState, ModelStates
from mobile_device_sim.srv import DeleteModel, GetModelState, SetModelState, SpawnModel

PHONE_SPAWN = (3.288, -2.11, 1.0)
BOX_URDF = '''<robot name="box"><link name="box_link">
  <inertial><mass value="1.0"/><inertia ixx="0.0017" ixy="0" ixz="0" iyy="0.0017" iyz="0" izz="0.0017"/></inertial>
  <visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>
  <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link></robot>'''


def pose(x, y, z, qx=0.0, qy=0.0, qz=0.0, qw=1.0):
    p = PoseMsg()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = qx, qy, qz, qw
    return p


class SimWorldApi(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_sim_world_api')
        for s in ('/gazebo/get_model_state', '/gazebo/set_model_state',
                  '/gazebo/spawn_urdf_model', '/gazebo/delete_model'):
            rospy.wait_for_service(s, timeout=60)
        cls.get = rospy.ServiceProxy('/gazebo/get_model_state', GetModelState)
        cls.set = rospy.ServiceProxy('/gazebo/set_model_state', SetModelState)
        cls.spawn = rospy.ServiceProxy('/gazebo/spawn_urdf_model', SpawnModel)
        cls.spawn_sdf = rospy.ServiceProxy('/gazebo/spawn_sdf_model', SpawnModel)
        cls.delete = rospy.ServiceProxy('/gazebo/delete_model', DeleteModel)
        # wait until the launch file's spawners have put the phone and the flycam in
        deadline = time.time() + 60
        while time.time() < deadline:
            if cls.get('mobile_device', 'world').success and cls.get('flycam', 'world').success:
                break
            time.sleep(0.2)

    def sim_sleep(self, seconds):
        """Wait for `seconds` of sim time, by /clock."""
        start = rospy.wait_for_message('/clock', Clock, timeout=30).clock.to_sec()
        deadline = time.time() + 120
        while time.time() < deadline:
            now = rospy.wait_for_message('/clock', Clock, timeout=30).clock.to_sec()
            if now - start >= seconds:
                return now
        self.fail('sim time did not advance by %g s' % seconds)

    # -- the thesis's console output 3.3.1 -----------------------------------------------
    def test_thesis_get_model_state(self):
        res = self.get(model_name='mobile_device', relative_entity_name='world')
        self.assertTrue(res.success, res.status_message)
        self.assertEqual(res.status_message, 'GetModelState: got properties')
        p = res.pose.position
        # the phone floats (turnGravityOff): it stays where it was spawned
        self.assertAlmostEqual(p.x, PHONE_SPAWN[0], places=3)
        self.assertAlmostEqual(p.y, PHONE_SPAWN[1], places=3)
        self.assertAlmostEqual(p.z, PHONE_SPAWN[2], places=3)
        self.assertAlmostEqual(res.pose.orientation.w, 1.0, places=4)

    def test_relative_entity(self):
        res = self.get('mobile_device', 'paper')
        self.assertTrue(res.success, res.status_message)
        self.assertAlmostEqual(res.pose.position.z, 1.0 - 0.75025, places=3)
        res = self.get('mobile_device', 'desk::top')
        self.assertTrue(res.success, res.status_message)
        self.assertAlmostEqual(res.pose.position.z, 1.0 - 0.735, places=3)

    def test_clock_advances(self):
        a = rospy.wait_for_message('/clock', Clock, timeout=10).clock
        time.sleep(1.0)
        b = rospy.wait_for_message('/clock', Clock, timeout=10).clock
        self.assertGreater((b - a).to_sec(), 0.05)
        self.assertTrue(rospy.get_param('/use_sim_time'))

    def test_set_then_get_round_trip(self):
        s = math.sin(0.3)
        c = math.cos(0.3)
        st = ModelState(model_name='flycam', pose=pose(1.0, 2.0, 1.5, 0, 0, s, c),
                        reference_frame='world')
        res = self.set(st)
        self.assertTrue(res.success, res.status_message)
        got = self.get('flycam', 'world')
        self.assertTrue(got.success)
        self.assertAlmostEqual(got.pose.position.x, 1.0, places=3)
        self.assertAlmostEqual(got.pose.position.y, 2.0, places=3)
        self.assertAlmostEqual(got.pose.position.z, 1.5, places=3)
        self.assertAlmostEqual(abs(got.pose.orientation.z), s, places=4)
        # relative to another model: set in the desk's frame, read in the desk's frame
        st = ModelState(model_name='flycam', pose=pose(0.1, 0.2, 0.6), reference_frame='desk')
        self.assertTrue(self.set(st).success)
        rel = self.get('flycam', 'desk')
        self.assertAlmostEqual(rel.pose.position.x, 0.1, places=3)
        self.assertAlmostEqual(rel.pose.position.z, 0.6, places=3)
        w = self.get('flycam', 'world')
        self.assertAlmostEqual(w.pose.position.x, 3.32 + 0.1, places=3)
        self.assertAlmostEqual(w.pose.position.z, 0.735 + 0.6, places=3)
        # the topic interface does the same
        pub = rospy.Publisher('/gazebo/set_model_state', ModelState, queue_size=1, latch=True)
        pub.publish(ModelState(model_name='flycam', pose=pose(2.0, -1.0, 1.2),
                               reference_frame='world'))
        deadline = time.time() + 10
        while time.time() < deadline:
            if abs(self.get('flycam', 'world').pose.position.x - 2.0) < 1e-3:
                break
            time.sleep(0.1)
        self.assertAlmostEqual(self.get('flycam', 'world').pose.position.x, 2.0, places=3)
        pub.unregister()

    def test_spawn_fall_delete(self):
        req = dict(model_name='falling_box', model_xml=BOX_URDF, robot_namespace='',
                   initial_pose=pose(1.5, 0.5, 1.0), reference_frame='world')
        res = self.spawn(**req)
        self.assertTrue(res.success, res.status_message)
        # the same name again is refused
        again = self.spawn(**req)
        self.assertFalse(again.success)
        self.assertIn('already exists', again.status_message)
        self.sim_sleep(1.5)
        z = self.get('falling_box', 'world').pose.position.z
        self.assertAlmostEqual(z, 0.05, delta=0.01)    # fell 1 m and rests on the floor
        names = rospy.wait_for_message('/gazebo/model_states', ModelStates, timeout=10).name
        self.assertIn('falling_box', names)
        self.assertIn('mobile_device', names)
        res = self.delete('falling_box')
        self.assertTrue(res.success, res.status_message)
        res = self.get('falling_box', 'world')
        self.assertFalse(res.success)
        self.assertFalse(self.delete('falling_box').success)

    def test_spawn_sdf(self):
        sdf = ('<sdf version="1.6"><model name="ball"><link name="l"><collision name="c">'
               '<geometry><sphere><radius>0.05</radius></sphere></geometry></collision>'
               '<inertial><mass>0.2</mass></inertial></link></model></sdf>')
        res = self.spawn_sdf('ball', sdf, '', pose(5.0, 0.0, 0.05), 'world')
        self.assertTrue(res.success, res.status_message)
        self.assertTrue(self.delete('ball').success)

    def test_tf_of_phone_links(self):
        buf = tf2_ros.Buffer()
        tf2_ros.TransformListener(buf)
        t = buf.lookup_transform('world', 'mobile_camera_unit', rospy.Time(0),
                                 rospy.Duration(20))
        self.assertAlmostEqual(t.transform.translation.x, PHONE_SPAWN[0] + 0.032, places=3)
        self.assertAlmostEqual(t.transform.translation.z, PHONE_SPAWN[2] - 0.00544 - 0.00025,
                               places=3)
        # the images' frame (REP 103): /tf_static carries the optical joint; optical z (the
        # view direction) is the camera unit's +x, i.e. out of the phone's back (world -z)
        o = buf.lookup_transform('mobile_camera_unit', 'mobile_camera_optical_frame',
                                 rospy.Time(0), rospy.Duration(20))
        q = o.transform.rotation
        x, y, z, w = q.x, q.y, q.z, q.w
        # columns of the rotation matrix: optical x, y, z in the camera unit's frame
        zc = (2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y))
        xc = (1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w))
        for a, b in zip(zc, (1, 0, 0)):
            self.assertAlmostEqual(a, b, places=6)
        for a, b in zip(xc, (0, -1, 0)):
            self.assertAlmostEqual(a, b, places=6)
        flycam = buf.lookup_transform('flycam_link', 'flycam_optical_frame', rospy.Time(0),
                                      rospy.Duration(20))
        self.assertAlmostEqual(abs(flycam.transform.rotation.w), 0.5, places=6)

    def test_camera_move_moves_along_own_axes(self):
        # flycam yawed 90 degrees: its forward axis is the world's +y
        q = (0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4))
        self.assertTrue(self.set(ModelState(model_name='flycam', pose=pose(4.0, -1.0, 1.0, *q),
                                            reference_frame='world')).success)
        pub = rospy.Publisher('/test/joy', Joy, queue_size=10)
        deadline = time.time() + 20
        while pub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.1)
        for _ in range(10):   # 10 messages of x = 50 / linear_scaler 100 = 0.5 m each
            pub.publish(Joy(axes=[50.0, 0, 0, 0, 0, 0]))
            time.sleep(0.2)
        deadline = time.time() + 10
        while time.time() < deadline:
            p = self.get('flycam', 'world').pose.position
            if p.y > -1.0 + 4.9:
                break
            time.sleep(0.2)
        p = self.get('flycam', 'world').pose.position
        self.assertAlmostEqual(p.x, 4.0, places=2)
        self.assertAlmostEqual(p.y, -1.0 + 5.0, places=2)
        self.assertAlmostEqual(p.z, 1.0, places=2)
        pub.publish(Joy(axes=[0.0] * 6))    # zero messages do not move it
        time.sleep(0.5)
        self.assertAlmostEqual(self.get('flycam', 'world').pose.position.y, 4.0, places=2)

    def test_imu_of_the_phone(self):
        # thesis snippet 3.3.2: the phone's IMU; held still (gravity off) it reads +g up
        msg = rospy.wait_for_message('/mobile_device/imu_sensor_data', Imu, timeout=30)
        msg = rospy.wait_for_message('/mobile_device/imu_sensor_data', Imu, timeout=30)
        self.assertEqual(msg.header.frame_id, 'mobile_device_frame')   # Android's device frame
        self.assertGreater(msg.header.stamp.to_sec(), 0.0)
        # Android CDD noise: accelerometer sigma 0.05 m/s^2, gyroscope 3.2 mrad/s (5 sigma)
        self.assertAlmostEqual(msg.linear_acceleration.z, 9.81, delta=0.25)
        self.assertAlmostEqual(msg.angular_velocity.x, 0.0, delta=0.016)

    # -- bad input -----------------------------------------------------------------------
    def assertWorldAlive(self):
        res = self.get('mobile_device', 'world')
        self.assertTrue(res.success, 'world lost the phone: ' + res.status_message)

    def test_bad_spawn_inputs(self):
        cases = [
            ('<robot name="x"><link name="a"></robot>', 'malformed URDF'),
            ('<robot name="x"><link name="a"/><joint name="j" type="fixed"><parent link="a"/>'
             '<child link="ghost"/></joint></robot>', 'ghost'),
            ('<robot name="x"><link name="a"><visual><geometry><box size="1 1"/></geometry>'
             '</visual></link></robot>', 'box size'),
            ('', 'empty'),
        ]
        for xml, words in cases:
            res = self.spawn('bad_model', xml, '', pose(0, 0, 1), 'world')
            self.assertFalse(res.success, xml)
            self.assertIn(words, res.status_message)
            self.assertFalse(self.get('bad_model', 'world').success)
        res = self.spawn('bad_model', BOX_URDF, '', pose(0, 0, 1), 'no_such_frame')
        self.assertFalse(res.success)
        self.assertIn('no_such_frame', res.status_message)
        res = self.spawn('bad_model', BOX_URDF, '', pose(0, 0, 1, 0, 0, 0, 0), 'world')
        self.assertFalse(res.success)
        self.assertWorldAlive()

    def test_bad_get_set_inputs(self):
        res = self.get('no_such_model', 'world')
        self.assertFalse(res.success)
        self.assertIn('no_such_model', res.status_message)
        res = self.get('mobile_device', 'no_such_frame')
        self.assertFalse(res.success)
        self.assertIn('no_such_frame', res.status_message)
        before = self.get('mobile_device', 'world').pose
        for q in [(0, 0, 0, 0), (float('nan'), 0, 0, 1)]:
            res = self.set(ModelState(model_name='mobile_device', pose=pose(0, 0, 0, *q),
                                      reference_frame='world'))
            self.assertFalse(res.success)
        res = self.set(ModelState(model_name='mobile_device', pose=pose(float('nan'), 0, 0),
                                  reference_frame='world'))
        self.assertFalse(res.success)
        res = self.set(ModelState(model_name='mobile_device', pose=pose(0, 0, 0),
                                  reference_frame='no_such_frame'))
        self.assertFalse(res.success)
        res = self.set(ModelState(model_name='ghost', pose=pose(0, 0, 0), reference_frame='world'))
        self.assertFalse(res.success)
        after = self.get('mobile_device', 'world').pose
        self.assertAlmostEqual(before.position.x, after.position.x, places=6)
        self.assertAlmostEqual(before.position.z, after.position.z, places=6)

    def test_missing_world_file_stops_with_clear_line(self):
        env = dict(os.environ)
        proc = subprocess.run(['rosrun', 'mobile_device_sim', 'sim_world',
                               '/nonexistent/dir/nowhere.world', '__name:=sim_world_missing'],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=60,
                              env=env, text=True)
        self.assertEqual(proc.returncode, 1, proc.stdout)
        lines = [l for l in proc.stdout.splitlines() if 'nowhere.world' in l]
        self.assertEqual(len(lines), 1, proc.stdout)
        self.assertIn('does not exist', lines[0])

    def test_zz_pause_and_reset(self):
        pause = rospy.ServiceProxy('/gazebo/pause_physics', Empty)
        unpause = rospy.ServiceProxy('/gazebo/unpause_physics', Empty)
        reset = rospy.ServiceProxy('/gazebo/reset_world', Empty)
        pause()
        try:
            time.sleep(0.3)
            a = rospy.wait_for_message('/clock', Clock, timeout=10).clock
            time.sleep(0.8)
            b = rospy.wait_for_message('/clock', Clock, timeout=10).clock
            self.assertEqual(a, b)
        finally:
            unpause()
        self.set(ModelState(model_name='mobile_device', pose=pose(0.0, 0.0, 2.0),
                            reference_frame='world'))
        reset()
        p = self.get('mobile_device', 'world').pose.position
        self.assertAlmostEqual(p.x, PHONE_SPAWN[0], places=3)
        self.assertAlmostEqual(p.z, PHONE_SPAWN[2], places=3)


if __name__ == '__main__':
    engine = [a for a in sys.argv[1:] if a in ('ode', 'bullet')] or ['ode']
    rostest.rosrun('mobile_device_sim', 'sim_world_api_' + engine[0], SimWorldApi, sys.argv)
