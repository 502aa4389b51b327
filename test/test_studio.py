"""The studio (sim_studio, issue 47) against a real world: ``studio`` started as a user
starts it (its own master at ROS_MASTER_URI, the office world), commands over /ws and
POST /api/cmd checked with /gazebo/get_model_state, bad commands answered with one error
each while it keeps serving, the page in Debian's Chromium (Playwright) with real mouse
events on the translate handle, recording, running the recording, and Ctrl-C leaving no
process behind."""
import asyncio
import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest

from fixtures.studio import data_url, open_page, png_pixels, post, start_studio

pytestmark = pytest.mark.rostest

# a ROS client of its own (not the studio's), one request per line in, one JSON line out:
# "state MODEL" -> its /gazebo/get_model_state; "touches" -> the TouchEvents of
# /mobile_device/touch so far; "latest TOPIC FIELD..." -> those fields of the last message of
# a topic it subscribes to from its start (the device panel is checked against them)
PROBE = """
import json, sys, threading, rospy
import roslib.message, rostopic
from mobile_device_sim.srv import GetModelState
from mobile_device_sim.msg import TouchEvent
rospy.init_node('studio_probe', anonymous=True, disable_signals=True)
get = rospy.ServiceProxy('/gazebo/get_model_state', GetModelState)
touches, latest = [], {}
rospy.Subscriber('/mobile_device/touch', TouchEvent, touches.append)
TOPICS = %r
def keep(msg, topic):
    latest[topic] = msg
for t, ty in TOPICS:
    rospy.Subscriber(t, roslib.message.get_message_class(ty), keep, callback_args=t)
def field(msg, path):
    for part in path.split('.'):
        msg = getattr(msg, part)
    return msg
for line in sys.stdin:
    words = line.split()
    if words[0] == 'state':
        res = get(words[1], '')
        p, q = res.pose.position, res.pose.orientation
        print(json.dumps([res.success, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w]]), flush=True)
    elif words[0] == 'touches':
        print(json.dumps([[e.action, e.x, e.y, e.width, e.height, e.source]
                          for e in touches]), flush=True)
    elif words[0] == 'latest':
        m = latest.get(words[1])
        print(json.dumps(None if m is None else [field(m, f) for f in words[2:]]), flush=True)
""" % ([('/mobile_device/magnetic', 'sensor_msgs/MagneticField'),
        ('/mobile_device/imu_sensor_data', 'sensor_msgs/Imu'),
        ('/mobile_device/battery_state', 'sensor_msgs/BatteryState')],)




def descendants(pid):
    from testing_instance.world.procs import descendants as d
    return d(pid)


@pytest.fixture(scope='module')
def studio(tmp_path_factory):
    yield from start_studio(tmp_path_factory.mktemp('studio'))



def probe(studio, request):
    """The answer of the test's own ROS client (PROBE) to one request."""
    if 'getter' not in studio:
        studio['getter'] = subprocess.Popen([sys.executable, '-c', PROBE],
                                            env=studio['env'], stdin=subprocess.PIPE,
                                            stdout=subprocess.PIPE, text=True)
    g = studio['getter']
    g.stdin.write(request + '\n')
    g.stdin.flush()
    line = g.stdout.readline()
    assert line, 'the probe died'
    return json.loads(line)


def model_state(studio, model='mobile_device'):
    ok, pos, quat = probe(studio, 'state ' + model)
    assert ok
    return pos, quat


async def ws_session(url, commands):
    """Send each command on one /ws connection; their replies (in order), and the poses
    streamed meanwhile."""
    import aiohttp
    replies, poses = [], []
    async with aiohttp.ClientSession() as s:
        async with s.ws_connect(url.replace('http', 'ws') + 'ws',
                                max_msg_size=0) as ws:
            for c in commands:
                if callable(c):
                    await c(poses)
                    continue
                await ws.send_str(c if isinstance(c, str) else json.dumps(c))
                while True:
                    m = await asyncio.wait_for(ws.receive(), 60)
                    if m.type != aiohttp.WSMsgType.TEXT:
                        continue
                    d = json.loads(m.data)
                    if d.get('type') == 'poses':
                        poses.append(d)
                    elif d.get('type') == 'reply':
                        replies.append(d)
                        break
            # the stream: poses keep coming after the commands
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.0:
                m = await asyncio.wait_for(ws.receive(), 10)
                if m.type == aiohttp.WSMsgType.TEXT and json.loads(m.data)['type'] == 'poses':
                    poses.append(json.loads(m.data))
    return replies, poses


