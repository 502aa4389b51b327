#!/usr/bin/env python3
"""rostest: the phone's proximity, ambient light, touch/buttons and battery topics with a
real roscore (simsensors_phone.test)."""
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose as PoseMsg
from sensor_msgs.msg import BatteryState, Illuminance, Range
from std_msgs.msg import Bool, ColorRGBA

from mobile_device_sim.msg import ButtonEvent, ContactsState, PowerState, TouchEvent
from mobile_device_sim.srv import DeleteModel, InjectTouch, PressButton, SpawnModel
from common import Recorder, rated_topics, rosservice, sim_sleep, start  # noqa: E402

NS = '/mobile_device/'
# topic -> (documented type, class, rate in Hz of sim time or None for event topics)
TOPICS = {
    'proximity': ('sensor_msgs/Range', Range, None),
    'illuminance': ('sensor_msgs/Illuminance', Illuminance, 5.0),
    'light_color': ('std_msgs/ColorRGBA', ColorRGBA, None),
    'touch': ('mobile_device_sim/TouchEvent', TouchEvent, None),
    'buttons': ('mobile_device_sim/ButtonEvent', ButtonEvent, None),
    'contacts': ('mobile_device_sim/ContactsState', ContactsState, 100.0),
    'power_state': ('mobile_device_sim/PowerState', PowerState, 10.0),
    'battery_state': ('sensor_msgs/BatteryState', BatteryState, 1.0),
}
HAND = '''<robot name="hand"><link name="palm">
  <collision><geometry><box size="0.1 0.1 0.02"/></geometry></collision></link>
  <gazebo><static>true</static></gazebo></robot>'''


