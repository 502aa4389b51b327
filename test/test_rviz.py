"""rviz on the simulated phone (issue 14): `roslaunch mobile_device_sim rviz.launch` under
Xvfb, screenshots with xwd; the phone camera's Image panel must show the QR code (zbar decodes
it from the screenshot) and the flycam's Camera panel the office (the desk's colour above
it). Alignment (issue 22): a blue ball is spawned in the world in front of the flycam and an
rviz PointStamped display's green sphere of the same size is published at the same world point; the
Camera display draws rviz's scene over the flycam image from the image's frame
(``flycam_optical_frame``, REP 103), so the marker must land on the ball in the panel
(half-transparent overlay: teal where both are). The last screenshot is kept as
build/test-output/rviz.png (docs/rviz.png is one)."""
import os
import shutil
import subprocess
import time

import cv2
import numpy as np
import pytest
from pyzbar import pyzbar

from fixtures.xwd import read_xwd, screenshot, start_xvfb, stop_groups
from sim_world.netutil import master_port  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, 'build', 'test-output')


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
        return False, 0, None
    r, g, b = (left[:, :, i].astype(int) for i in range(3))
    desk = (r > 180) & (g > 100) & (g < 175) & (b < 120)
    rows = np.arange(left.shape[0])
    outside = (rows < best[1] - 90) | (rows > best[2] + 110)
    return True, int(desk[outside].sum()), outside


#: the ball and the marker: in front of the flycam (office.launch: at 3.05 -2.68 1.08,
#: pitch 0.42, yaw 1.15), 0.47 m along its axis, out of the phone camera's view
BALL = (3.20, -2.30, 0.85)
RADIUS = 0.03


