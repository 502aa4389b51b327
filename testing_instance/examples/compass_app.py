#!/usr/bin/env python3
"""The app under test of the compass scenario: the azimuth as Android computes it
(SensorManager.getRotationMatrix + getOrientation) from the accelerometer and the
magnetometer.

Subscribes ~imu (/mobile_device/imu_sensor_data) and ~magnetic (/mobile_device/magnetic,
sensor_msgs/MagneticField, T). Publishes ~azimuth (std_msgs/Float64, degrees clockwise from
magnetic north of the device's y axis (its top), 0..360) for every magnetometer message, in
their order.

Each magnetometer reading is paired with the accelerometer reading of the latest stamp at or
before its own, as Android hands an app its sensor events in time order on one thread. rospy
runs each subscription's callbacks in a thread of its own, so "the last accelerometer reading
received" would depend on which thread ran first: the same world gave different azimuths
under load (bench/load). A magnetometer reading waits until an accelerometer reading stamped
at or after it has arrived (the IMU, at 100 Hz, is stamped at the same world ticks).
"""
import bisect
import math
import threading

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


class Pairing(object):
    """Magnetometer readings paired with the accelerometer reading of the latest stamp at
    or before theirs, in stamp order, whichever subscription's thread runs first."""

    def __init__(self, emit, keep=200):
        self.emit = emit
        self.keep = keep
        self.lock = threading.Lock()
        self.acc_t = []          # stamps (ns), ascending
        self.acc = []
        self.mags = []           # (stamp ns, field) waiting for a later accelerometer reading

    def on_acc(self, t, a):
        with self.lock:
            if self.acc_t and t <= self.acc_t[-1]:
                return           # a repeat (a latched or re-sent reading)
            self.acc_t.append(t)
            self.acc.append(a)
            if len(self.acc_t) > self.keep:
                del self.acc_t[0], self.acc[0]
            self._flush()

    def on_mag(self, t, f):
        with self.lock:
            bisect.insort(self.mags, (t, f))
            self._flush()

    def _flush(self):
        while self.mags and self.acc_t and self.acc_t[-1] >= self.mags[0][0]:
            t, f = self.mags.pop(0)
            i = bisect.bisect_right(self.acc_t, t) - 1
            if i >= 0:
                self.emit(self.acc[i], f)


def main():
    rospy.init_node('compass_app')
    pub = rospy.Publisher('~azimuth', Float64, queue_size=100)

    def emit(acc, mag):
        az = azimuth(acc, mag)
        if az is not None:
            pub.publish(Float64(az))
    pairing = Pairing(emit)

    def on_imu(m):
        a = m.linear_acceleration
        pairing.on_acc(m.header.stamp.to_nsec(), (a.x, a.y, a.z))

    def on_mag(m):
        f = m.magnetic_field
        pairing.on_mag(m.header.stamp.to_nsec(), (f.x, f.y, f.z))

    rospy.Subscriber(rospy.get_param('~imu', '/mobile_device/imu_sensor_data'), Imu, on_imu,
                     queue_size=100)
    rospy.Subscriber(rospy.get_param('~magnetic', '/mobile_device/magnetic'), MagneticField,
                     on_mag, queue_size=100)
    rospy.spin()


if __name__ == '__main__':
    main()
