#!/usr/bin/env python3
"""The app under test of the thesis's QR scenario (4.7, 5.4): it reads the phone camera,
decodes QR codes with zbar and shows the result on the phone's own display.

Subscribes ~image (default /mobile_device/image_raw, sensor_msgs/Image).
Publishes ~result (std_msgs/String, 'QR-Code,<data>' once per new code) and ~screen
(sensor_msgs/Image, 320x480 rgb8: green with the text when a code was read, grey before;
the scenario points the phone's display_topic at it).
"""
import cv2
import numpy as np
import rospy
from sensor_msgs.msg import Image
from std_msgs.msg import String

from simvid import barcode
from simvid.imageconv import array_to_image, image_to_rgb


def screen(text):
    img = np.full((480, 320, 3), (90, 90, 90) if not text else (30, 200, 60), np.uint8)
    for i, part in enumerate((text or 'scanning...').split(',')):
        cv2.putText(img, part[:24], (10, 200 + 30 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
                    (255, 255, 255), 2)
    return img


def main():
    rospy.init_node('qr_app')
    pub = rospy.Publisher('~result', String, queue_size=10, latch=True)
    scr = rospy.Publisher('~screen', Image, queue_size=1, latch=True)
    last = [None]
    scr.publish(array_to_image(screen(None), 'rgb8'))

    def on_image(msg):
        found = barcode.decode(image_to_rgb(msg), 'rgb8')
        if not found:
            return
        text = barcode.format_barcode(*found[0])
        if text != last[0]:
            last[0] = text
            pub.publish(String(text))
            scr.publish(array_to_image(screen(text), 'rgb8', stamp=msg.header.stamp))

    rospy.Subscriber(rospy.get_param('~image', '/mobile_device/image_raw'), Image, on_image,
                     queue_size=10, buff_size=1 << 24)
    rospy.spin()


if __name__ == '__main__':
    main()
