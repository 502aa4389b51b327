#!/usr/bin/env python3
"""rostest: the phone's GPS, magnetometer, barometer, ambient and device clock topics with a
real roscore (simsensors_location.test)."""
import math
import os
import unittest

import rospy
import rostest
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import (FluidPressure, MagneticField, NavSatFix, NavSatStatus,
                             RelativeHumidity, Temperature, TimeReference)
from std_msgs.msg import Float64, String

from mobile_device_sim.msg import EnvironmentValue
from mobile_device_sim.srv import SetDeviceTime, SetEnvironment
from common import (Recorder, model_state_msg, rated_topics, sim_now, sim_sleep,  # noqa: E402
                    start)

NS = '/mobile_device/'
# topic -> (documented type, class, rate in Hz of sim time; None: not checked here)
TOPICS = {
    'fix': ('sensor_msgs/NavSatFix', NavSatFix, 1.0),
    'fix_velocity': ('geometry_msgs/Vector3Stamped', Vector3Stamped, None),  # with a fix
    'nmea_sentence': ('std_msgs/String', String, 2.0),        # GGA + RMC each second
    'magnetic': ('sensor_msgs/MagneticField', MagneticField, 50.0),
    'pressure': ('sensor_msgs/FluidPressure', FluidPressure, 10.0),
    'altitude': ('std_msgs/Float64', Float64, 10.0),
    'temperature': ('sensor_msgs/Temperature', Temperature, 1.0),
    'humidity': ('sensor_msgs/RelativeHumidity', RelativeHumidity, 1.0),
    'time_reference': ('sensor_msgs/TimeReference', TimeReference, 1.0),
}
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class LocationSensors(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        _, cls.set_state = start('simsensors_location_test', timeout=60)
        cls.rec = dict((t, Recorder(NS + t, c)) for t, (_, c, _) in TOPICS.items())
        sim_sleep(6.0)
        cls.window = dict((t, (list(r.msgs), list(r.times))) for t, r in cls.rec.items())

    def test_1_types_and_rates(self):
        for topic, rate in rated_topics(self, NS, TOPICS):
            msgs, times = self.window[topic]
            if msgs and hasattr(msgs[0], 'header'):
                stamps = [m.header.stamp.to_sec() for m in msgs]
            else:
                stamps = times
            self.assertGreater(len(stamps), 3, topic)
            span = stamps[-1] - stamps[0]
            measured = (len(stamps) - 1) / span if span > 0 else 0.0
            # topics without a header: arrival in sim time, two NMEA lines share a stamp
            tol = 0.1 * rate if hasattr(msgs[0], 'header') else 0.35 * rate
            self.assertAlmostEqual(measured, rate, delta=tol, msg=topic)

    def test_2_indoor_values(self):
        fixes, _ = self.window['fix']
        self.assertTrue(all(f.status.status == NavSatStatus.STATUS_NO_FIX for f in fixes))
        nmea = [m.data for m in self.window['nmea_sentence'][0]]
        self.assertTrue(any(s.startswith('$GPGGA') for s in nmea))
        self.assertTrue(any(s.startswith('$GPRMC') and ',V,' in s for s in nmea))
        p = self.window['pressure'][0][-1].fluid_pressure
        # phone at z = 1 m in the office at 519 m: ICAO 95 232 Pa (+-5 sigma of 1 Pa)
        self.assertAlmostEqual(p, 101325 * (1 - 0.0065 * 520 / 288.15) ** 5.2559, delta=5)
        self.assertAlmostEqual(self.window['temperature'][0][-1].temperature, 21.0, delta=0.5)
        b = self.window['magnetic'][0][-1].magnetic_field
        self.assertAlmostEqual(math.sqrt(b.x ** 2 + b.y ** 2 + b.z ** 2), 48e-6, delta=4e-6)
        tr = self.window['time_reference'][0][-1]
        self.assertAlmostEqual(tr.time_ref.to_sec(), tr.header.stamp.to_sec(), places=6)

    def test_3_walk_out_of_the_door_gets_a_fix_after_ttff(self):
        from sim_world.sdf import load_world_file
        env = load_world_file(os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')).environment
        n0 = len(self.rec['fix'].msgs)
        t_visible = None
        x = 3.3
        while x <= 9.0 + 1e-9:
            p = (x, -3.0, 1.0)
            before = sim_now()
            self.assertTrue(self.set_state(model_state_msg('mobile_device', p)).success)
            inside, _, margin = env.indoor(p)
            if t_visible is None and (not inside or margin):
                t_visible = (before, sim_now() + 0.01)
            sim_sleep(0.25)
            x += 0.25
        self.assertIsNotNone(t_visible)
        deadline = sim_now() + 15
        while sim_now() < deadline:
            got = [f for f in self.rec['fix'].msgs[n0:] if f.status.status >= 0]
            if got:
                break
            sim_sleep(0.2)
        got = [f for f in self.rec['fix'].msgs[n0:] if f.status.status >= 0]
        self.assertTrue(got, 'no fix outdoors')
        t_fix = got[0].header.stamp.to_sec()
        # warm start (the fix was lost at t = 0): 5 s, on the 1 Hz grid
        self.assertGreaterEqual(t_fix, t_visible[0] + 5.0 - 1e-6)
        self.assertLessEqual(t_fix, t_visible[1] + 6.0 + 0.01)
        self.assertAlmostEqual(got[0].latitude, 48.1489, delta=0.001)
        self.assertAlmostEqual(got[0].longitude, 11.5667, delta=0.001)
        sim_sleep(2.5)
        self.assertTrue(any(v.header.stamp.to_sec() >= t_fix for v in self.rec['fix_velocity'].msgs))
        self.assertTrue(any(m.data.startswith('$GPRMC') and ',A,' in m.data
                            for m in self.rec['nmea_sentence'].msgs[-4:]))

    def test_4_set_device_time(self):
        before = sim_now()
        # a proxy, not `rosservice call` (seconds of start-up; the README's command is run
        # by test_readme_commands)
        res = rospy.ServiceProxy(NS + 'set_device_time', SetDeviceTime)(
            device_time=rospy.Time(1700000000, 0))
        self.assertTrue(res.success, res.status_message)
        after = sim_now()
        sim_sleep(2.5)
        tr = self.rec['time_reference'].msgs[-1]
        # set somewhere between before and after the call
        ran = tr.time_ref.to_sec() - 1700000000
        self.assertGreaterEqual(ran, tr.header.stamp.to_sec() - after - 0.01)
        self.assertLessEqual(ran, tr.header.stamp.to_sec() - before + 0.01)

    def test_5_set_environment(self):
        srv = rospy.ServiceProxy('/gazebo/set_environment', SetEnvironment)
        res = srv([EnvironmentValue('indoor_temperature', 30.0), EnvironmentValue('temperature', 30.0),
                   EnvironmentValue('humidity', 70.0)])
        self.assertTrue(res.success, res.status_message)
        sim_sleep(2.5)
        self.assertAlmostEqual(self.rec['temperature'].msgs[-1].temperature, 30.0, delta=0.5)
        self.assertAlmostEqual(self.rec['humidity'].msgs[-1].relative_humidity, 0.70, delta=0.02)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'simsensors_location', LocationSensors)
