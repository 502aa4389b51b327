"""rviz on the simulated phone (issue 14): `roslaunch mobile_device_sim rviz.launch` under
Xvfb, screenshots with xwd; the phone camera's Image panel must show the QR code (zbar decodes
it from the screenshot) and the flycam's Camera panel the office (the desk's colour above
it). The last screenshot is kept as build/test-output/rviz.png (docs/rviz.png is one)."""
import os
import shutil
import signal
import socket
import subprocess
import time

import cv2
import numpy as np
import pytest
from pyzbar import pyzbar

from fixtures.xwd import read_xwd

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, 'build', 'test-output')


def _free_port():
    s = socket.socket()
    s.bind(('localhost', 0))
    p = s.getsockname()[1]
    s.close()
    return p


def _panels_ok(rgb):
    """(QR decoded in the left dock, desk pixels outside the phone-camera panel). The dock
    order of the two panels is up to Qt, so the phone camera's panel is found by its code
    (the largest decoded) and the flycam's desk is counted outside that panel's rows."""
    left = np.ascontiguousarray(rgb[:, :rgb.shape[1] // 3])
    gray = cv2.cvtColor(left, cv2.COLOR_RGB2GRAY)
    best = None
    for scale in (2, 1, 3, 1.5, 2.5, 4):
        big = cv2.resize(gray, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
        for img in (big, cv2.threshold(big, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)[1]):
            for c in pyzbar.decode(img):
                if c.data != b'http://vmi.lmt.ei.tum.de':
                    continue
                area = c.rect.width * c.rect.height / scale ** 2
                if best is None or area > best[0]:
                    best = (area, c.rect.top / scale, (c.rect.top + c.rect.height) / scale)
        if best is not None:
            break
    if best is None:
        return False, 0
    r, g, b = (left[:, :, i].astype(int) for i in range(3))
    desk = (r > 180) & (g > 100) & (g < 175) & (b < 120)
    rows = np.arange(left.shape[0])
    outside = (rows < best[1] - 90) | (rows > best[2] + 110)
    return True, int(desk[outside].sum())


@pytest.mark.slow
def test_rviz_shows_phone_camera_and_flycam(tmp_path):
    for tool in ('rviz', 'Xvfb', 'xwd'):
        if shutil.which(tool) is None:
            pytest.skip('%s is not installed (tools/setup installs rviz, xvfb, x11-apps)' % tool)
    xvfb = subprocess.Popen(['Xvfb', '-displayfd', '1', '-screen', '0', '1280x800x24', '-nolisten',
                             'tcp'], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    display = ':' + xvfb.stdout.readline().decode().strip()
    port = _free_port()
    env = dict(os.environ, DISPLAY=display, ROS_MASTER_URI='http://localhost:%d' % port,
               ROS_HOSTNAME='localhost')
    log = open(tmp_path / 'rviz.log', 'w')
    launch = subprocess.Popen(['roslaunch', '-p', str(port), 'mobile_device_sim', 'rviz.launch'],
                              env=env, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    try:
        os.makedirs(OUT, exist_ok=True)
        shot = os.path.join(OUT, 'rviz.png')
        ok, desk = False, 0
        end = time.time() + 150
        while time.time() < end and not (ok and desk > 2000):
            time.sleep(3)
            assert launch.poll() is None, open(tmp_path / 'rviz.log').read()[-3000:]
            r = subprocess.run(['xwd', '-root', '-silent', '-display', display],
                               capture_output=True)
            if r.returncode != 0 or not r.stdout:
                continue
            rgb = read_xwd(r.stdout)
            cv2.imwrite(shot, rgb[:, :, ::-1])
            ok, desk = _panels_ok(rgb)
        assert ok, 'the phone camera panel never showed the QR code (see %s)' % shot
        assert desk > 2000, 'the flycam panel never showed the desk (see %s)' % shot
    finally:
        for p in (launch, xvfb):
            try:
                os.killpg(p.pid, signal.SIGINT)
                p.wait(20)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        log.close()


def test_xwd_reader_round_trip():
    """read_xwd on a dump made by xwd of a known Xvfb screen is tested above; here on a
    synthetic 24-bit LSBFirst dump."""
    import struct
    w, h = 3, 2
    px = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]],
                   [[10, 20, 30], [40, 50, 60], [70, 80, 90]]], np.uint8)
    body = b''.join(bytes([p[2], p[1], p[0]]) for row in px for p in row)
    bpl = w * 3
    fields = [100 + 4, 7, 2, 24, w, h, 0, 0, 32, 0, 32, 24, bpl, 4, 0xff0000, 0xff00, 0xff,
              8, 256, 0, w, h, 0, 0, 0]
    data = struct.pack('>25I', *fields) + b'abc\0' + body
    assert np.array_equal(read_xwd(data), px)
