#!/usr/bin/env python3
"""The app under test of the indoor/outdoor scenario: it tells whether it has a position
fix (outdoors) or not (indoors, no sky), from the GPS receiver.

Subscribes ~fix (/mobile_device/fix, sensor_msgs/NavSatFix). Publishes ~state
(std_msgs/String, latched, on change: 'outdoor' with a fix, 'indoor' without one).
"""
import rospy
from sensor_msgs.msg import NavSatFix, NavSatStatus
from std_msgs.msg import String


def main():
    rospy.init_node('location_app')
    pub = rospy.Publisher('~state', String, queue_size=10, latch=True)
    last = [None]

    def on_fix(m):
        s = 'outdoor' if m.status.status >= NavSatStatus.STATUS_FIX else 'indoor'
        if s != last[0]:
            last[0] = s
            pub.publish(String(s))

    rospy.Subscriber(rospy.get_param('~fix', '/mobile_device/fix'), NavSatFix, on_fix,
                     queue_size=10)
    rospy.spin()


if __name__ == '__main__':
    main()
