#!/usr/bin/env python3
"""rostest: the phone's LED, vibration motor and thermal display (outputs.test). The LED is
commanded with `rostopic pub` as simsensors/README_outputs.md shows (started in the
background: the test waits for the LED to light, not for rostopic's 3 s linger); the other
commands go through latched publishers of this node (a rostopic process per command cost
seconds of wall time each)."""
import subprocess
import time
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Imu, Temperature
from std_msgs.msg import ColorRGBA, Float64

from mobile_device_sim.msg import Vibration
from common import Recorder, sim_now, sim_sleep, start, wait_connected  # noqa: E402

NS = '/mobile_device/'


def wait_until(what, cond, timeout=60.0):
    deadline = time.time() + timeout
    while not cond():
        if time.time() > deadline:
            raise AssertionError('timed out waiting for ' + what)
        time.sleep(0.01)


class Outputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        start('outputs_test', timeout=60)
        cls.imu = Recorder(NS + 'imu_sensor_data', Imu)
        cls.led = Recorder(NS + 'led/state', ColorRGBA)
        cls.thermal = Recorder(NS + 'thermal_display/state', Temperature)
        cls.vibrate = rospy.Publisher(NS + 'vibrate', Vibration, queue_size=1, latch=True)
        cls.temp = rospy.Publisher(NS + 'thermal_display/temperature', Float64, queue_size=1,
                                   latch=True)
        wait_connected(cls.vibrate, cls.imu.sub)
        wait_connected(cls.temp, cls.thermal.sub)
        sim_sleep(1.0)

    def accel_var(self, t0, t1):
        a = np.array([(m.linear_acceleration.x, m.linear_acceleration.y,
                       m.linear_acceleration.z) for m in list(self.imu.msgs)
                      if t0 <= m.header.stamp.to_sec() <= t1])
        self.assertGreater(len(a), 20, (t0, t1))
        return np.var(a, axis=0).sum()

    def test_vibration_raises_the_imu_variance(self):
        t0 = sim_now()
        sim_sleep(1.5)
        quiet = self.accel_var(t0, sim_now())
        self.vibrate.publish(Vibration(timings=[6.0, 1.0], amplitudes=[1.0, 0.0], repeat=-1))
        t1 = sim_now()                 # the world may take the message a little later
        sim_sleep(1.0)
        t2 = sim_now()
        busy = self.accel_var(t2 - 0.4, t2)
        sim_sleep(7.0)                 # the 6 s segment is over (1 s allowed for delivery)
        t3 = sim_now()
        after = self.accel_var(t3 - 1.0, t3)
        self.assertGreater(busy, 20 * quiet, (quiet, busy, t1))
        self.assertLess(after, busy / 20, (after, busy))
        # bad input: one line, the world keeps running
        self.vibrate.publish(Vibration(timings=[1.0, 2.0], amplitudes=[1.0], repeat=-1))
        sim_sleep(0.5)

    def test_led_and_thermal_state(self):
        cli = subprocess.Popen(['rostopic', 'pub', '-1', NS + 'led', 'mobile_device_sim/LedCommand',
                                '{argb: 0, on_ms: 500, off_ms: 500, color: "red"}'],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            wait_until('the LED to light', lambda: any(m.a == 1.0 for m in self.led.msgs))
            sim_sleep(2.2)
        finally:
            out = cli.communicate(timeout=60)[0]
        self.assertEqual(cli.returncode, 0, out)
        lit = [m for m in self.led.msgs if m.a == 1.0]
        self.assertTrue(lit, 'the LED never lit')
        self.assertEqual((lit[-1].r, lit[-1].g, lit[-1].b), (1.0, 0.0, 0.0))
        self.assertGreaterEqual(len([m for m in self.led.msgs if m.a == 0.0]), 2)   # blinks
        self.temp.publish(Float64(43.0))
        sim_sleep(3.5)
        temp = self.thermal.msgs[-1].temperature
        self.assertTrue(38.0 < temp < 43.0, temp)     # about 63 % after tau = 3 s
        self.temp.publish(Float64(float('nan')))
        sim_sleep(0.5)
        self.assertGreater(self.thermal.msgs[-1].temperature, temp - 0.01)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'outputs', Outputs)
