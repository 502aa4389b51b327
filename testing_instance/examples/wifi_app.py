#!/usr/bin/env python3
"""The app under test of the WiFi walk: a status bar that shows the connected access point
and the link speed, like Android's WifiInfo in a settings screen.

Subscribes ~link (default /mobile_device/wifi/link, mobile_device_sim/WifiLink).
Publishes ~ap (std_msgs/String, latched, on change: the BSSID, '' when not connected) and
~link_speed (std_msgs/Int32, latched, on change: Mbit/s, 0 when not connected).
"""
import rospy
from std_msgs.msg import Int32, String

from mobile_device_sim.msg import WifiLink


def main():
    rospy.init_node('wifi_app')
    ap = rospy.Publisher('~ap', String, queue_size=10, latch=True)
    speed = rospy.Publisher('~link_speed', Int32, queue_size=10, latch=True)
    last = {'ap': None, 'speed': None}

    def on_link(m):
        bssid = m.bssid if m.connected else ''
        mbit = m.link_speed if m.connected else 0
        if bssid != last['ap']:
            last['ap'] = bssid
            ap.publish(String(bssid))
        if mbit != last['speed']:
            last['speed'] = mbit
            speed.publish(Int32(mbit))

    rospy.Subscriber(rospy.get_param('~link', '/mobile_device/wifi/link'), WifiLink, on_link,
                     queue_size=10)
    rospy.spin()


if __name__ == '__main__':
    main()