def _alignment(rgb, outside):
    """(ball pixels, marker pixels, distance of their centroids in pixels, overlap) in the
    flycam panel (left dock, rows outside the phone-camera panel). Ball: the flycam image's
    blue (alone, or teal under the marker); marker: the overlay's green (mixed half and
    half with what the image shows beneath: teal over the ball)."""
    left = rgb[:, :rgb.shape[1] // 3].astype(int)
    r, g, b = left[:, :, 0], left[:, :, 1], left[:, :, 2]
    # the flycam's picture: the box around its desk pixels (not the Displays panel's icons)
    desk = (r > 180) & (g > 100) & (g < 175) & (b < 120)
    desk[~outside] = False
    if desk.sum() < 100:
        return 0, 0, None, 0.0
    ys, xs = np.nonzero(desk)
    y0, y1 = np.percentile(ys, [1, 99]).astype(int)
    x0, x1 = np.percentile(xs, [1, 99]).astype(int)
    mask = np.zeros(r.shape, bool)
    mask[y0:y1 + 1, x0:x1 + 1] = True       # the ball stands over the desk in the picture
    mask[~outside] = False
    ball = mask & (b > 60) & (b > r + 40)
    marker = mask & (g > 60) & (g > r + 40)
    nb, nm = int(ball.sum()), int(marker.sum())
    if nb < 20 or nm < 20:
        return nb, nm, None, 0.0
    cb = np.argwhere(ball).mean(axis=0)
    cm = np.argwhere(marker).mean(axis=0)
    overlap = (ball & marker).sum() / float(min(nb, nm))
    return nb, nm, float(np.linalg.norm(cb - cm)), float(overlap)


def _test_config(tmp_path):
    """phone.rviz plus a PointStamped display (a sphere) on /rviz_test/point, shown in the
    Camera display."""
    text = open(os.path.join(ROOT, 'sim_world', 'config', 'phone.rviz')).read()
    marker = ('    - Class: rviz/PointStamped\n      Enabled: true\n      Name: AlignMarker\n'
              '      Topic: /rviz_test/point\n      Color: 0; 255; 0\n      Alpha: 1\n'
              '      Radius: %g\n      History Length: 1\n      Queue Size: 10\n'
              '      Value: true\n' % RADIUS)
    text = text.replace('    - Class: rviz/Camera\n', marker + '    - Class: rviz/Camera\n', 1)
    text = text.replace('        PhoneCamera: false\n', '        PhoneCamera: false\n'
                        '        AlignMarker: true\n', 1)
    assert 'AlignMarker: true' in text
    path = tmp_path / 'test.rviz'
    path.write_text(text)
    return str(path)


@pytest.mark.slow
def test_rviz_shows_phone_camera_and_flycam(tmp_path):
    for tool in ('rviz', 'Xvfb', 'xwd'):
        if shutil.which(tool) is None:
            pytest.skip('%s is not installed (tools/setup installs rviz, xvfb, x11-apps)' % tool)
    xvfb, display = start_xvfb('1280x800x24')
    port = master_port()
    env = dict(os.environ, DISPLAY=display, ROS_MASTER_URI='http://localhost:%d' % port,
               ROS_HOSTNAME='localhost')
    log = open(tmp_path / 'rviz.log', 'w')
    launch = subprocess.Popen(['roslaunch', '-p', str(port), 'mobile_device_sim', 'rviz.launch',
                               'config:=' + _test_config(tmp_path)],
                              env=env, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    ball = tmp_path / 'ball.urdf'
    ball.write_text('''<robot name="ball"><link name="b"><visual>
      <geometry><sphere radius="%g"/></geometry>
      <material name="blue"><color rgba="0 0 1 1"/></material></visual></link>
      <gazebo><static>true</static></gazebo></robot>''' % RADIUS)
    marker = ['rostopic', 'pub', '-r', '2', '/rviz_test/point', 'geometry_msgs/PointStamped',
              '{header: {frame_id: world}, point: {x: %g, y: %g, z: %g}}' % BALL]
    spawned = pub = None
    try:
        os.makedirs(OUT, exist_ok=True)
        shot = os.path.join(OUT, 'rviz.png')
        ok, desk, align = False, 0, (0, 0, None, 0.0)
        end = time.time() + 150

        def aligned():
            return align[2] is not None and align[2] < 0.4 * np.sqrt(align[0] / np.pi) \
                and align[3] > 0.5
        while time.time() < end and not (ok and desk > 2000 and aligned()):
            time.sleep(3)
            assert launch.poll() is None, open(tmp_path / 'rviz.log').read()[-3000:]
            if pub is None or pub.poll() is not None:       # (again if the master was not up)
                pub = subprocess.Popen(marker, env=env, stdout=log, stderr=subprocess.STDOUT,
                                       start_new_session=True)
            if spawned is None or (spawned.poll() not in (None, 0)):
                spawned = subprocess.Popen(
                    ['rosrun', 'mobile_device_sim', 'spawn_model', '-urdf', '-file', str(ball),
                     '-model', 'ball', '-x', str(BALL[0]), '-y', str(BALL[1]), '-z',
                     str(BALL[2])], env=env, stdout=log, stderr=subprocess.STDOUT)
            rgb = screenshot(display)
            if rgb is None:
                continue
            cv2.imwrite(shot, rgb[:, :, ::-1])
            ok, desk, outside = _panels_ok(rgb)
            if ok:
                align = _alignment(rgb, outside)
        assert ok, 'the phone camera panel never showed the QR code (see %s)' % shot
        assert desk > 2000, 'the flycam panel never showed the desk (see %s)' % shot
        nb, nm, dist, overlap = align
        assert nb >= 20, 'the flycam panel never showed the ball (see %s)' % shot
        assert nm >= 20, 'the marker never landed on the ball in the flycam panel: ' \
            'rviz overlay misaligned (%s)' % shot
        radius = np.sqrt(nb / np.pi)
        assert dist < 0.4 * radius and overlap > 0.5, \
            'marker and ball apart by %.1f px (ball radius %.1f px), overlap %.2f (%s)' % (
                dist, radius, overlap, shot)
    finally:
        if spawned is not None and spawned.poll() is None:
            spawned.kill()
            spawned.wait()
        stop_groups((pub, launch, xvfb))
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
