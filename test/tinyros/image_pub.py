#!/usr/bin/env python3
"""rospy sensor_msgs/Image publisher for the tinyros tests.

    image_pub.py TOPIC [--width W] [--height H] [--encoding rgb8] [--rate HZ (0: unthrottled)]
                 [--count N (0: forever)] [--wait-subscribers N]

Frame i has frame_id "frame_<i>" and data that differs for every i; after publishing
it prints "pub <i> <crc32 of data>" so a test can check what a subscriber received
byte for byte."""
import argparse
import sys
import time
import zlib

import numpy as np
import rospy
from sensor_msgs.msg import Image

CHANNELS = {'rgb8': 3, 'bgr8': 3, 'rgba8': 4, 'bgra8': 4, 'mono8': 1}


def frame_data(i, n):
    return ((np.arange(n, dtype=np.uint32) * 7 + i * 13 + (np.arange(n, dtype=np.uint32) >> 11)) & 0xFF) \
        .astype(np.uint8).tobytes()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('topic')
    ap.add_argument('--width', type=int, default=64)
    ap.add_argument('--height', type=int, default=48)
    ap.add_argument('--encoding', default='rgb8')
    ap.add_argument('--rate', type=float, default=30.0)
    ap.add_argument('--count', type=int, default=0)
    ap.add_argument('--wait-subscribers', type=int, default=0)
    a = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node('tinyros_test_pub', anonymous=False, disable_signals=False)
    pub = rospy.Publisher(a.topic, Image, queue_size=1)
    deadline = time.time() + 30
    while pub.get_num_connections() < a.wait_subscribers and time.time() < deadline and not rospy.is_shutdown():
        time.sleep(0.05)
    step = a.width * CHANNELS[a.encoding]
    n = step * a.height
    i = 0
    period = 1.0 / a.rate if a.rate > 0 else 0
    nxt = time.time()
    while not rospy.is_shutdown() and (a.count == 0 or i < a.count):
        data = frame_data(i, n)
        msg = Image(height=a.height, width=a.width, encoding=a.encoding, is_bigendian=0, step=step, data=data)
        msg.header.frame_id = 'frame_%d' % i
        msg.header.stamp = rospy.Time.now()
        pub.publish(msg)
        sys.stdout.write('pub %d %08x\n' % (i, zlib.crc32(data) & 0xFFFFFFFF))
        sys.stdout.flush()
        i += 1
        if period:
            nxt += period
            time.sleep(max(0.0, nxt - time.time()))
    time.sleep(0.5)


if __name__ == '__main__':
    main()
