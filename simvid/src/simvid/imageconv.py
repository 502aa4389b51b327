"""Conversion helpers between sensor_msgs/Image and numpy arrays.

One place for every component that reads or writes images (video texture, image_sink,
barcode reader, vnc_image_client, pcl2image, the camera). The common 8-bit encodings are
converted here with plain numpy views (no copy where the layout allows); anything else
that cv_bridge understands (16-bit, Bayer, YUV422, ...) goes through cv_bridge.

Errors are raised as ``UnsupportedEncoding`` (a ValueError) with a message that names the
encoding, so a node can log one clear line and keep the last good image.
"""
import numpy as np

__all__ = ['UnsupportedEncoding', 'CHANNELS', 'image_to_array', 'image_to_rgb',
           'image_to_rgba', 'array_to_image', 'rgb_from_array']

# encoding -> (channels, channel order as understood by to_rgb)
CHANNELS = {
    'rgb8': 3, 'bgr8': 3, 'rgba8': 4, 'bgra8': 4, 'mono8': 1,
    '8UC1': 1, '8UC3': 3, '8UC4': 4, '8SC1': 1, '8SC3': 3, '8SC4': 4,
}


class UnsupportedEncoding(ValueError):
    """An image whose encoding or layout cannot be converted."""


def _check_layout(msg, channels):
    h, w = int(msg.height), int(msg.width)
    step = int(msg.step)
    if h <= 0 or w <= 0:
        raise UnsupportedEncoding('empty image (%dx%d, encoding %r)' % (w, h, msg.encoding))
    if step < w * channels:
        raise UnsupportedEncoding('image step %d is smaller than width %d x %d channels '
                                  '(encoding %r)' % (step, w, channels, msg.encoding))
    if len(msg.data) < step * h:
        raise UnsupportedEncoding('image data has %d bytes, %dx%d with step %d needs %d '
                                  '(encoding %r)' % (len(msg.data), w, h, step, step * h,
                                                     msg.encoding))
    return h, w, step


def image_to_array(msg):
    """Return (array, encoding) for a sensor_msgs/Image.

    The array is HxWxC uint8 (C = 1, 3 or 4) in the message's own channel order, the
    encoding is the message's (normalised: 8UC3 -> bgr8 as OpenCV means it, 8UC1 -> mono8,
    8UC4 -> bgra8). Other encodings are converted through cv_bridge to rgb8.
    """
    enc = msg.encoding
    if enc in CHANNELS:
        c = CHANNELS[enc]
        h, w, step = _check_layout(msg, c)
        buf = np.frombuffer(msg.data, dtype=np.uint8, count=step * h).reshape(h, step)
        arr = buf[:, :w * c].reshape(h, w, c)
        norm = {'8UC1': 'mono8', '8SC1': 'mono8', '8UC3': 'bgr8', '8SC3': 'bgr8',
                '8UC4': 'bgra8', '8SC4': 'bgra8'}.get(enc, enc)
        return arr, norm
    return _via_cv_bridge(msg), 'rgb8'


def _via_cv_bridge(msg):
    try:
        from cv_bridge import CvBridge, CvBridgeError
    except ImportError:  # pragma: no cover - cv_bridge is a declared dependency
        raise UnsupportedEncoding('unsupported image encoding %r (cv_bridge missing)'
                                  % msg.encoding)
    try:
        arr = CvBridge().imgmsg_to_cv2(msg, desired_encoding='rgb8')
    except (CvBridgeError, TypeError, ValueError, AttributeError) as e:
        raise UnsupportedEncoding('unsupported image encoding %r: %s' % (msg.encoding, e))
    return np.ascontiguousarray(arr).reshape(arr.shape[0], arr.shape[1], 3)


def rgb_from_array(arr, encoding):
    """Convert an HxWxC array in ``encoding`` to HxWx3 rgb (uint8)."""
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if encoding in ('rgb8',):
        return arr
    if encoding == 'bgr8':
        return arr[:, :, ::-1]
    if encoding == 'rgba8':
        return arr[:, :, :3]
    if encoding == 'bgra8':
        return arr[:, :, 2::-1]
    if encoding == 'mono8':
        return np.repeat(arr[:, :, :1], 3, axis=2)
    raise UnsupportedEncoding('unsupported image encoding %r' % encoding)


def image_to_rgb(msg):
    """sensor_msgs/Image -> HxWx3 uint8 RGB array (a view where possible)."""
    arr, enc = image_to_array(msg)
    return rgb_from_array(arr, enc)


def image_to_rgba(msg):
    """sensor_msgs/Image -> HxWx4 uint8 RGBA array (alpha 255 where the source has none)."""
    arr, enc = image_to_array(msg)
    if enc == 'rgba8':
        return arr
    if enc == 'bgra8':
        return arr[:, :, [2, 1, 0, 3]]
    rgb = rgb_from_array(arr, enc)
    out = np.empty(rgb.shape[:2] + (4,), np.uint8)
    out[:, :, :3] = rgb
    out[:, :, 3] = 255
    return out


def array_to_image(arr, encoding='rgb8', stamp=None, frame_id='', msg=None):
    """HxW(xC) uint8 array -> sensor_msgs/Image (the data is copied once, as bytes)."""
    from sensor_msgs.msg import Image
    arr = np.ascontiguousarray(arr, dtype=np.uint8)
    c = 1 if arr.ndim == 2 else arr.shape[2]
    if encoding in CHANNELS and CHANNELS[encoding] != c:
        raise UnsupportedEncoding('array with %d channels cannot be %r' % (c, encoding))
    if msg is None:
        msg = Image()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(arr.shape[0]), int(arr.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = int(arr.shape[1] * c)
    msg.data = arr.tobytes()
    return msg
