#!/usr/bin/env python3
"""rostest: the vnc_image_client node against a real, password-protected Xtigervnc.

Proves: the published rgba8 image equals the server's screen pixel for pixel; the next
image follows a screen change; a resize gives images of the new size; after the server
is killed and restarted images resume (one warning per outage); a wrong password gives
one clear error and the node stops (no retry storm); no password and no TTY gives one
clear error; a TTY gets a no-echo prompt; the password is neither left on the parameter
server nor written to /rosout."""
import os
import pty
import select
import signal
import subprocess
import threading
import time
import unittest

import numpy as np
import rosgraph
import rospkg
import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import Image

from vnc_image_client.testserver import XVncServer, pattern

PKG = 'mobile_device_sim'


def to_rgb(msg):
    assert msg.encoding == 'rgba8', msg.encoding
    assert msg.step == msg.width * 4
    a = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width, 4)
    return a


class Collector(object):
    def __init__(self, topic, cls):
        self.lock = threading.Lock()
        self.msgs = []
        self.sub = rospy.Subscriber(topic, cls, self._cb, queue_size=50)

    def _cb(self, m):
        with self.lock:
            self.msgs.append(m)
            del self.msgs[:-100]

    def latest(self):
        with self.lock:
            return self.msgs[-1] if self.msgs else None

    def first(self, timeout=20.0):
        """Wait up to ``timeout`` s for a message: the latest one, None without any."""
        deadline = time.monotonic() + timeout
        while self.latest() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        return self.latest()

    def all(self):
        with self.lock:
            return list(self.msgs)


class VncNodeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('vnc_image_client_rostest')
        cls.port = int(rospy.get_param('~port'))
        cls.pw = rospy.get_param('~password')
        cls.rosout = Collector('/rosout', Log)
        cls.images = Collector('/vnc_image', Image)
        cls.server = XVncServer(320, 240, password=cls.pw, port=cls.port,
                                extra_args=['-BlacklistThreshold', '1000'])
        time.sleep(1.0)   # let the clients fail their first attempt: unreachable at start
        cls.server.start()

    @classmethod
    def tearDownClass(cls):
        cls.server.cleanup()

    def wait_image(self, rgb, timeout=10.0):
        deadline = time.monotonic() + timeout
        last = None
        while time.monotonic() < deadline:
            m = self.images.latest()
            if m is not None:
                last = to_rgb(m)
                if last.shape[:2] == rgb.shape[:2] and np.array_equal(last[:, :, :3], rgb):
                    return last
            time.sleep(0.05)
        self.fail('no image equal to the screen within %.0f s (last: %s)' % (
            timeout, None if last is None else last.shape))

    def node_logs(self, node, level=None, since=0.0):
        return [m for m in self.rosout.all() if m.name == node and
                (level is None or m.level == level) and m.header.stamp.to_sec() >= since]

    def test_1_pixels_change_resize(self):
        p1 = pattern(320, 240, seed=11)
        self.server.show(p1)
        img = self.wait_image(p1)
        self.assertTrue((img[:, :, 3] == 255).all())
        p2 = pattern(320, 240, seed=12)
        self.server.show(p2)
        self.wait_image(p2, timeout=5)
        self.server.resize(400, 300)
        p3 = pattern(400, 300, seed=13)
        self.server.show(p3)
        img = self.wait_image(p3, timeout=5)
        self.assertEqual(img.shape, (300, 400, 4))

    def test_2_kill_and_restart(self):
        self.server.show(pattern(self.server.width, self.server.height, seed=14))
        t0 = rospy.Time.now().to_sec()
        self.server.kill()
        time.sleep(3.0)     # several reconnect attempts fail meanwhile
        self.server.width, self.server.height = 320, 240
        self.server.start()
        p = pattern(320, 240, seed=15)
        self.server.show(p)
        self.wait_image(p, timeout=15)
        time.sleep(0.5)
        warns = self.node_logs('/vnc_image_client', Log.WARN, since=t0)
        self.assertEqual(len(warns), 1, [w.msg for w in warns])
        self.assertIn('went away', warns[0].msg)
        infos = [m.msg for m in self.node_logs('/vnc_image_client', Log.INFO, since=t0)]
        self.assertTrue(any('reconnected' in m for m in infos), infos)

    def test_3_wrong_password(self):
        deadline = time.monotonic() + 20
        errs = []
        while time.monotonic() < deadline:
            errs = self.node_logs('/vnc_wrong', Log.ERROR)
            if errs:
                break
            time.sleep(0.1)
        time.sleep(2.0)   # would a retry storm follow?
        errs = self.node_logs('/vnc_wrong', Log.ERROR)
        self.assertEqual(len(errs), 1, [e.msg for e in errs])
        self.assertIn('rejected the password', errs[0].msg)
        # the node stopped: it no longer publishes its topic
        state = rosgraph.Master('/vnc_image_client_rostest').getSystemState()
        pubs = dict((t, n) for t, n in state[0])
        self.assertNotIn('/vnc_wrong', pubs.get('/vnc_wrong', []))

    def test_4_password_not_on_param_server_nor_in_logs(self):
        for name in ('/vnc_image_client/password', '/vnc_wrong/password'):
            self.assertFalse(rospy.has_param(name), name)
        text = '\n'.join(m.msg for m in self.rosout.all())
        self.assertIn('VNC server', text)   # the collector did see the nodes' logs
        # the nodes' own log files (rospy writes every log line there, DEBUG included)
        logdir = os.path.join(rospkg.get_log_dir(), rospy.get_param('/run_id'))
        files = [f for f in os.listdir(logdir) if f.startswith(('vnc_image_client', 'vnc_wrong'))]
        self.assertTrue(files, os.listdir(logdir))
        for f in files:
            with open(os.path.join(logdir, f), errors='replace') as fh:
                text += fh.read()
        for pw in (self.pw, 'not-the-pw'):
            self.assertNotIn(pw, text)

    def _spawn_args(self, name):
        return ['rosrun', PKG, 'vnc_image_client', '__name:=' + name, '_host:=127.0.0.1',
                '_port:=%d' % self.port, '_image_topic:=/' + name]

    def test_5_no_password_no_tty(self):
        p = subprocess.run(self._spawn_args('vnc_nopw'), stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=60)
        out = p.stdout.decode('utf-8', 'replace')
        self.assertEqual(p.returncode, 1, out)
        self.assertIn('requires a password', out)
        self.assertNotIn('Password for VNC server', out)

    def test_6_tty_prompt_without_echo(self):
        self.server.show(pattern(self.server.width, self.server.height, seed=16))
        images = Collector('/vnc_tty', Image)
        pid, fd = pty.fork()
        if pid == 0:   # child: the node on a terminal
            os.execvp('rosrun', self._spawn_args('vnc_tty'))
        out = b''
        try:
            deadline = time.monotonic() + 30
            while b'Password for VNC server' not in out and time.monotonic() < deadline:
                if select.select([fd], [], [], 0.2)[0]:
                    out += os.read(fd, 4096)
            self.assertIn(b'Password for VNC server', out)
            os.write(fd, (self.pw + '\n').encode())
            deadline = time.monotonic() + 20
            while images.latest() is None and time.monotonic() < deadline:
                if select.select([fd], [], [], 0.2)[0]:
                    try:
                        out += os.read(fd, 4096)
                    except OSError:
                        break
            self.assertIsNotNone(images.latest(), out.decode('utf-8', 'replace'))
            self.assertNotIn(self.pw.encode(), out)    # typed without echo
        finally:
            os.kill(pid, signal.SIGINT)
            for _ in range(50):
                if os.waitpid(pid, os.WNOHANG)[0]:
                    break
                time.sleep(0.1)
            else:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            os.close(fd)

    def test_7_password_file(self):
        import tempfile
        with tempfile.NamedTemporaryFile('w', suffix='.pw') as f:
            f.write(self.pw + '\n')
            f.flush()
            images = Collector('/vnc_file', Image)
            p = subprocess.Popen(self._spawn_args('vnc_file') + ['_password_file:=' + f.name],
                                 stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT)
            try:
                self.assertIsNotNone(images.first(20), 'no image with ~password_file')
            finally:
                p.send_signal(signal.SIGINT)
                try:
                    out = p.communicate(timeout=10)[0].decode('utf-8', 'replace')
                except subprocess.TimeoutExpired:
                    p.kill()
                    out = p.communicate()[0].decode('utf-8', 'replace')
            self.assertNotIn(self.pw, out)

    def test_8_publish_rate_limits_a_fast_changing_screen(self):
        w, h = self.server.width, self.server.height
        pics = [pattern(w, h, seed=s) for s in (21, 22)]
        images = Collector('/vnc_rate', Image)
        p = subprocess.Popen(self._spawn_args('vnc_rate') + ['_publish_rate:=4',
                                                             '_password:=' + self.pw],
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        try:
            self.assertIsNotNone(images.first(20))
            n0 = len(images.all())
            t0 = time.monotonic()
            i = 0
            while time.monotonic() - t0 < 3.0:       # ~20+ screen changes per second
                self.server.show(pics[i & 1])
                i += 1
                time.sleep(0.02)
            time.sleep(0.3)
            n = len(images.all()) - n0
            self.assertGreater(i, 40, 'the screen did not change fast enough to test')
            self.assertLessEqual(n, 4 * 3 + 3, '%d images in 3 s at publish_rate 4' % n)
            self.assertGreaterEqual(n, 6, 'only %d images in 3 s of changes' % n)
        finally:
            p.send_signal(signal.SIGINT)
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


if __name__ == '__main__':
    rostest.rosrun(PKG, 'vnc_image_client_rostest', VncNodeTest)
