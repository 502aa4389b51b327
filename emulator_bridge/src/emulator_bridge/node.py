"""The emulator_bridge node: rosrun mobile_device_sim emulator_bridge [_console_port:=5554] [_console_host:=localhost]
   [_namespace:=/mobile_device] [_rate:=50.0] [_retry_period:=2.0]
   [_auth_token_file:=~/.emulator_console_auth_token] [_auth_token:=...]
   [_grace_period:=5.0] [_satellites:=8]

The simulated phone's sensors, location, battery and signal into an Android emulator's
console (see docs/consumers.md, "Android emulator bridge")."""
import sys
import threading
import time

import rospy
from sensor_msgs.msg import (BatteryState, FluidPressure, Illuminance, Imu, MagneticField,
                             NavSatFix, Range, RelativeHumidity, Temperature)
from std_msgs.msg import String

from mobile_device_sim.msg import CellSignal, Environment, WifiLink
from emulator_bridge import bridge as eb


class Node(object):
    def __init__(self):
        ns = rospy.get_param('~namespace', '/mobile_device').rstrip('/')
        host = rospy.get_param('~console_host', 'localhost')
        port = rospy.get_param('~console_port', 5554)
        rate = rospy.get_param('~rate', 50.0)
        retry = rospy.get_param('~retry_period', 2.0)
        self.grace = float(rospy.get_param('~grace_period', 5.0))
        self.satellites = int(rospy.get_param('~satellites', 8))
        token = rospy.get_param('~auth_token', '') or None
        token_file = rospy.get_param('~auth_token_file', eb.DEFAULT_TOKEN_FILE)
        for name, v, ok in (('console_port', port, isinstance(port, int) and 0 < port < 65536),
                            ('rate', rate, isinstance(rate, (int, float)) and rate > 0),
                            ('retry_period', retry,
                             isinstance(retry, (int, float)) and retry > 0)):
            if not ok:
                raise ValueError('parameter ~%s must be %s, got %r' % (
                    name, 'a port 1..65535' if name == 'console_port' else 'a number > 0', v))
        self.north_alpha = None
        self.client = eb.ConsoleClient(host, port, token=token, token_file=token_file)
        self.bridge = eb.Bridge(self.client, rate=rate, retry_period=retry,
                                info=rospy.loginfo, warn=rospy.logwarn, error=rospy.logerr)
        rospy.loginfo('emulator_bridge: %s/* -> emulator console %s:%d, at most %g Hz per '
                      'sensor (wall clock)', ns, host, port, rate)
        self.seen = {}
        topics = [('imu_sensor_data', Imu, lambda m: eb.imu_commands(m, self.north_alpha)),
                  ('magnetic', MagneticField, eb.magnetic_commands),
                  ('temperature', Temperature, eb.temperature_commands),
                  ('proximity', Range, eb.proximity_commands),
                  ('illuminance', Illuminance, eb.illuminance_commands),
                  ('pressure', FluidPressure, eb.pressure_commands),
                  ('humidity', RelativeHumidity, eb.humidity_commands),
                  ('fix', NavSatFix, lambda m: eb.fix_commands(m, self.satellites)),
                  ('battery_state', BatteryState, eb.battery_commands),
                  ('cellular/signal', CellSignal, eb.cell_commands),
                  ('wifi/link', WifiLink, eb.wifi_commands)]
        self.subs = []
        for rel, cls, conv in topics:
            topic = '%s/%s' % (ns, rel)
            self.seen[topic] = False
            self.subs.append(rospy.Subscriber(topic, cls, self.callback, (topic, conv),
                                              queue_size=1))
        self.subs.append(rospy.Subscriber(ns + '/nmea_sentence', String, self.on_nmea,
                                          queue_size=10))
        self.subs.append(rospy.Subscriber('/gazebo/environment', Environment, self.on_env,
                                          queue_size=1))
        self.bridge.start()
        threading.Thread(target=self.report_missing, daemon=True).start()

    def callback(self, msg, args):
        topic, conv = args
        self.seen[topic] = True
        try:
            pairs = conv(msg)
        except (ValueError, TypeError) as e:
            rospy.logwarn_throttle(10.0, 'emulator_bridge: bad message on %s: %s' % (topic, e))
            return
        self.bridge.submit_all(pairs)

    def on_env(self, msg):
        for v in msg.values:
            if v.name == 'north_alpha':
                self.north_alpha = v.value

    def on_nmea(self, msg):
        n = eb.gga_satellites(msg.data)
        if n is not None:
            self.satellites = n

    def report_missing(self):
        """One info line per phone topic that sent nothing within the grace period (wall
        clock: the world may be paused, the line only says what is skipped)."""
        time.sleep(self.grace)
        for topic, seen in sorted(self.seen.items()):
            if not seen and not rospy.is_shutdown():
                rospy.loginfo('emulator_bridge: nothing on %s after %g s: the phone has no such '
                              'sensor; skipped (sent as soon as it publishes)', topic, self.grace)
        if self.north_alpha is None and not rospy.is_shutdown():
            rospy.loginfo('emulator_bridge: no north_alpha on /gazebo/environment yet: '
                          '"sensor set orientation" waits for it')

    def shutdown(self):
        self.bridge.stop()


def main():
    rospy.init_node('emulator_bridge')
    try:
        node = Node()
    except ValueError as e:
        rospy.logfatal('emulator_bridge: %s', e)
        return 1
    rospy.on_shutdown(node.shutdown)
    rospy.spin()
    return 0


