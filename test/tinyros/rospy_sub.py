#!/usr/bin/env python3
"""rospy sensor_msgs/Image subscriber for bench/tinyros: counts frames for --seconds and
prints "stats frames=N fps=F latency_ms=L" (rates from the first frame on)."""
import argparse
import time

import rospy
from sensor_msgs.msg import Image


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('topic')
    ap.add_argument('--seconds', type=float, default=5.0)
    a = ap.parse_args(rospy.myargv()[1:])
    rospy.init_node('tinyros_bench_rospy_sub', anonymous=True)
    st = {'n': 0, 'first': None, 'last': None, 'lat': 0.0}

    def cb(msg):
        now = time.time()
        st['lat'] += now - msg.header.stamp.to_sec()
        st['last'] = now
        if st['first'] is None:
            st['first'] = now
        st['n'] += 1

    rospy.Subscriber(a.topic, Image, cb, queue_size=10, tcp_nodelay=True)
    t0 = time.time()
    while time.time() - t0 < a.seconds and not rospy.is_shutdown():
        time.sleep(0.05)
    n = st['n']
    span = (st['last'] - st['first']) if n > 1 else 0.0
    print('stats frames=%d elapsed=%.3f fps=%.2f latency_ms=%.3f' % (
        n, time.time() - t0, (n - 1) / span if span > 0 else 0.0, 1000.0 * st['lat'] / n if n else 0.0),
        flush=True)
    rospy.signal_shutdown('done')


if __name__ == '__main__':
    main()
