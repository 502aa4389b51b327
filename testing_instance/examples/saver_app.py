#!/usr/bin/env python3
"""The app under test of the battery-saver scenario: below 15 % it blinks the notification
LED red (500 ms on, 500 ms off) and dims the display to 20 %; with the charger plugged in
(or above 15 %) it stops blinking and restores full brightness.

Subscribes <ns>/battery_state (sensor_msgs/BatteryState: percentage 0..1, power supply
status). Publishes <ns>/led (mobile_device_sim/LedCommand), <ns>/display/brightness
(std_msgs/Float32, 0..1) and ~saving (std_msgs/Bool, latched, on change).
"""
import rospy
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, Float32

from mobile_device_sim.msg import LedCommand


def main():
    rospy.init_node('saver_app')
    ns = '/' + rospy.get_param('~ns', 'mobile_device').strip('/')
    led = rospy.Publisher(ns + '/led', LedCommand, queue_size=10, latch=True)
    bright = rospy.Publisher(ns + '/display/brightness', Float32, queue_size=10, latch=True)
    saving = rospy.Publisher('~saving', Bool, queue_size=10, latch=True)
    state = [None]

    def on_battery(m):
        charging = m.power_supply_status == BatteryState.POWER_SUPPLY_STATUS_CHARGING
        s = m.percentage < 0.15 and not charging
        if s != state[0]:
            state[0] = s
            if s:
                led.publish(LedCommand(color='red', on_ms=500, off_ms=500))
                bright.publish(Float32(0.2))
            else:
                led.publish(LedCommand(argb=0, on_ms=0, off_ms=0))
                bright.publish(Float32(1.0))
            saving.publish(Bool(s))

    rospy.Subscriber(ns + '/battery_state', BatteryState, on_battery, queue_size=10)
    rospy.spin()


if __name__ == '__main__':
    main()
