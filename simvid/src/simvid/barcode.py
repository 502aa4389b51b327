"""Barcode reader: sensor_msgs/Image -> zbar -> ``"<symbol type>,<data>"`` strings.

The thesis (section 4.7, figure 4.8) fed the phone camera's ``image_raw`` to the ROS
``zbar_barcode_reader_node``, which published ``QR-Code,http://www.vmi.ei.tum.de`` on
``/barcode``. This module is that node's logic without ROS (the executable is
``simvid/nodes/barcode_reader``):

* ``decode(gray_or_rgb)`` runs zbar (through python3-pyzbar) and returns
  ``[(type name, data)]``; type names are zbar's own (``zbar_get_symbol_name``):
  ``QR-Code``, ``EAN-13``, ``EAN-8``, ``CODE-128``, ``CODE-39``, ``UPC-A``, ``I2/5`` ...
* ``format_barcode(type, data)`` gives the message text ``QR-Code,<data>``.
* ``Throttle`` drops a code that was already published less than ``period`` seconds ago.
* ``BarcodeReader.process(msg, now)`` ties these together for one image message and
  returns the strings to publish; a bad image is reported by one log line per distinct
  problem (not one per frame), and the reader keeps working for the next good image.
"""
import ctypes
import logging

import numpy as np

from sim_world.logonce import LogOnce

from .imageconv import UnsupportedEncoding, image_to_array

__all__ = ['main', 'BarcodeError', 'symbol_name', 'to_gray', 'decode', 'locate', 'format_barcode',
           'Throttle', 'BarcodeReader']

log = logging.getLogger('simvid.barcode')

# pyzbar's enum names -> zbar's symbol names; used only when libzbar's own
# zbar_get_symbol_name cannot be called.
_FALLBACK_NAMES = {
    'EAN2': 'EAN-2', 'EAN5': 'EAN-5', 'EAN8': 'EAN-8', 'UPCE': 'UPC-E', 'ISBN10': 'ISBN-10',
    'UPCA': 'UPC-A', 'EAN13': 'EAN-13', 'ISBN13': 'ISBN-13', 'COMPOSITE': 'COMPOSITE',
    'I25': 'I2/5', 'DATABAR': 'DataBar', 'DATABAR_EXP': 'DataBar-Exp', 'CODABAR': 'Codabar',
    'CODE39': 'CODE-39', 'PDF417': 'PDF417', 'QRCODE': 'QR-Code', 'SQCODE': 'SQ-Code',
    'CODE93': 'CODE-93', 'CODE128': 'CODE-128',
}
_zbar_name_fn = None


class BarcodeError(RuntimeError):
    """zbar is not available or failed on an image."""


def _zbar():
    try:
        from pyzbar import pyzbar
    except ImportError as e:  # pragma: no cover - python3-pyzbar is a declared dependency
        raise BarcodeError('zbar is not available (install python3-pyzbar): %s' % e)
    return pyzbar


def symbol_name(pyzbar_type):
    """zbar's name of a symbol type given as pyzbar reports it ('QRCODE' -> 'QR-Code')."""
    global _zbar_name_fn
    pyzbar = _zbar()
    try:
        value = pyzbar.ZBarSymbol[pyzbar_type].value
    except KeyError:
        return str(pyzbar_type)
    if _zbar_name_fn is None:
        try:
            from pyzbar import wrapper
            _zbar_name_fn = wrapper.zbar_function('zbar_get_symbol_name', ctypes.c_char_p,
                                                  ctypes.c_int)
        except Exception:  # noqa: BLE001 - any failure: use the table
            _zbar_name_fn = False
    if _zbar_name_fn:
        name = _zbar_name_fn(value)
        if name and name != b'UNKNOWN':
            return name.decode('ascii', 'replace')
    return _FALLBACK_NAMES.get(pyzbar_type, str(pyzbar_type))


def to_gray(arr, encoding='rgb8'):
    """HxW or HxWxC uint8 array in ``encoding`` -> contiguous HxW uint8 luminance."""
    arr = np.asarray(arr)
    if arr.dtype != np.uint8:
        raise UnsupportedEncoding('barcode reader needs 8-bit images, got %s' % arr.dtype)
    if arr.ndim == 2 or arr.shape[2] == 1:
        return np.ascontiguousarray(arr.reshape(arr.shape[0], arr.shape[1]))
    import cv2
    code = {'rgb8': cv2.COLOR_RGB2GRAY, 'bgr8': cv2.COLOR_BGR2GRAY,
            'rgba8': cv2.COLOR_RGBA2GRAY, 'bgra8': cv2.COLOR_BGRA2GRAY}.get(encoding)
    if code is None:
        raise UnsupportedEncoding('barcode reader cannot convert encoding %r to gray'
                                  % encoding)
    return cv2.cvtColor(np.ascontiguousarray(arr), code)


