#!/usr/bin/env python3
"""VM test publisher: known frames (frames.py) on /camera/image_raw as rgb8 at ~rate Hz;
logs 'k monotonic_time' per published frame to ~log. The rate can be changed while it runs
by writing a number into the file ~rate_file."""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rospy  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

import frames  # noqa: E402
from simvid.imageconv import array_to_image  # noqa: E402


def main():
    rospy.init_node('vm_publisher')
    w, h = rospy.get_param('~width', 640), rospy.get_param('~height', 480)
    rate = float(rospy.get_param('~rate', 30))
    rate_file = rospy.get_param('~rate_file', '')
    log = open(rospy.get_param('~log', '/tmp/pub.log'), 'a', buffering=1)
    msgs = [array_to_image(frames.picture(k, w, h), 'rgb8') for k in range(frames.N)]
    pub = rospy.Publisher('/camera/image_raw', Image, queue_size=1, tcp_nodelay=True)
    k = 0
    next_t = time.monotonic()
    while not rospy.is_shutdown():
        if rate_file and os.path.exists(rate_file):
            try:
                rate = float(open(rate_file).read().strip() or rate)
            except ValueError:
                pass
        m = msgs[k % frames.N]
        m.header.stamp = rospy.Time.now()
        m.header.seq = k
        pub.publish(m)
        log.write('%d %.6f\n' % (k, time.monotonic()))
        k += 1
        next_t += 1.0 / rate
        delay = next_t - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            next_t = time.monotonic()


if __name__ == '__main__':
    main()