def test_startup_line_and_scene(studio):
    assert open(studio['log']).read().count('studio: http://127.0.0.1:') == 1
    with urllib.request.urlopen(studio['url'] + 'api/scene', timeout=30) as r:
        scene = json.loads(r.read())
    names = [m['name'] for m in scene['models']]
    assert 'mobile_device' in names and 'desk' in names
    phone = next(m for m in scene['models'] if m['name'] == 'mobile_device')
    assert {'mobile_base_link', 'mobile_display'} <= {ln['name'] for ln in phone['links']}
    assert all(len(ln['world_pose']['position']) == 3 for ln in phone['links'])
    with urllib.request.urlopen(studio['url'] + 'three/three.min.js', timeout=30) as r:
        assert b'REVISION' in r.read()[:200000]


def test_commands_over_ws_and_post_move_the_world(studio):
    bad = [
        '{"v": 1, "op": "set_pose", "model": "mobile_device", "position": [NaN, 0, 1], "id": 1}',
        {'v': 1, 'op': 'teleport', 'id': 2},
        {'v': 1, 'op': 'set_pose', 'model': 'no_such_phone', 'position': [0, 0, 1], 'id': 3},
        {'v': 1, 'op': 'set_pose', 'model': 'mobile_device', 'position': 'up', 'id': 4},
        {'v': 1, 'op': 'check', 'yaml': 'x' * 300000, 'id': 5},
        {'v': 1, 'op': 'touch', 'x': 0.5, 'y': 0.5, 'duration': -1, 'id': 6},
    ]
    before, _q = model_state(studio)
    replies, _ = asyncio.run(ws_session(studio['url'], [{'v': 1, 'op': 'pause'}] + bad))
    assert replies[0]['ok'], replies[0]
    errors = replies[1:]
    assert [r['ok'] for r in errors] == [False] * len(bad), errors
    assert [r.get('id') for r in errors[1:]] == [2, 3, 4, None, 6]
    assert 'NaN' in errors[0]['error'] and 'unknown op' in errors[1]['error']
    assert 'no model' in errors[2]['error'] and 'larger than' in errors[4]['error']
    after, _q = model_state(studio)
    assert np.allclose(before, after, atol=1e-6), 'a refused command moved the phone'

    target = [3.1, -2.0, 1.1]
    got = {}

    async def wait_pose(poses):
        t0 = time.monotonic()
        while time.monotonic() - t0 < 10:
            await asyncio.sleep(0.02)
            if poses and np.allclose(poses[-1]['poses']['mobile_device'][:3], target,
                                     atol=1e-3):
                got['seen'] = True
                return
    replies, poses = asyncio.run(ws_session(studio['url'], [
        {'v': 1, 'op': 'set_pose', 'model': 'mobile_device', 'position': target,
         'rpy': [0, 0, 0.5], 'id': 'move'},
        {'v': 1, 'op': 'scene'}, wait_pose]))
    assert replies[0]['ok'] and replies[0]['id'] == 'move', replies
    pos, quat = model_state(studio)
    assert np.allclose(pos, target, atol=1e-3)
    assert abs(2 * np.arctan2(quat[2], quat[3]) - 0.5) < 1e-3
    assert len(poses) >= 10 and all(p['v'] == 1 for p in poses)

    # POST /api/cmd: the same handler
    code, rep = post(studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                         'position': [3.2, -2.05, 1.05]}))
    assert code == 200 and rep['ok'], rep
    assert np.allclose(model_state(studio)[0], [3.2, -2.05, 1.05], atol=1e-3)
    code, rep = post(studio, '{"v": 1, "op": "set_pose", "model": "mobile_device", '
                             '"position": [Infinity, 0, 1]}')
    assert code == 400 and not rep['ok'] and 'Infinity' in rep['error']
    code, rep = post(studio, 'not json')
    assert code == 400 and 'not JSON' in rep['error']
    assert np.allclose(model_state(studio)[0], [3.2, -2.05, 1.05], atol=1e-3)