def _text(data):
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError:
        return data.decode('latin-1')


def decode(image, encoding='rgb8'):
    """All barcodes zbar finds in ``image`` (array, see ``to_gray``), in zbar's order, as
    ``[(type name, data text)]``."""
    return [(t, d) for t, d, _poly in locate(image, encoding)]


def locate(image, encoding='rgb8'):
    """Like ``decode``, with where each code lies: ``[(type name, data text, [(x, y), ...])]``
    (zbar's polygon in image pixels; the scenario report outlines it)."""
    pyzbar = _zbar()
    gray = to_gray(image, encoding)
    h, w = gray.shape
    try:
        found = pyzbar.decode((gray.tobytes(), w, h))
    except Exception as e:  # noqa: BLE001 - pyzbar raises its own and ctypes errors
        raise BarcodeError('zbar failed on a %dx%d image: %s' % (w, h, e))
    return [(symbol_name(d.type), _text(d.data), [(int(p.x), int(p.y)) for p in d.polygon])
            for d in found]


def format_barcode(type_name, data):
    """The /barcode message text, e.g. ``QR-Code,http://vmi.lmt.ei.tum.de``."""
    return '%s,%s' % (type_name, data)


class Throttle(object):
    """Lets the same key through at most once per ``period`` seconds (0: always).

    The window starts when a key is let through, so a code that stays in view is
    published again every ``period`` seconds, like zbar_ros's throttle_repeated_barcodes.
    """

    def __init__(self, period):
        self.period = float(period)
        self._last = {}

    def allow(self, key, now):
        if self.period <= 0:
            return True
        last = self._last.get(key)
        if last is not None and 0 <= now - last < self.period:
            return False
        self._last[key] = now
        # forget entries that cannot throttle anything any more
        if len(self._last) > 256:
            self._last = {k: t for k, t in self._last.items()
                          if 0 <= now - t < self.period}
        return True


class BarcodeReader(object):
    """Decodes image messages and returns the throttled ``type,data`` strings to publish.

    ``logger`` is called with one line for each *new* kind of problem (an unsupported
    encoding is reported once, not at every frame); ``problems`` counts all of them.
    """

    def __init__(self, throttle=2.0, logger=None):
        self.throttle = Throttle(throttle)
        self.logger = logger or log.error
        self.problems = 0
        self.images = 0
        self._reported = LogOnce(say=self.logger)

    def _problem(self, text):
        self.problems += 1
        self._reported(text)

    def decode_msg(self, msg):
        """[(type, data)] of one sensor_msgs/Image; [] and one log line when the image
        cannot be read."""
        try:
            arr, enc = image_to_array(msg)
            return decode(arr, enc)
        except UnsupportedEncoding as e:
            self._problem('barcode_reader: cannot read image: %s' % e)
        except BarcodeError as e:
            self._problem('barcode_reader: %s' % e)
        return []

    def process(self, msg, now):
        """Strings to publish for image ``msg`` received at time ``now`` (seconds)."""
        self.images += 1
        out = []
        for type_name, data in self.decode_msg(msg):
            text = format_barcode(type_name, data)
            if self.throttle.allow(text, now):
                out.append(text)
        return out


def main():
    """``rosrun mobile_device_sim barcode_reader`` (the whole node; the script in
    simvid/nodes/ only calls it)."""
    import time
    import rospy
    from sensor_msgs.msg import Image
    from std_msgs.msg import String
    rospy.init_node('barcode_reader')
    image_topic = rospy.get_param('~image_topic', 'image')
    barcode_topic = rospy.get_param('~barcode_topic', '/barcode')
    throttle = float(rospy.get_param('~throttle_repeated_barcodes', 2.0))
    reader = BarcodeReader(throttle=throttle, logger=rospy.logerr)
    pub = rospy.Publisher(barcode_topic, String, queue_size=10)

    def on_image(msg):
        for text in reader.process(msg, time.monotonic()):
            rospy.loginfo('barcode: %s', text)
            pub.publish(String(data=text))

    # queue_size=1: decode the newest frame, drop the ones zbar could not keep up with
    rospy.Subscriber(image_topic, Image, on_image, queue_size=1, buff_size=2 ** 24)
    rospy.loginfo('barcode_reader: %s -> %s (throttle %.2f s)',
                  rospy.resolve_name(image_topic), rospy.resolve_name(barcode_topic), throttle)
    rospy.spin()
