#!/usr/bin/env python3
"""The app under test of the in-call proximity scenario: during a call the screen turns off
while something is near the proximity sensor (the ear, the cheek) and on again when the
phone is taken away, as Android's PROXIMITY_SCREEN_OFF_WAKE_LOCK does.

Subscribes <ns>/proximity (sensor_msgs/Range; near: range < max_range). Publishes
<ns>/display/enable (std_msgs/Bool: the phone's display on/off) and ~screen (std_msgs/String,
latched, on change: 'on' / 'off').
"""
import rospy
from sensor_msgs.msg import Range
from std_msgs.msg import Bool, String


def main():
    rospy.init_node('incall_app')
    ns = '/' + rospy.get_param('~ns', 'mobile_device').strip('/')
    display = rospy.Publisher(ns + '/display/enable', Bool, queue_size=10, latch=True)
    screen = rospy.Publisher('~screen', String, queue_size=10, latch=True)
    state = ['on']
    screen.publish(String('on'))

    def on_range(m):
        s = 'off' if m.range < m.max_range else 'on'
        if s != state[0]:
            state[0] = s
            display.publish(Bool(s == 'on'))
            screen.publish(String(s))

    rospy.Subscriber(ns + '/proximity', Range, on_range, queue_size=10)
    rospy.spin()


if __name__ == '__main__':
    main()