@pytest.fixture(scope='module')
def page(studio):
    yield from open_page(studio)


def test_the_page_draws_the_world_and_the_camera(studio, page):
    px = png_pixels(data_url(page, "document.querySelector('[data-testid=viewport]')"))
    assert px.std() > 10, 'the 3D view is blank'
    assert len({tuple(c) for c in px[::7, ::7].reshape(-1, 3)}) > 20
    page.evaluate("studio.send({op: 'play'})")        # the last test paused it
    page.wait_for_function("window.studio.cameraFrames > 1 && document.querySelector("
                           "'[data-testid=camera-view]').naturalWidth > 0", timeout=180000)
    cam = png_pixels(data_url(page, "(() => { const i = document.querySelector("
                                    "'[data-testid=camera-view]'); const c = document."
                                    "createElement('canvas'); c.width = i.naturalWidth; "
                                    "c.height = i.naturalHeight; c.getContext('2d')."
                                    "drawImage(i, 0, 0); return c; })()"))
    assert cam.shape[0] > 100 and cam.shape[1] > 100
    assert cam.std() > 5, 'the camera panel is blank'
    page.wait_for_function("document.querySelector('[data-testid=sim-time]')"
                           ".textContent !== '-'", timeout=30000)
    assert float(page.get_by_test_id('sim-time').text_content()) > 0
    assert page.outside == [] and page.errors == []


def test_a_click_on_the_display_view_touches_the_phone_at_that_pixel(studio, page):
    with urllib.request.urlopen(studio['url'] + 'api/scene', timeout=30) as r:
        phone = next(m for m in json.loads(r.read())['models'] if m['name'] == 'mobile_device')
    width, height = phone['display']['width'], phone['display']['height']
    before = len(probe(studio, 'touches'))
    page.evaluate("studio.send({op: 'play'})")
    box = page.get_by_test_id('display-view').bounding_box()
    assert abs(box['height'] / box['width'] - height / width) < 0.02   # the display's shape
    cx, cy = box['x'] + 0.25 * box['width'], box['y'] + 0.75 * box['height']
    page.mouse.click(cx, cy)
    deadline = time.monotonic() + 30
    while True:
        events = probe(studio, 'touches')[before:]
        if events or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert events and events[0][0] == 0, events           # a DOWN
    _, x, y, w, h, source = events[0]
    assert (w, h) == (width, height) and source == 'inject'
    sent = page.evaluate('studio.lastTouch')
    assert abs(x - sent['x'] * width) < 0.01 and abs(y - sent['y'] * height) < 0.01
    px = width / box['width'] + 0.01          # display pixels in one pixel of the page
    assert abs(x - 0.25 * width) < px and abs(y - 0.75 * height) < px, (x, y)
    # the event reaches the page too (the device panel), and the view marks it
    page.wait_for_function("(() => { const t = studio.device['/mobile_device/touch']; "
                           "return t && t.n >= 1; })()", timeout=30000)
    shown = page.locator('[data-testid=device-value][data-topic="/mobile_device/touch"]'
                         '[data-field=x]').text_content()
    assert abs(float(shown) - x) < 1e-3


