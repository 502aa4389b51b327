#!/usr/bin/env python3
"""rostest: the phone's LED, vibration motor and thermal display through rostopic pub
(outputs.test)."""
import subprocess
import unittest

import numpy as np
import rostest
from sensor_msgs.msg import Imu, Temperature
from std_msgs.msg import ColorRGBA

from common import Recorder, sim_now, sim_sleep, start  # noqa: E402

NS = '/mobile_device/'


def pub(topic, typ, yaml):
    out = subprocess.run(['rostopic', 'pub', '-1', topic, typ, yaml], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=60)
    assert out.returncode == 0, out.stdout


class Outputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        start('outputs_test', timeout=60)
        cls.imu = Recorder(NS + 'imu_sensor_data', Imu)
        cls.led = Recorder(NS + 'led/state', ColorRGBA)
        cls.thermal = Recorder(NS + 'thermal_display/state', Temperature)
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
        pub(NS + 'vibrate', 'mobile_device_sim/Vibration',
            '{timings: [6.0, 1.0], amplitudes: [1.0, 0.0], repeat: -1}')
        # rostopic pub -1 returns about 3 s (wall) after it published
        t1 = sim_now()
        sim_sleep(0.5)
        t2 = sim_now()
        busy = self.accel_var(t2 - 0.4, t2)
        sim_sleep(6.5)                 # the 6 s segment is over
        t3 = sim_now()
        after = self.accel_var(t3 - 1.0, t3)
        self.assertGreater(busy, 20 * quiet, (quiet, busy, t1))
        self.assertLess(after, busy / 20, (after, busy))
        # bad input: one line, the world keeps running
        pub(NS + 'vibrate', 'mobile_device_sim/Vibration',
            '{timings: [1.0, 2.0], amplitudes: [1.0], repeat: -1}')
        sim_sleep(0.5)

    def test_led_and_thermal_state(self):
        pub(NS + 'led', 'mobile_device_sim/LedCommand',
            '{argb: 0, on_ms: 500, off_ms: 500, color: "red"}')
        sim_sleep(2.2)
        lit = [m for m in self.led.msgs if m.a == 1.0]
        self.assertTrue(lit, 'the LED never lit')
        self.assertEqual((lit[-1].r, lit[-1].g, lit[-1].b), (1.0, 0.0, 0.0))
        self.assertGreaterEqual(len([m for m in self.led.msgs if m.a == 0.0]), 2)   # blinks
        pub(NS + 'thermal_display/temperature', 'std_msgs/Float64', '{data: 43.0}')
        sim_sleep(3.5)
        temp = self.thermal.msgs[-1].temperature
        self.assertTrue(38.0 < temp < 43.0, temp)     # about 63 % after tau = 3 s
        pub(NS + 'thermal_display/temperature', 'std_msgs/Float64', '{data: .nan}')
        sim_sleep(0.5)
        self.assertGreater(self.thermal.msgs[-1].temperature, temp - 0.01)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'outputs', Outputs)
