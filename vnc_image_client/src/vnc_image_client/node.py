"""The vnc_image_client ROS node (thesis section 4.4.1, table 4.5).

Private parameters:
  ~image_topic   (/vnc_image)  topic of the sensor_msgs/Image (rgba8, framebuffer size)
  ~host          (localhost)   VNC server
  ~port          (5901)        VNC server port
  ~password      (unset)       VNC password; read once, then deleted from the parameter
                               server. Unset and the server wants one: asked on the
                               terminal without echo when stdin is a TTY, else one error.
  ~password_file (unset)       used when ~password is unset: a file whose first line is
                               the password (keeps it out of launch files and roslaunch's
                               parameter summary)
  ~publish_rate  (15)          maximum images per second
  ~frame_id      (vnc)         header.frame_id of the images
  ~encodings     (LibVNCClient's default) RFB encodings to offer, e.g. "tight zrle raw"
  ~republish_period (1.0)      while the screen does not change, the latest image is
                               published again after this many seconds (0 = never)

Two threads as in the thesis: VncReceiver handles the server's messages, the publisher
thread copies the framebuffer under the shared lock and publishes it. An image is
published when the screen changed (at most publish_rate per second) and repeated every
~republish_period while it does not; a new subscriber immediately gets the latest image.
"""
import getpass
import os
import sys
import threading
import time

import rospy
from sensor_msgs.msg import Image

from .client import VncAuthError, VncClient, VncReceiver

FATAL_LOG_GRACE = 1.0   # s between a fatal error's log line and the node's shutdown

try:
    from simvid.imageconv import array_to_image
except ImportError:  # pragma: no cover - the stack is installed together with simvid
    array_to_image = None


def read_password_file(path, log_error):
    """First line of ``path`` without its line end, or None (one error line) when the file
    cannot be read."""
    try:
        with open(os.path.expanduser(str(path)), 'rb') as f:
            line = f.readline()
    except (OSError, IOError) as e:
        log_error('cannot read ~password_file %r: %s' % (path, e.strerror or e))
        return None
    return line.rstrip(b'\r\n').decode('utf-8', 'replace')


class PasswordSource(object):
    """Where the VNC password comes from: the parameter (read once, deleted), else the
    terminal (getpass, no echo) when stdin is a TTY, else nothing.

    The password is kept in this object only; it is never logged or put back on the
    parameter server."""

    MAX_PROMPTS = 3

    def __init__(self, param_value=None, stdin=None, prompt=getpass.getpass, where=''):
        self._value = param_value
        self._from_param = param_value is not None
        self._stdin = stdin if stdin is not None else sys.stdin
        self._prompt = prompt
        self._where = where
        self.prompts = 0

    @classmethod
    def from_param(cls, name='~password', file_param='~password_file', **kw):
        """Read and delete the parameter (also when it is empty). Without it, the first
        line of the file named by ``~password_file`` (keeps the password out of launch
        files and roslaunch's parameter summary)."""
        value = None
        if rospy.has_param(name):
            value = rospy.get_param(name)
            value = '' if value is None else str(value)
            try:
                rospy.delete_param(name)
            except KeyError:
                pass
        elif rospy.has_param(file_param):
            value = read_password_file(rospy.get_param(file_param), rospy.logerr)
        return cls(value, **kw)

    def interactive(self):
        try:
            return bool(self._stdin) and self._stdin.isatty()
        except (AttributeError, ValueError):
            return False

    def __call__(self):
        if self._value is not None:
            return self._value
        if self.interactive() and self.prompts < self.MAX_PROMPTS:
            self.prompts += 1
            self._value = self._prompt('Password for VNC server %s: ' % self._where)
            return self._value
        return None

    def retry(self):
        """After a rejected password: may we ask again? Only when it came from the TTY."""
        if self._from_param or not self.interactive() or self.prompts >= self.MAX_PROMPTS:
            return False
        self._value = None
        return True