def test_the_device_panel_shows_the_phones_sensor_values(studio, page):
    fields = {'/mobile_device/magnetic': ['magnetic_field.x', 'magnetic_field.z'],
              '/mobile_device/imu_sensor_data': ['linear_acceleration.z', 'angular_velocity.y'],
              '/mobile_device/battery_state': ['percentage', 'voltage']}
    page.evaluate("studio.send({op: 'play'})")
    t0 = time.monotonic()
    page.wait_for_function('%s.every((t) => studio.device[t])' % json.dumps(
        list(fields) + ['/mobile_device/fix', '/mobile_device/wifi/scan']), timeout=60000)
    print('device values after %.1f s' % (time.monotonic() - t0))
    assert page.evaluate("studio.send({op: 'pause'}).then((r) => r.ok)")
    print('paused after %.1f s' % (time.monotonic() - t0))
    time.sleep(1.0)                  # the last messages reach the probe and the studio
    n = page.evaluate('studio.deviceMessages')
    page.wait_for_function('studio.deviceMessages > %d + 1' % n, timeout=10000)
    print('values settled after %.1f s' % (time.monotonic() - t0))
    for topic, names in fields.items():
        want = probe(studio, 'latest %s %s' % (topic, ' '.join(names)))
        assert want is not None, 'the probe got nothing on ' + topic
        for name, v in zip(names, want):
            cell = page.locator('[data-testid=device-value][data-topic="%s"][data-field="%s"]'
                                % (topic, name))
            shown = float(cell.text_content())
            assert abs(shown - v) <= 1e-6 * abs(v) + 1e-12, (topic, name, shown, v)
    plot = png_pixels(data_url(page, "document.querySelector('[data-testid=plot]"
                                     "[data-topic=\"/mobile_device/magnetic\"]')"))
    assert (np.abs(plot - [0x15, 0x18, 0x1c]).sum(axis=2) > 60).sum() > 50, 'no plot drawn'
    text = page.get_by_test_id('device-panel').text_content()
    for topic in ('/mobile_device/fix', '/mobile_device/wifi/scan'):
        assert topic in text, text[:2000]


def viewport_pixels(page, after_frames=2):
    n = page.evaluate('studio.frames')
    page.wait_for_function('studio.frames >= %d' % (n + after_frames), timeout=30000)
    return png_pixels(data_url(page, "document.querySelector('[data-testid=viewport]')"))


def test_a_mesh_is_drawn_as_its_triangles_not_its_bounding_box(studio, page):
    page.wait_for_function('studio.shapesLoaded >= 2', timeout=60000)   # pyramid, QR paper
    assert page.evaluate("studio.lookAt('studio_pyramid', [-1.2, 0.5, 0.6])")
    page.evaluate('studio.handle.visible = false')      # its arrows are red, green, blue
    red = lambda px: (px[:, :, 0] > 100) & (px[:, :, 0] > 2 * px[:, :, 1]) & \
        (px[:, :, 0] > 2 * px[:, :, 2])                                  # noqa: E731
    mesh = red(viewport_pixels(page))
    page.evaluate('studio.showShapeBoxes(true)')
    box = red(viewport_pixels(page))
    page.evaluate('studio.showShapeBoxes(false)')
    page.evaluate("studio.handle.visible = true; studio.lookAt('mobile_device')")
    assert mesh.sum() > 500, 'the pyramid is not drawn'
    # a pyramid covers its box's outline only partly: the box's top corners are not red
    assert box.sum() > 1.3 * mesh.sum(), (box.sum(), mesh.sum())
    assert (box & ~mesh).sum() > 0.2 * box.sum()
    assert not (mesh & ~box).sum() > 0.02 * mesh.sum()   # and it is inside it


def test_a_jointed_model_is_drawn_at_its_link_states(studio, page):
    page.evaluate("studio.send({op: 'play'})")
    page.wait_for_function("studio.links.studio_pendulum && studio.links.studio_pendulum.rod",
                           timeout=30000)
    assert page.evaluate("studio.lookAt('studio_pendulum', [0, 2.2, -0.3])")
    page.evaluate('studio.handle.visible = false')
    blue = lambda px: (px[:, :, 2] > 100) & (px[:, :, 2] > 2 * px[:, :, 0])   # noqa: E731
    shots, times = [], []
    for _ in range(3):
        times.append(page.evaluate('studio.simTime'))
        shots.append(blue(viewport_pixels(page)))
        time.sleep(0.3)
    page.evaluate("studio.handle.visible = true; studio.lookAt('mobile_device')")
    assert all(m.sum() > 200 for m in shots), [m.sum() for m in shots]
    changed = max((a ^ b).sum() for a in shots for b in shots)
    assert changed > 200, ('the pendulum does not move in the view', times,
                           [m.sum() for m in shots])
    with urllib.request.urlopen(studio['url'] + 'api/scene', timeout=30) as r:
        pend = next(m for m in json.loads(r.read())['models'] if m['name'] == 'studio_pendulum')
    rod = next(ln for ln in pend['links'] if ln['name'] == 'rod')
    assert rod['world_pose'] != _rest_world_pose(pend, rod), 'GET /api/scene: rest poses'