class PhoneSensors(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        start('simsensors_phone_test', timeout=60)
        cls.rec = dict((t, Recorder(NS + t, c)) for t, (_, c, _) in TOPICS.items())
        rospy.wait_for_service(NS + 'inject_touch', timeout=30)
        cls.touch = rospy.ServiceProxy(NS + 'inject_touch', InjectTouch)
        cls.press = rospy.ServiceProxy(NS + 'press_button', PressButton)
        sim_sleep(3.0)

    def test_types_and_rates(self):
        for topic, rate in rated_topics(self, NS, TOPICS):
            msgs = [m for m in self.rec[topic].msgs if hasattr(m, 'header')]
            stamps = [m.header.stamp.to_sec() for m in msgs]
            self.assertGreater(len(stamps), 3, topic)
            measured = (len(stamps) - 1) / (stamps[-1] - stamps[0])
            self.assertAlmostEqual(measured, rate, delta=0.1 * rate, msg=topic)
        # proximity: on change plus a repeat every second of sim time
        prox = self.rec['proximity'].msgs
        self.assertGreaterEqual(len(prox), 2)
        self.assertEqual(prox[0].radiation_type, Range.INFRARED)
        self.assertEqual(self.rec['light_color'].msgs[-1].a, 1.0)

    def test_office_light_and_battery_values(self):
        lux = self.rec['illuminance'].msgs[-1].illuminance
        self.assertTrue(100 < lux < 1000, lux)
        ps = self.rec['power_state'].msgs[-1]
        self.assertEqual(ps.AC_present, 0)
        self.assertGreater(ps.power_consumption, 0.1)
        bs = self.rec['battery_state'].msgs[-1]
        self.assertLess(bs.current, 0)
        self.assertEqual(bs.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)

    def test_inject_touch_and_press_button_via_rosservice(self):
        n = len(self.rec['touch'].msgs)
        out = rosservice(NS + 'inject_touch',
                              '{x: 150, y: 250, duration: 0.2, pressure: 0.5, x_end: -1, y_end: -1}')
        self.assertIn('success: True', out)
        nb = len(self.rec['buttons'].msgs)
        # the rest through proxies (a rosservice process costs seconds of start-up)
        res = self.press(button='power', duration=0.1)
        self.assertTrue(res.success, res.status_message)
        sim_sleep(1.0)
        ev = self.rec['touch'].msgs[n:]
        self.assertEqual([e.action for e in ev][0], TouchEvent.DOWN)
        self.assertEqual([e.action for e in ev][-1], TouchEvent.UP)
        self.assertAlmostEqual(ev[0].x, 150, places=3)
        self.assertAlmostEqual(ev[0].y, 250, places=3)
        self.assertEqual((ev[0].width, ev[0].height), (307, 512))
        self.assertAlmostEqual(ev[-1].header.stamp.to_sec() - ev[0].header.stamp.to_sec(), 0.2,
                               delta=2 / 100.0)
        be = self.rec['buttons'].msgs[nb:]
        self.assertEqual([(b.button, b.state) for b in be],
                         [('power', ButtonEvent.PRESSED), ('power', ButtonEvent.RELEASED)])
        # bad input: refused with a reason, nothing happens
        res = self.touch(x=-5, y=250, duration=0.2, pressure=0.5, x_end=-1, y_end=-1)
        self.assertFalse(res.success)
        self.assertIn('outside the display', res.status_message)
        res = self.press(button='home', duration=0.1)
        self.assertFalse(res.success)
        self.assertIn("named 'home'", res.status_message)

    def test_charger(self):
        pub = rospy.Publisher(NS + 'charger', Bool, queue_size=1, latch=True)
        # the world's subscription first: on a loaded machine it took longer than the 1.5 s
        # of sim time below (the world runs at real time here)
        deadline = time.time() + 60.0
        while pub.get_num_connections() < 1 and time.time() < deadline:
            time.sleep(0.05)
        pub.publish(Bool(True))
        try:
            sim_sleep(1.5)
            ps = self.rec['power_state'].msgs[-1]
            self.assertEqual(ps.AC_present, 1)
            self.assertIn(self.rec['battery_state'].msgs[-1].power_supply_status,
                          (BatteryState.POWER_SUPPLY_STATUS_CHARGING,
                           BatteryState.POWER_SUPPLY_STATUS_FULL))
            # how far below full depends on how long the world ran before (it runs at real
            # time from launch: seconds more on a loaded machine); the power state predicts
            # when it is full, and at 1 Hz the battery state says so within a second after
            left = ps.time_remaining.to_sec() if ps.power_consumption < 0 else 0.0
            self.assertLess(left, 60.0)
            sim_sleep(left + 1.5)
            self.assertLess(self.rec['power_state'].msgs[-1].power_consumption, 0.001)
            self.assertEqual(self.rec['battery_state'].msgs[-1].power_supply_status,
                             BatteryState.POWER_SUPPLY_STATUS_FULL)
        finally:
            pub.publish(Bool(False))           # the other tests see the battery discharging
            sim_sleep(1.5)
        self.assertEqual(self.rec['power_state'].msgs[-1].AC_present, 0)

    def test_proximity_hand(self):
        """A hand 2 cm over the sensor (phone at 3.288 -2.11 1.0, the sensor link at
        +0.055 +0.012 +0.006 of mobile_base_link): near (0 m), and the light it covers
        drops; taken away: far (0.05 m) again."""
        before = self.rec['illuminance'].msgs[-1].illuminance
        spawn = rospy.ServiceProxy('/gazebo/spawn_urdf_model', SpawnModel)
        p = PoseMsg()
        p.position.x, p.position.y = 3.288 + 0.055, -2.11 + 0.012
        p.position.z = 1.0 + 0.006 + 0.02 + 0.01
        p.orientation.w = 1.0
        res = spawn('hand', HAND, '', p, 'world')
        self.assertTrue(res.success, res.status_message)
        sim_sleep(1.5)
        self.assertEqual(self.rec['proximity'].msgs[-1].range, 0.0)
        covered = self.rec['illuminance'].msgs[-1].illuminance
        self.assertLess(covered, 0.5 * before)
        res = rospy.ServiceProxy('/gazebo/delete_model', DeleteModel)('hand')
        self.assertTrue(res.success, res.status_message)
        sim_sleep(1.5)
        self.assertAlmostEqual(self.rec['proximity'].msgs[-1].range, 0.05, places=6)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'simsensors_phone', PhoneSensors)