class ImagePublisherThread(threading.Thread):
    """Copies the framebuffer under the client's lock and publishes rgba8 images."""

    def __init__(self, client, topic, rate, frame_id='vnc', republish=1.0):
        threading.Thread.__init__(self, name='vnc-publisher')
        self.republish = republish
        self.daemon = True
        self.client = client
        self.period = 1.0 / rate if rate and rate > 0 else 0.0
        self.frame_id = frame_id
        self.latest = None
        self._latest_lock = threading.Lock()
        self.published = 0
        self.pub = rospy.Publisher(topic, Image, queue_size=2,
                                   subscriber_listener=_SendLatest(self))

    def _to_msg(self, img):
        stamp = rospy.Time.now()
        if array_to_image is not None:
            return array_to_image(img, 'rgba8', stamp=stamp, frame_id=self.frame_id)
        msg = Image()
        msg.header.stamp = stamp
        msg.header.frame_id = self.frame_id
        msg.height, msg.width = img.shape[:2]
        msg.encoding = 'rgba8'
        msg.step = img.shape[1] * 4
        msg.data = img.tobytes()
        return msg

    def run(self):
        last_seq = 0     # seq counts complete frames from 1: the first one is always new
        buf = None
        next_t = 0.0
        last_pub = time.monotonic()
        while not rospy.is_shutdown():
            seq = self.client.wait_update(last_seq, 0.25)
            fresh = seq > last_seq
            # a static screen: repeat the current image now and then, so subscribers that
            # missed it (or dropped it while starting up) still get it
            due = self.republish and time.monotonic() - last_pub >= self.republish
            if not fresh and not (due and self.client.valid):
                continue
            now = time.monotonic()
            if fresh and now < next_t:
                time.sleep(next_t - now)
            img, seq = self.client.snapshot(buf)
            last_seq = max(last_seq, seq)
            if img is None:          # connection dropped meanwhile
                continue
            buf = img
            msg = self._to_msg(img)
            with self._latest_lock:
                self.latest = msg
            self.pub.publish(msg)
            last_pub = time.monotonic()
            self.published += 1
            if fresh:
                next_t = max(next_t + self.period, time.monotonic()) if self.period else 0.0


class _SendLatest(rospy.SubscribeListener):
    def __init__(self, owner):
        self.owner = owner

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        with self.owner._latest_lock:
            msg = self.owner.latest
        if msg is not None:
            peer_publish(msg)


class _RospyLog(object):
    info = staticmethod(rospy.loginfo)
    warn = staticmethod(rospy.logwarn)
    error = staticmethod(rospy.logerr)


def main(argv=None):
    rospy.init_node('vnc_image_client', argv=argv)
    topic = rospy.get_param('~image_topic', '/vnc_image')
    host = str(rospy.get_param('~host', 'localhost'))
    port = rospy.get_param('~port', 5901)
    rate = rospy.get_param('~publish_rate', 15)
    frame_id = rospy.get_param('~frame_id', 'vnc')
    encodings = rospy.get_param('~encodings', '') or None
    republish = rospy.get_param('~republish_period', 1.0)
    password = PasswordSource.from_param('~password', where='%s:%s' % (host, port))
    try:
        port = int(port)
        if not 0 < port < 65536:
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('~port must be a TCP port number (1..65535), got %r; using 5901', port)
        port = 5901
    try:
        rate = float(rate)
        if rate <= 0:
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('~publish_rate must be a positive number, got %r; using 15', rate)
        rate = 15.0
    try:
        republish = float(republish)
        if republish < 0:
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('~republish_period must be >= 0 seconds, got %r; using 1', republish)
        republish = 1.0
    client = VncClient(host, port, password=password, encodings=encodings)

    def fatal(exc):
        # a wrong or missing password will not fix itself: stop instead of retrying, once
        # the error just logged has gone out on /rosout. rospy's shutdown closes the
        # publishers' connections at once and drops what their threads have not written:
        # the line was lost 6 ms after it was logged (bench/flaky), and rqt_console (or a
        # test reading /rosout) never saw why the node stopped
        reason = ('VNC authentication failed' if isinstance(exc, VncAuthError)
                  else 'VNC password missing')
        timer = threading.Timer(FATAL_LOG_GRACE, rospy.signal_shutdown, args=(reason,))
        timer.daemon = True
        timer.start()

    receiver = VncReceiver(client, log=_RospyLog, on_fatal=fatal, retry_auth=password.retry)
    publisher = ImagePublisherThread(client, topic, rate, frame_id, republish)
    rospy.loginfo('vnc_image_client: %s:%d -> %s (rgba8, at most %g images/s)',
                  host, port, rospy.resolve_name(topic), rate)
    receiver.start()
    publisher.start()
    rospy.spin()
    receiver.stop()
    receiver.join(2.0)
    return 1 if receiver.fatal is not None else 0