def _rest_world_pose(model, link):
    from sim_studio.server import _compose
    p = model['pose']
    return _compose(list(p['position']) + list(p['orientation']), link['pose'])


def grid(px, rows=10, cols=6):
    """Mean grey level of rows x cols cells of an image, standardised."""
    g = px.mean(axis=2)
    h, w = g.shape
    cells = np.array([[g[r * h // rows:(r + 1) * h // rows, c * w // cols:(c + 1) * w // cols]
                       .mean() for c in range(cols)] for r in range(rows)])
    return (cells - cells.mean()) / (cells.std() + 1e-9)


def test_the_view_through_the_phone_camera_sees_what_the_camera_sees(studio, page):
    assert page.evaluate("studio.send({op: 'pause'}).then((r) => r.ok)")
    time.sleep(0.5)                  # the camera's last image reaches the page
    cam = png_pixels(data_url(page, "(() => { const i = document.querySelector("
                                    "'[data-testid=camera-view]'); const c = document."
                                    "createElement('canvas'); c.width = i.naturalWidth; "
                                    "c.height = i.naturalHeight; c.getContext('2d')."
                                    "drawImage(i, 0, 0); return c; })()"))
    page.evaluate("studio.handle.visible = false")
    free = viewport_pixels(page)
    page.get_by_test_id('view-mode').select_option('camera')
    view = viewport_pixels(page)
    page.get_by_test_id('view-mode').select_option('free')
    page.evaluate("studio.handle.visible = true")
    # the view has the camera's vertical field of view: its middle, as wide as the image's
    # aspect makes it, is the camera's picture
    h, w = view.shape[:2]
    cw = int(round(h * cam.shape[1] / cam.shape[0]))
    crop = lambda px: px[:, (w - cw) // 2:(w + cw) // 2]          # noqa: E731
    through = float((grid(crop(view)) * grid(cam)).mean())
    other = float((grid(crop(free)) * grid(cam)).mean())
    print('correlation with the camera image: through it %.2f, free view %.2f'
          % (through, other))
    assert through > 0.6 and through > other + 0.2, (through, other)


def test_the_follow_view_keeps_its_distance_to_the_moving_phone(studio, page):
    page.get_by_test_id('view-mode').select_option('follow')
    offset = ("(() => studio.camera.position.clone().sub("
              "studio.models.mobile_device.position).toArray())()")
    before = page.evaluate(offset)
    pos, _q = model_state(studio)
    to = [pos[0] + 0.3, pos[1] + 0.1, pos[2]]
    code, rep = post(studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                         'position': to}))
    assert code == 200, rep
    page.wait_for_function('Math.abs(studio.models.mobile_device.position.x - %r) < 1e-4'
                           % to[0], timeout=30000)
    viewport_pixels(page)
    after = page.evaluate(offset)
    code, rep = post(studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                         'position': pos}))
    page.get_by_test_id('view-mode').select_option('free')
    assert np.allclose(before, after, atol=1e-3), (before, after)


