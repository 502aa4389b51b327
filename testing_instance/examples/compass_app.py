#!/usr/bin/env python3
"""The app under test of the compass scenario: the azimuth as Android computes it
(SensorManager.getRotationMatrix + getOrientation) from the accelerometer and the
magnetometer.

Subscribes ~imu (/mobile_device/imu_sensor_data) and ~magnetic (/mobile_device/magnetic,
sensor_msgs/MagneticField, T). Publishes ~azimuth (std_msgs/Float64, degrees clockwise from
magnetic north of the device's y axis (its top), 0..360) on every magnetometer message.
"""
import math

import rospy
from sensor_msgs.msg import Imu, MagneticField
from std_msgs.msg import Float64


def azimuth(acc, mag):
    """Android's getRotationMatrix/getOrientation: degrees, 0..360."""
    ax, ay, az = acc
    ex, ey, ez = mag
    hx, hy, hz = ey * az - ez * ay, ez * ax - ex * az, ex * ay - ey * ax
    nh = math.sqrt(hx * hx + hy * hy + hz * hz)
    na = math.sqrt(ax * ax + ay * ay + az * az)
    if nh < 1e-12 or na < 1e-6:
        return None
    hx, hy, hz = hx / nh, hy / nh, hz / nh
    ax, ay, az = ax / na, ay / na, az / na
    my = az * hx - ax * hz
    return math.degrees(math.atan2(hy, my)) % 360.0


def main():
    rospy.init_node('compass_app')
    pub = rospy.Publisher('~azimuth', Float64, queue_size=100)
    acc = [None]

    def on_imu(m):
        a = m.linear_acceleration
        acc[0] = (a.x, a.y, a.z)

    def on_mag(m):
        if acc[0] is None:
            return
        f = m.magnetic_field
        az = azimuth(acc[0], (f.x, f.y, f.z))
        if az is not None:
            pub.publish(Float64(az))

    rospy.Subscriber(rospy.get_param('~imu', '/mobile_device/imu_sensor_data'), Imu, on_imu,
                     queue_size=100)
    rospy.Subscriber(rospy.get_param('~magnetic', '/mobile_device/magnetic'), MagneticField,
                     on_mag, queue_size=100)
    rospy.spin()


if __name__ == '__main__':
    main()
