"""image_sink: a ROS image topic becomes a V4L2 webcam (thesis section 4.6, table 4.6).

Everything here runs without a roscore; ``simvid/nodes/image_sink`` only reads the
parameters, subscribes and calls ``ImageSink.on_image`` and ``ImageSink.spin``.

* ``Converter`` (simvid.yuv) turns each image into a frame of the output size and format.
* ``FramePacer`` hands out write deadlines at ``fps``; the newest frame is written at each
  deadline, so a slower topic has its last frame repeated and readers never starve, and a
  faster topic has frames dropped instead of flooding the device.
* ``DeviceWriter`` owns the ``OutputDevice`` (simvid.v4l2): a missing device, a device that
  is not an output device or a refused format is ONE error line, then the device is
  retried every ``retry_period`` seconds while the node keeps running.
"""
import threading
import time

from sim_world.logonce import LogOnce
from simvid import imageconv
from simvid.v4l2 import DeviceError, OutputDevice
from simvid.yuv import Converter

__all__ = ['main', 'PARAMS', 'FramePacer', 'DeviceWriter', 'ImageSink', 'OnceLogger']

# thesis table 4.6, plus io_method and pixel_format
PARAMS = {
    'device': '/dev/video0',
    'topic': '/camera/image_raw',
    'width': 640,
    'height': 480,
    'fps': 15.0,
    'io_method': 'mmap',
    'pixel_format': 'yuyv',
    'retry_period': 1.0,
}


def OnceLogger(log):
    """Logs a message once, again only after a different message (or ``reset``): the
    repository's one log-once (sim_world.logonce)."""
    return LogOnce(say=log, until_changed=True)


class FramePacer(object):
    """Deadlines at a fixed rate; if the writer falls behind it skips, never bursts."""

    def __init__(self, fps, clock=time.monotonic):
        if not fps > 0:
            raise ValueError('fps must be positive, got %r' % (fps,))
        self.period = 1.0 / float(fps)
        self.clock = clock
        self.next_t = None

    def wait_time(self):
        """Seconds until the next frame is due (0 when due now)."""
        now = self.clock()
        if self.next_t is None:
            self.next_t = now
        return max(0.0, self.next_t - now)

    def done(self):
        """Mark the due frame written; schedule the next one."""
        now = self.clock()
        if self.next_t is None:
            self.next_t = now
        self.next_t += self.period
        if self.next_t < now - self.period:  # fell far behind: restart the grid
            self.next_t = now + self.period


class DeviceWriter(object):
    """Opens the output device lazily and reopens it after errors."""

    def __init__(self, device, width, height, fps, pixel_format='yuyv', io_method='mmap',
                 retry_period=1.0, log_error=print, log_info=print, clock=time.monotonic,
                 opener=OutputDevice):
        self.args = dict(device=device, width=width, height=height, fps=fps,
                         pixel_format=pixel_format, io_method=io_method)
        self.device = device
        self.retry_period = float(retry_period)
        self.err = OnceLogger(log_error)
        self.log_info = log_info
        self.clock = clock
        self.opener = opener
        self.dev = None
        self.next_try = 0.0
        self.opens = 0
        self.failures = 0

    @property
    def is_open(self):
        return self.dev is not None

    def ensure_open(self):
        if self.dev is not None:
            return True
        now = self.clock()
        if now < self.next_try:
            return False
        try:
            self.dev = self.opener(**self.args)
        except DeviceError as e:
            self.failures += 1
            self.next_try = now + self.retry_period
            self.err('image_sink: %s; retrying every %.1f s' % (e, self.retry_period))
            return False
        self.opens += 1
        self.err.reset()
        a = self.args
        io = getattr(self.dev, 'io_method', a['io_method'])
        why = getattr(self.dev, 'fallback', None)
        self.log_info('image_sink: writing %dx%d %s at %g fps to %s (%s I/O%s, driver %s)'
                      % (a['width'], a['height'], a['pixel_format'], a['fps'],
                         a['device'], io, (' instead of %s: %s' % (a['io_method'], why))
                         if why else '', getattr(self.dev, 'driver', '?')))
        return True

    def write(self, frame):
        """Write one frame; False (and the device closed for a retry) on a device error."""
        if not self.ensure_open():
            return False
        try:
            self.dev.write(frame)
            return True
        except DeviceError as e:
            self.err('image_sink: %s; closing the device, retrying every %.1f s'
                     % (e, self.retry_period))
            self.close()
            self.next_try = self.clock() + self.retry_period
            return False

    def close(self):
        if self.dev is not None:
            try:
                self.dev.close()
            finally:
                self.dev = None


