#!/usr/bin/env python3
"""Closed loop through the video texture: an image published to the phone display's
image_in is rendered on the screen (unlit: it glows in the dark room), a second camera films the screen, barcode_reader
decodes it; the same picture loaded through load_file is decoded again; a second display
in the same world shows its own picture from its own topics."""
import os
import sys
import time
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Image
from std_msgs.msg import String

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from textvid_common import (PAPER, PAYLOAD, SCREEN, Watch, blue_fraction,  # noqa: E402
                            connected, screen_image)
from simvid import barcode, qrassets  # noqa: E402
from simvid.imageconv import array_to_image  # noqa: E402

QR_PAYLOAD = 'QR-Code,' + PAYLOAD
QR_URL = 'QR-Code,' + qrassets.DEMO_URL


class ClosedLoop(unittest.TestCase):
    def test_closed_loop(self):
        w = Watch()
        image_in = rospy.Publisher('/phone/image_in', Image, queue_size=1, latch=True)
        load_file = rospy.Publisher('/phone/load_file', String, queue_size=1, latch=True)
        load_file2 = rospy.Publisher('/phone2/load_file', String, queue_size=1, latch=True)

        # 1. the world renders; both displays are blue until their first image
        # (the renderer is created by the camera's first frame; the displays' textures
        # follow in the next one)
        w.wait(lambda: w.frame, 90, 'the first image of the screen camera')
        w.wait(lambda: w.frames >= 3, 30, 'three camera frames')
        blue = blue_fraction(w.frame[1])
        self.assertGreater(blue, 0.2, 'displays not blue at start (%.3f)' % blue)
        t0 = time.time()
        time.sleep(1.5)
        self.assertEqual(w.codes_since(0), [], 'a barcode before any image was shown')

        # 2. image topic -> display -> camera -> zbar
        t1 = time.time()
        connected(image_in).publish(screen_image('rgb8'))
        w.wait(lambda: w.codes_since(t1, QR_PAYLOAD), 30, QR_PAYLOAD + ' on /barcode')
        self.assertEqual(w.codes_since(t0, QR_URL), [], 'phone2 must still be blank')
        rgb = w.frame_after(time.time())
        self.assertGreater(blue_fraction(rgb), 0.1, 'phone2 lost its blue')
        self.assertLess(blue_fraction(rgb), blue - 0.1, 'phone still blue')
        # unlit: in the dark room the lit white card (top of the view) is dim, the screen's
        # white glows at full brightness
        gray = rgb.astype(float).mean(axis=2)
        card = float(np.median(gray[10:50, 270:370]))
        self.assertLess(card, 80, 'the white card is lit brightly (%.0f): room not dark' % card)
        self.assertGreater((gray >= 240).mean(), 0.08, 'the screen does not glow')

        # 3. blank the screen (mono8), the code disappears
        t2 = time.time()
        gray = array_to_image(np.full((800, 480), 128, np.uint8), 'mono8')
        image_in.publish(gray)
        w.wait(lambda: w.frame if w.frame and w.frame[0] > t2 + 0.3
               and not barcode.decode(w.frame[1]) else None, 30,
               'the camera to see the blanked screen')
        t3 = time.time()

        # 4. the same picture through load_file: decoded again
        connected(load_file).publish(String(data=SCREEN))
        w.wait(lambda: w.codes_since(t3, QR_PAYLOAD), 30,
               QR_PAYLOAD + ' again after load_file')

        # 5. the second display, its own topic: both codes in view at once
        t4 = time.time()
        connected(load_file2).publish(String(data=PAPER))
        w.wait(lambda: w.codes_since(t4, QR_URL), 30, QR_URL + ' from the second display')
        found = set(w.decoded_after(time.time()))
        self.assertEqual(found, {('QR-Code', PAYLOAD), ('QR-Code', qrassets.DEMO_URL)})
        self.assertEqual(w.errors_since(0, 'video texture'), [])


if __name__ == '__main__':
    rospy.init_node('textvid_closed_loop_test')
    rostest.rosrun('mobile_device_sim', 'textvid_closed_loop', ClosedLoop, sys.argv)