def test_assert_mode_turns_a_clicked_value_into_an_expectation(studio, page):
    page.get_by_test_id('assert').click()
    cell = page.locator('[data-testid=device-value][data-topic="/mobile_device/magnetic"]'
                        '[data-field="magnetic_field.z"]')
    value = float(cell.text_content())
    cell.click()
    form = page.get_by_test_id('assert-form')
    assert form.is_visible()
    form.locator('select[name=check]').select_option('near')
    page.get_by_test_id('assert-add').click()
    page.wait_for_function("document.querySelector('[data-testid=scenario-yaml]').value"
                           ".includes('magnetic_field.z')", timeout=30000)
    page.get_by_test_id('assert').click()
    yaml = page.get_by_test_id('scenario-yaml').input_value()
    line = [ln for ln in yaml.splitlines() if 'magnetic_field.z' in ln][0]
    m = re.search(r'topic: /mobile_device/magnetic, field: magnetic_field.z, '
                  r'eventually: \{near: ([-\de.]+), tol: ([-\de.]+)\}', line)
    assert m, line
    assert abs(float(m.group(1)) - value) <= 1e-6 * abs(value) + 1e-12
    assert abs(float(m.group(2)) - 0.1 * abs(value)) <= 0.01 * abs(value)
    rep = page.evaluate("studio.send({op: 'check', yaml: document.querySelector("
                        "'[data-testid=scenario-yaml]').value})")
    assert rep['ok'] and rep['problems'] == [], rep


def test_drag_the_handle_record_and_run(studio, page):
    page.evaluate("studio.send({op: 'pause'})")
    page.get_by_test_id('record').click()
    page.wait_for_function('window.studio.recording === true', timeout=30000)
    before, _q = model_state(studio)
    page.wait_for_function('!window.studio.dragging')
    p = page.evaluate("studio.handlePoint('X')")
    page.mouse.move(p['x'], p['y'])
    page.mouse.move(p['x'] + 1, p['y'])
    page.mouse.down()
    for i in range(1, 11):
        page.mouse.move(p['x'] + 12 * i, p['y'], steps=2)
    page.mouse.up()
    deadline = time.monotonic() + 30
    while True:
        pos, _q = model_state(studio)
        if pos[0] - before[0] > 0.02 or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert pos[0] - before[0] > 0.02, (before, pos)
    assert abs(pos[1] - before[1]) < 0.01 and abs(pos[2] - before[2]) < 0.01
    page.get_by_test_id('record').click()
    page.wait_for_function('window.studio.recording === false', timeout=30000)
    yaml = page.get_by_test_id('scenario-yaml').input_value()
    assert 'action: set_model_state, model: mobile_device' in yaml, yaml
    last = [ln for ln in yaml.splitlines() if 'set_model_state' in ln][-1]
    x = float(re.search(r'position: \[([-\d.e]+),', last).group(1))
    assert abs(x - pos[0]) < 1e-3, (last, pos)
    page.screenshot(path=str(studio['dir'] / 'studio.png'))
    page.get_by_test_id('run').click()
    page.wait_for_function("/scenario: (PASS|FAIL|ERROR)/.test(document.querySelector("
                           "'[data-testid=verdicts]').textContent)", timeout=180000)
    text = page.get_by_test_id('verdicts').text_content()
    assert 'scenario: PASS' in text, text


def test_the_page_shows_a_banner_with_the_log_tail_when_the_world_dies(studio, page):
    from testing_instance.world.procs import cmdline
    world = [k for k in descendants(studio['proc'].pid) if '__name:=sim_world' in cmdline(k)]
    assert len(world) == 1
    assert page.get_by_test_id('world-gone').is_hidden()
    os.kill(world[0], signal.SIGKILL)
    page.wait_for_function("!document.querySelector('[data-testid=world-gone]').hidden",
                           timeout=60000)
    text = page.get_by_test_id('world-gone').text_content()
    assert 'the world exited' in text and 'sim_world' in text, text


def test_ctrl_c_leaves_no_process_behind(studio, page):
    p = studio['proc']
    kids = descendants(p.pid)
    assert len(kids) >= 3            # the studio, its master and rosout (the world died)
    os.kill(p.pid, signal.SIGINT)
    p.wait(60)
    deadline = time.monotonic() + 20
    from testing_instance.world.procs import alive
    while any(alive(k) for k in kids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [k for k in kids if alive(k)]
    assert 'studio: stopped' in open(studio['log']).read()