class ImageSink(object):
    """The node's logic: images in (any thread), paced frames out (``step``/``spin``)."""

    def __init__(self, params=None, log_error=print, log_info=print, clock=time.monotonic,
                 opener=OutputDevice):
        p = dict(PARAMS)
        p.update(params or {})
        p['width'], p['height'] = int(p['width']), int(p['height'])
        if p['pixel_format'] in ('yuyv', 'uyvy') and p['width'] % 2:
            log_error('image_sink: width %d is odd but %s pairs pixels; writing %d pixel '
                      'wide frames instead' % (p['width'], p['pixel_format'], p['width'] + 1))
            p['width'] += 1
        self.params = p
        self.converter = Converter(p['width'], p['height'], p['pixel_format'])
        self.pacer = FramePacer(p['fps'], clock=clock)
        self.writer = DeviceWriter(p['device'], self.converter.width, self.converter.height,
                                   p['fps'], p['pixel_format'], p['io_method'],
                                   p['retry_period'], log_error, log_info, clock, opener)
        self.bad_input = OnceLogger(log_error)
        self.clock = clock
        self.lock = threading.Lock()
        self.frame = None          # newest converted frame (bytes)
        self.frame_seq = 0         # images converted so far
        self.written_seq = 0       # frame_seq of the last frame written
        self.stats = dict(images=0, bad_images=0, written=0, repeated=0, failed=0)
        self.stamp_of_frame = None
        self.last_latency = None
        self._black = None

    # -- input ---------------------------------------------------------------------------
    def on_image(self, msg):
        """Subscriber callback: convert now (in the ROS thread), keep only the newest."""
        try:
            frame = self.converter.convert(msg)
        except (imageconv.UnsupportedEncoding, ValueError) as e:
            with self.lock:
                self.stats['bad_images'] += 1
            self.bad_input('image_sink: dropping image from %s: %s'
                           % (self.params['topic'], e))
            return False
        self.bad_input.reset()
        with self.lock:
            self.frame = frame
            self.frame_seq += 1
            self.stats['images'] += 1
            self.stamp_of_frame = getattr(getattr(msg, 'header', None), 'stamp', None)
        return True

    def black_frame(self):
        if self._black is None:
            import numpy as np
            self._black = self.converter.rgb_to_bytes(
                np.zeros((self.converter.height, self.converter.width, 3), np.uint8))
        return self._black

    # -- output --------------------------------------------------------------------------
    def step(self):
        """Write the frame that is due now: the newest image, the last one again, or black
        before the first image arrives (so readers see the format and never starve)."""
        with self.lock:
            frame, seq = self.frame, self.frame_seq
        if frame is None:
            frame = self.black_frame()
        ok = self.writer.write(frame)
        self.pacer.done()
        if ok:
            self.stats['written'] += 1
            if seq and seq == self.written_seq:
                self.stats['repeated'] += 1
            self.written_seq = seq
        else:
            self.stats['failed'] += 1
        return ok

    def spin(self, is_shutdown, sleep=time.sleep):
        """Loop until ``is_shutdown()``: wait for the next deadline, write."""
        try:
            while not is_shutdown():
                wait = self.pacer.wait_time()
                if wait > 0:
                    sleep(min(wait, 0.1))
                    continue
                self.step()
        finally:
            self.writer.close()


def main():
    """``rosrun mobile_device_sim image_sink`` (the whole node; the script in
    simvid/nodes/ only calls it)."""
    import rospy
    from sensor_msgs.msg import Image
    rospy.init_node('image_sink')
    params = {k: rospy.get_param('~' + k, v) for k, v in PARAMS.items()}
    try:
        sink = ImageSink(params, log_error=rospy.logerr, log_info=rospy.loginfo)
    except ValueError as e:
        rospy.logfatal('image_sink: bad parameter: %s' % e)
        return 2
    rospy.Subscriber(sink.params['topic'], Image, sink.on_image, queue_size=1,
                     buff_size=1 << 24, tcp_nodelay=True)
    sink.spin(rospy.is_shutdown)
    rospy.loginfo('image_sink: stopped after %(written)d frames (%(repeated)d repeated, '
                  '%(images)d images, %(bad_images)d bad)' % sink.stats)
    return 0
