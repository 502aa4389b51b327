#!/usr/bin/env python3
"""rostest: emulator_bridge between the simulated phone and a console test server
(emulator_bridge.test)."""
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import BatteryState

from common import model_state_msg, sim_sleep, start  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))  # test/fixtures
from fixtures.emulator_console_testserver import ConsoleTestServer  # noqa: E402


def values(cmd):
    return [float(v) for v in cmd.split()[-1].split(':')]


class EmulatorBridge(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.battery = []
        _, cls.set_state = start('emulator_bridge_test', timeout=60)
        rospy.Subscriber('/mobile_device/battery_state', BatteryState, cls.battery.append,
                         queue_size=10)
        cls.tmp = tempfile.mkdtemp(prefix='emulator_bridge_test')
        cls.token_file = os.path.join(cls.tmp, 'emulator_console_auth_token')
        with open(cls.token_file, 'w') as f:
            f.write('rostestToken42\n')
        # humidity refused as on an AVD without that sensor: KO, the rest goes on
        cls.server = ConsoleTestServer(token_file=cls.token_file, disabled=('humidity',)).start()
        cls.log = open(os.path.join(cls.tmp, 'bridge.log'), 'w+')
        cls.proc = subprocess.Popen(
            ['rosrun', 'mobile_device_sim', 'emulator_bridge',
             '_console_port:=%d' % cls.server.port, '_console_host:=127.0.0.1',
             '_auth_token_file:=' + cls.token_file, '_rate:=20.0',
             '__name:=emulator_bridge_under_test'],
            stdout=cls.log, stderr=subprocess.STDOUT, start_new_session=True)

    @classmethod
    def tearDownClass(cls):
        os.killpg(cls.proc.pid, signal.SIGINT)
        try:
            cls.proc.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(cls.proc.pid, signal.SIGKILL)
        cls.server.stop()
        cls.log.close()
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def teleport(self, x, y, z, rpy=(0, 0, 0)):
        self.assertTrue(self.set_state(model_state_msg('mobile_device', (x, y, z), rpy)).success)

    def recent(self, prefix, since, count=10):
        deadline = time.time() + 60
        while time.time() < deadline:
            got = self.server.commands(prefix)[since:]
            if len(got) >= count:
                return got
            time.sleep(0.05)
        self.fail('only %d %r commands after the pose (bridge log: %s)'
                  % (len(self.server.commands(prefix)[since:]), prefix, self.bridge_log()))

    def bridge_log(self):
        self.log.flush()
        with open(self.log.name) as f:
            return f.read()[-3000:]

    def mean_after_pose(self, rpy):
        self.teleport(3.288, -2.11, 1.0, rpy)
        sim_sleep(0.5)
        n0 = len(self.server.commands('sensor set acceleration'))
        got = self.recent('sensor set acceleration', n0, 10)
        vals = [values(c) for c in got]
        return [sum(v[i] for v in vals) / len(vals) for i in range(3)], vals

    def test_1_auth_and_upright(self):
        self.assertTrue(self.server.wait_for('sensor set acceleration', 1, 60),
                        self.bridge_log())
        self.assertIn('auth rostestToken42', self.server.lines)
        mean, vals = self.mean_after_pose((0, -math.pi / 2, 0))   # top (+x of the base) up
        self.assertAlmostEqual(mean[0], 0.0, delta=0.1)
        self.assertAlmostEqual(mean[1], 9.81, delta=0.1)
        self.assertAlmostEqual(mean[2], 0.0, delta=0.1)
        for v in vals:   # IMU noise sigma 0.05: every sample within 6 sigma
            self.assertAlmostEqual(v[1], 9.81, delta=0.3)

    def test_2_face_up_and_orientation(self):
        mean, vals = self.mean_after_pose((0, 0, 0))
        self.assertAlmostEqual(mean[0], 0.0, delta=0.1)
        self.assertAlmostEqual(mean[1], 0.0, delta=0.1)
        self.assertAlmostEqual(mean[2], 9.81, delta=0.1)
        n0 = len(self.server.commands('sensor set orientation'))
        az, pitch, roll = values(self.recent('sensor set orientation', n0, 3)[-1])
        # the top (device +y = world +x at yaw 0) is 21.5 deg west of north (338.5)
        self.assertAlmostEqual(az, 338.5, delta=1.0)
        self.assertAlmostEqual(pitch, 0.0, delta=1.0)
        self.assertAlmostEqual(roll, 0.0, delta=1.0)

    def test_3_pressure_magnetic_ko(self):
        p = values(self.recent('sensor set pressure', 0, 3)[-1])[0]
        self.assertAlmostEqual(p, 955.0, delta=3.0)        # hPa at ~520 m, not Pa
        b = values(self.recent('sensor set magnetic-field', 0, 3)[-1])
        self.assertTrue(20.0 < math.sqrt(sum(x * x for x in b)) < 70.0, b)   # microtesla
        self.recent('sensor set temperature', 0, 1)
        self.assertEqual(self.server.commands('sensor set humidity'), [])
        deadline = time.time() + 30
        while time.time() < deadline and \
                sum(l.startswith('sensor set humidity') for l in self.server.lines) < 3:
            time.sleep(0.1)
        self.assertEqual(self.bridge_log().count('KO: sensor humidity is not enabled'), 1,
                         self.bridge_log())

    def test_4_power_capacity(self):
        got = self.recent('power capacity', 0, 2)
        self.assertTrue(self.battery)
        pct = int(got[-1].split()[-1])
        self.assertTrue(0 <= pct <= 100)
        self.assertAlmostEqual(pct, self.battery[-1].percentage * 100, delta=1.0)
        self.assertTrue(self.server.commands('power status'))

    def test_5_geo_fix_longitude_first(self):
        self.assertEqual(self.server.commands('geo fix'), [], 'a fix inside the office')
        x = 3.3
        while x <= 9.0 + 1e-9:
            self.teleport(x, -3.0, 1.0)
            sim_sleep(0.25)
            x += 0.25
        got = self.recent('geo fix', 0, 1)
        words = got[0].split()
        lon, lat, alt, sats = float(words[2]), float(words[3]), float(words[4]), int(words[5])
        self.assertAlmostEqual(lon, 11.5667, delta=0.001)
        self.assertAlmostEqual(lat, 48.1489, delta=0.001)
        self.assertAlmostEqual(alt, 520.0, delta=15.0)
        self.assertTrue(1 <= sats <= 12)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'emulator_bridge', EmulatorBridge)
