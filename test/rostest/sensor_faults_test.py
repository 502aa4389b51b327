#!/usr/bin/env python3
"""rostest: sensor faults through /gazebo/set_sensor_fault act on every output
(sensor_faults.test). The calls go through a service proxy (a `rosservice` process costs
seconds of start-up on a loaded machine); one refused call goes through `rosservice call`
as a user types it, and its printed reason is checked."""
import re
import subprocess
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState, Imu

from mobile_device_sim.msg import ContactsState, PowerState
from mobile_device_sim.srv import SetSensorFault
from common import Recorder  # noqa: E402

NS = '/mobile_device/'


def fault(sensor, kind, value=0.0):
    """/gazebo/set_sensor_fault through a proxy: (success, status_message)."""
    res = rospy.ServiceProxy('/gazebo/set_sensor_fault', SetSensorFault)(
        model_name='mobile_device', sensor=sensor, fault=kind, value=value)
    return res.success, res.status_message


def fault_cli(sensor, kind, value=0.0):
    """`rosservice call /gazebo/set_sensor_fault ...` as a user types it: (success, text)."""
    out = subprocess.run(
        ['rosservice', 'call', '/gazebo/set_sensor_fault',
         '{model_name: mobile_device, sensor: %s, fault: %s, value: %g}' % (sensor, kind, value)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
        timeout=60).stdout
    out = re.sub(r'\\\n\s*\\?', '', out)     # YAML's folded long status line, joined
    return 'success: True' in out, out


def data(m):
    """A message's content without its header."""
    return tuple(str(getattr(m, s)) for s in m.__slots__ if s != 'header')


class SensorFaults(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('sensor_faults_test')
        rospy.wait_for_service('/gazebo/set_sensor_fault', timeout=60)
        rospy.wait_for_message(NS + 'imu_sensor_data', Imu, timeout=120)   # the phone is in
        cls.rec = dict(battery_state=Recorder(NS + 'battery_state', BatteryState),
                       power_state=Recorder(NS + 'power_state', PowerState),
                       contacts=Recorder(NS + 'contacts', ContactsState),
                       imu=Recorder(NS + 'imu_sensor_data', Imu))
        rospy.sleep(2.0)                 # sim time (/use_sim_time)

    def counts(self, *topics):
        return [len(self.rec[t].msgs) for t in topics]

    def test_drop_silences_every_output_then_none_restores(self):
        for sensor, topics in (('battery_state', ('battery_state', 'power_state')),
                               ('touch', ('contacts',))):
            ok, text = fault(sensor, 'drop')
            self.assertTrue(ok, text)
            rospy.sleep(0.5)             # messages in flight
            before = self.counts(*topics)
            rospy.sleep(2.5)
            self.assertEqual(self.counts(*topics), before, '%s under drop' % sensor)
            ok, text = fault(sensor, 'none')
            self.assertTrue(ok, text)
            rospy.sleep(2.5)
            for n0, n1, t in zip(before, self.counts(*topics), topics):
                self.assertGreater(n1, n0, '%s after none' % t)

    def test_freeze_repeats_the_last_message(self):
        ok, text = fault('imu_sensor_data', 'freeze')
        self.assertTrue(ok, text)
        rospy.sleep(0.5)
        n = len(self.rec['imu'].msgs)
        rospy.sleep(1.0)
        frozen = self.rec['imu'].msgs[n:]
        self.assertGreater(len(frozen), 20)
        self.assertEqual(len(set(data(m) for m in frozen)), 1)
        stamps = [m.header.stamp for m in frozen]
        self.assertEqual(len(set(stamps)), len(stamps))      # new stamps
        ok, text = fault('imu_sensor_data', 'none')
        self.assertTrue(ok, text)
        rospy.sleep(0.5)
        n = len(self.rec['imu'].msgs)
        rospy.sleep(0.5)
        self.assertGreater(len(set(data(m) for m in self.rec['imu'].msgs[n:])), 1)  # noise

    def test_what_a_plugin_cannot_take_is_refused_with_the_reason(self):
        ok, text = fault('battery_state', 'noise', 3.0)
        self.assertFalse(ok, text)
        self.assertIn('has no noise to scale', text)
        ok, text = fault('led', 'drop')
        self.assertFalse(ok, text)
        self.assertIn('not a sensor', text)
        ok, text = fault_cli('imu_sensor_data', 'smoke')
        self.assertFalse(ok, text)
        self.assertIn("'smoke' is not known", text)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'sensor_faults', SensorFaults)
