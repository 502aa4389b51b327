"""The QR demo's report: prints what the app behind the camera decoded and saves pictures.

Waits for the first message on ``/barcode`` (the thesis's console output 4.7.1), prints it,
then writes one PNG per image topic (the spectator view and the phone's camera image,
thesis figure 4.9) from frames received after the code was decoded.
"""
import os
import threading

import cv2

from .imageconv import UnsupportedEncoding, image_to_rgb

__all__ = ['main', 'DemoReport']


class DemoReport(object):
    def __init__(self, out_dir, images, printer=print):
        """images: {topic: file name}."""
        self.out_dir = out_dir
        self.images = dict(images)
        self.printer = printer
        self.codes = []
        self.written = {}
        self.done = threading.Event()
        self._lock = threading.Lock()

    def on_barcode(self, text):
        with self._lock:
            if text in self.codes:
                return
            self.codes.append(text)
        self.printer('QR demo: /barcode data: %s' % text)

    def on_image(self, topic, msg):
        if not self.codes or topic in self.written:
            return
        try:
            rgb = image_to_rgb(msg)
        except UnsupportedEncoding as e:
            self.printer('QR demo: cannot save %s: %s' % (topic, e))
            return
        os.makedirs(self.out_dir, exist_ok=True)
        path = os.path.join(self.out_dir, self.images[topic])
        if not cv2.imwrite(path, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
            self.printer('QR demo: could not write %s' % path)
            return
        with self._lock:
            self.written[topic] = path
            finished = len(self.written) == len(self.images)
        self.printer('QR demo: wrote %s (%s, %dx%d)' % (path, topic, msg.width, msg.height))
        if finished:
            self.done.set()


def main():
    """``rosrun mobile_device_sim qr_demo_report`` (the whole node; the script in
    simvid/nodes/ only calls it)."""
    import os
    import rospy
    from sensor_msgs.msg import Image
    from std_msgs.msg import String
    rospy.init_node('qr_demo_report')
    out_dir = os.path.abspath(rospy.get_param('~out_dir', 'out'))
    images = {rospy.get_param('~spectator_topic', '/flycam/image_raw'): 'qr_demo_spectator.png',
              rospy.get_param('~camera_topic', '/mobile_device/image_raw'): 'qr_demo_phone_camera.png'}

    def say(text):
        print(text, flush=True)

    report = DemoReport(out_dir, images, printer=say)
    rospy.Subscriber(rospy.get_param('~barcode_topic', '/barcode'), String,
                     lambda m: report.on_barcode(m.data))
    for topic in images:
        rospy.Subscriber(topic, Image, lambda m, t=topic: report.on_image(t, m), queue_size=1,
                         buff_size=2 ** 24)
    say('QR demo: waiting for the phone\'s app to decode the QR code on the desk ...')
    exit_when_done = rospy.get_param('~exit_when_done', False)
    while not rospy.is_shutdown():
        if report.done.wait(0.2):
            if exit_when_done:
                say('QR demo: done')
                rospy.signal_shutdown('done')
                return 0
            say('QR demo: running; Ctrl-C to stop. Try from another terminal: rosservice call '
                '/gazebo/get_model_state \'{model_name: mobile_device, relative_entity_name: world}\'')
            rospy.spin()
    return 0
