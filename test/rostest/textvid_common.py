"""Helpers shared by the textvid rostest nodes (imported from the node's own folder)."""
import os
import threading
import time

import numpy as np
import rospy
from rosgraph_msgs.msg import Clock, Log
from sensor_msgs.msg import Image
from std_msgs.msg import String

from simvid import barcode, qrassets
from simvid.imageconv import image_to_rgb

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PAYLOAD = qrassets.CLOSED_LOOP_PAYLOAD
SCREEN = os.path.join(qrassets.MEDIA_DIR, qrassets.CLOSED_LOOP_FILE)
PAPER = os.path.join(qrassets.MEDIA_DIR, qrassets.PAPER_FILE)
CAMERA = '/screen_cam/image_raw'


def blue_fraction(rgb):
    """Share of pixels in pure display blue (the video texture before its first image)."""
    r, g, b = (rgb[:, :, i].astype(int) for i in range(3))
    return float(((b > 200) & (r < 60) & (g < 60)).mean())


class Watch(object):
    """Collects /barcode texts, camera frames, /clock and ERROR lines of /rosout,
    each with the wall time it arrived."""

    def __init__(self):
        self.lock = threading.RLock()
        self.codes = []          # (wall time, text)
        self.errors = []         # (wall time, node name, text)
        self.frame = None        # (wall time, HxWx3 rgb, stamp)
        self.frames = 0
        self.clock = None
        rospy.Subscriber('/barcode', String, self._code, queue_size=100)
        rospy.Subscriber('/rosout', Log, self._log, queue_size=1000)
        rospy.Subscriber(CAMERA, Image, self._image, queue_size=1, buff_size=2 ** 24)
        rospy.Subscriber('/clock', Clock, self._clock, queue_size=1)

    def _code(self, msg):
        with self.lock:
            self.codes.append((time.time(), msg.data))

    def _log(self, msg):
        if msg.level >= Log.ERROR:
            with self.lock:
                self.errors.append((time.time(), msg.name, msg.msg))

    def _image(self, msg):
        rgb = image_to_rgb(msg).copy()
        with self.lock:
            self.frame = (time.time(), rgb, msg.header.stamp)
            self.frames += 1

    def _clock(self, msg):
        with self.lock:
            self.clock = msg.clock

    # -- waiting -------------------------------------------------------------------------
    def wait(self, cond, timeout, what):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                v = cond()
            if v:
                return v
            time.sleep(0.05)
        raise AssertionError('timed out after %.0f s waiting for %s' % (timeout, what))

    def codes_since(self, t, text=None):
        with self.lock:
            return [c for tt, c in self.codes if tt >= t and (text is None or c == text)]

    def errors_since(self, t, needle):
        with self.lock:
            return [(n, m) for tt, n, m in self.errors if tt >= t and needle in m]

    def frame_after(self, t, timeout=20.0):
        """A camera frame that arrived after wall time t."""
        return self.wait(lambda: self.frame if self.frame and self.frame[0] > t + 0.3
                         else None, timeout, 'a camera frame after t=%.1f' % t)[1]

    def decoded_after(self, t, timeout=20.0):
        return barcode.decode(self.frame_after(t, timeout))


def connected(pub, timeout=20.0):
    deadline = time.time() + timeout
    while pub.get_num_connections() == 0:
        if time.time() > deadline:
            raise AssertionError('nobody subscribes %s' % pub.resolved_name)
        time.sleep(0.05)
    return pub


def screen_image(encoding='rgb8'):
    import cv2
    from simvid.imageconv import array_to_image
    bgr = cv2.imread(SCREEN, cv2.IMREAD_COLOR)
    conv = {'rgb8': bgr[:, :, ::-1], 'bgr8': bgr,
            'bgra8': np.dstack([bgr, np.full(bgr.shape[:2], 255, np.uint8)]),
            'mono8': cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)}[encoding]
    return array_to_image(conv, encoding)
