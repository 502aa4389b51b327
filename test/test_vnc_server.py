"""vnc_image_client's LibVNCClient binding against a REAL VNC server.

Each test starts Debian's Xtigervnc on 127.0.0.1 (no authentication, or VNC password
authentication), draws known pixels on its screen with python-xlib and checks what comes
out of the ctypes-bound libvncclient: exact pixels, screen changes, resize, the server
being killed and restarted, wrong/missing password and an unreachable host.
The ROS node itself is tested under rostest in test/rostest/vnc_image_client.test.
"""
import logging
import os
import socket
import sys
import time

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'vnc_image_client', 'src'))

from vnc_image_client.client import (VncAuthError, VncClient, VncConnectError,  # noqa: E402
                                     VncPasswordRequired, VncReceiver)
from vnc_image_client.testserver import XVncServer, pattern  # noqa: E402

PASSWORD = 'Tr0ub4dor'


class Log(object):
    def __init__(self):
        self.lines = []

    def info(self, m):
        self.lines.append(('info', m))

    def warn(self, m):
        self.lines.append(('warn', m))

    def error(self, m):
        self.lines.append(('error', m))

    def count(self, level):
        return sum(1 for lv, _ in self.lines if lv == level)

    def text(self):
        return '\n'.join(m for _, m in self.lines)


def wait_frame(client, pred, timeout=5.0, poll=True):
    """Poll until snapshot() satisfies pred; returns the last image."""
    deadline = time.monotonic() + timeout
    img = None
    while time.monotonic() < deadline:
        if poll:
            client.poll(0.05)
        else:
            time.sleep(0.02)
        img, _ = client.snapshot()
        if img is not None and pred(img):
            return img
    return img


def same(img, rgb):
    return img is not None and img.shape[:2] == rgb.shape[:2] and np.array_equal(img[:, :, :3], rgb)


@pytest.fixture
def server():
    s = XVncServer(320, 240).start()
    yield s
    s.cleanup()


@pytest.fixture
def pw_server():
    # a high blacklist threshold: the wrong-password tests must not lock the others out
    s = XVncServer(320, 240, password=PASSWORD, extra_args=['-BlacklistThreshold', '1000']).start()
    yield s
    s.cleanup()


def test_pixels_equal_screen_then_follow_changes(server):
    p1 = pattern(320, 240, seed=1)
    server.show(p1)
    c = VncClient('127.0.0.1', server.port)
    c.connect()
    try:
        assert c.size == (320, 240)
        img = wait_frame(c, lambda im: True)
        assert img.shape == (240, 320, 4) and img.dtype == np.uint8
        assert np.array_equal(img[:, :, :3], p1), 'first frame differs from the screen'
        assert (img[:, :, 3] == 255).all()
        seq = c.seq
        p2 = pattern(320, 240, seed=2)
        server.show(p2)
        img = wait_frame(c, lambda im: same(im, p2))
        assert same(img, p2), 'frame did not follow the screen change'
        assert c.seq > seq
    finally:
        c.close()


def test_resize(server):
    server.show(pattern(320, 240, seed=3))
    c = VncClient('127.0.0.1', server.port)
    c.connect()
    try:
        wait_frame(c, lambda im: True)
        server.resize(400, 300)
        p = pattern(400, 300, seed=4)
        server.show(p)
        img = wait_frame(c, lambda im: same(im, p))
        assert img.shape == (300, 400, 4), img.shape
        assert same(img, p)
        assert c.size == (400, 300)
    finally:
        c.close()


def test_kill_and_restart_resumes_with_one_log_per_outage(server):
    server.show(pattern(320, 240, seed=5))
    log = Log()
    c = VncClient('127.0.0.1', server.port, connect_timeout=2)
    r = VncReceiver(c, log=log, backoff=(0.1, 0.4))
    r.start()
    try:
        assert wait_frame(c, lambda im: True, poll=False) is not None
        server.kill()
        time.sleep(2.0)            # several reconnect attempts fail meanwhile
        assert not c.connected
        assert r.outages == 1
        assert log.count('warn') == 1, log.lines
        server.start()
        p = pattern(320, 240, seed=6)
        server.show(p)
        img = wait_frame(c, lambda im: same(im, p), timeout=8, poll=False)
        assert same(img, p), 'images did not resume after the server came back'
        assert r.connects == 2
        assert any('reconnected' in m for _, m in log.lines), log.lines
        assert log.count('warn') == 1 and log.count('error') == 0, log.lines
    finally:
        r.stop()
        r.join(3)


