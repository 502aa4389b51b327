#!/usr/bin/env python3
"""The app under test of the auto-rotate scenario: it turns its display content with the
phone's orientation, as Android's window manager does, from the accelerometer alone.

Subscribes ~imu (default /mobile_device/imu_sensor_data, sensor_msgs/Imu; Android device
frame: x right, y up along the long edge, z out of the screen).
Publishes ~rotation (std_msgs/Int32, latched, on change): the display rotation in degrees
(0 portrait, 90 top to the left, 180 upside down, 270 top to the right), -1 while the phone
lies flat (|z| above 80 % of g: no rotation is decided, Android keeps the last one).
"""
import math

import rospy
from sensor_msgs.msg import Imu
from std_msgs.msg import Int32


def rotation(ax, ay, az, last=-1):
    g = math.sqrt(ax * ax + ay * ay + az * az)
    if g < 1e-6 or abs(az) > 0.8 * g:
        return last if last is not None else -1
    ang = math.degrees(math.atan2(-ax, ay)) % 360.0
    return int(round(ang / 90.0)) % 4 * 90


def main():
    rospy.init_node('rotate_app')
    pub = rospy.Publisher('~rotation', Int32, queue_size=10, latch=True)
    state = {'rot': -1}
    pub.publish(Int32(-1))

    def on_imu(m):
        a = m.linear_acceleration
        r = rotation(a.x, a.y, a.z, state['rot'])
        if r != state['rot']:
            state['rot'] = r
            pub.publish(Int32(r))

    rospy.Subscriber(rospy.get_param('~imu', '/mobile_device/imu_sensor_data'), Imu, on_imu,
                     queue_size=100)
    rospy.spin()


if __name__ == '__main__':
    main()
