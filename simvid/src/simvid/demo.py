"""The QR demo's report: prints what the app behind the camera decoded and saves pictures.

Waits for the first message on ``/barcode`` (the thesis's console output 4.7.1), prints it,
then writes one PNG per image topic (the spectator view and the phone's camera image,
thesis figure 4.9) from frames received after the code was decoded.
"""
import os
import threading

import cv2

from .imageconv import UnsupportedEncoding, image_to_rgb

__all__ = ['DemoReport']


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