def test_password_from_parameter(pw_server):
    p = pattern(320, 240, seed=7)
    pw_server.show(p)
    c = VncClient('127.0.0.1', pw_server.port, password=PASSWORD)
    c.connect()
    try:
        assert c.password_asked and c.password_given
        assert same(wait_frame(c, lambda im: same(im, p)), p)
    finally:
        c.close()


def test_password_from_callable_prompt(pw_server):
    asked = []
    c = VncClient('127.0.0.1', pw_server.port, password=lambda: asked.append(1) or PASSWORD)
    c.connect()
    c.close()
    assert asked == [1]


def test_wrong_password_is_a_clear_error_without_retry_storm(pw_server, caplog):
    caplog.set_level(logging.DEBUG)
    c = VncClient('127.0.0.1', pw_server.port, password='wrong-one')
    with pytest.raises(VncAuthError) as ei:
        c.connect()
    assert 'rejected the password' in str(ei.value)
    assert 'wrong-one' not in str(ei.value)
    # the receiver gives up after ONE attempt with one error line
    log = Log()
    fatal = []
    r = VncReceiver(VncClient('127.0.0.1', pw_server.port, password='wrong-one'), log=log,
                    backoff=(0.05, 0.1), on_fatal=fatal.append)
    r.start()
    r.join(5)
    assert not r.is_alive()
    assert isinstance(r.fatal, VncAuthError) and len(fatal) == 1
    assert log.count('error') == 1 and log.count('warn') == 0, log.lines
    assert r.connects == 0
    # the password is in no log line, ours or libvncclient's
    assert 'wrong-one' not in log.text()
    assert 'wrong-one' not in caplog.text
    assert 'libvncclient:' in caplog.text  # the library's messages were captured


def test_missing_password_is_a_clear_error(pw_server):
    c = VncClient('127.0.0.1', pw_server.port, password=None)
    with pytest.raises(VncPasswordRequired) as ei:
        c.connect()
    assert 'requires a password' in str(ei.value)


def test_unreachable_host_and_port():
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()
    with pytest.raises(VncConnectError) as ei:
        VncClient('127.0.0.1', port, connect_timeout=2).connect()
    assert 'refused' in str(ei.value).lower() and str(port) in str(ei.value)
    with pytest.raises(VncConnectError) as ei:
        VncClient('no-such-host.invalid', 5901, connect_timeout=2).connect()
    assert 'no-such-host.invalid' in str(ei.value)


def test_unreachable_at_start_logs_once_then_connects():
    s = XVncServer(160, 120)
    log = Log()
    c = VncClient('127.0.0.1', s.port, connect_timeout=1)
    r = VncReceiver(c, log=log, backoff=(0.1, 0.3))
    r.start()
    try:
        time.sleep(1.2)
        assert log.count('warn') == 1, log.lines
        s.start()
        p = pattern(160, 120, seed=8)
        s.show(p)
        assert same(wait_frame(c, lambda im: same(im, p), timeout=8, poll=False), p)
        assert log.count('warn') == 1
    finally:
        r.stop()
        r.join(3)
        s.cleanup()


def test_reconnects_do_not_leak_framebuffers():
    """LibVNCClient's rfbClientCleanup leaves the framebuffer to its user: 15 reconnects
    at 640x480 would leak 18 MB without the client freeing it."""
    def rss_mb():
        with open('/proc/self/statm') as f:
            return int(f.read().split()[1]) * os.sysconf('SC_PAGE_SIZE') / 1e6

    with XVncServer(640, 480) as s:
        def once():
            c = VncClient('127.0.0.1', s.port)
            c.connect()
            assert wait_frame(c, lambda im: True) is not None
            c.close()
        for _ in range(3):
            once()
        before = rss_mb()
        for _ in range(15):
            once()
        assert rss_mb() - before < 6.0, 'process grew by %.1f MB' % (rss_mb() - before)
