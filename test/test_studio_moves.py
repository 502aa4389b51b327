"""The studio's moves and overlays in Chromium (sim_studio/moves.py, overlay.py,
static/ext/moves.js) on the shared studio, with real mouse clicks: a preset puts the phone
where /gazebo/get_model_state then has it, a two-waypoint walk clicked on the top view
takes it to the last waypoint in sim time and is recorded as the runner's walk, the WiFi
access point's icon is drawn where the AP projects, the WiFi map overlay changes the floor's
pixels, a fault chosen in the device controls stops the sensor's topic, and bad moves are
one error each with nothing moved; the device controls' NFC switch, a waypoint's height, the
vibration's state and the time of day (noon and midnight on the light sensor). The phone,
its faults, switches, daylight and the recording are left as they were found."""
import json
import re
import time

import numpy as np
import pytest

from fixtures.studio import until as _until, data_url, png_pixels, post
from test_studio import model_state, probe

pytestmark = pytest.mark.rostest

AP = '00:1a:2b:3c:4d:01'          # ap_office, at (5.6, 0.7, 2.2)


@pytest.fixture(scope='module')
def page(shared_studio, shared_page):
    pg = shared_page
    pg.evaluate("studio.setView('free'); studio.live = true; studio.select('mobile_device')")
    post(shared_studio, json.dumps({'v': 1, 'op': 'play'}))
    pg.wait_for_function("window.studio.moves && studio.moves.bounds && "
                         "studio.moves.icons['wifi:%s']" % AP, timeout=90000)
    start, quat = model_state(shared_studio)
    yield pg
    post(shared_studio, json.dumps({'v': 1, 'op': 'fault', 'sensor': '/mobile_device/magnetic',
                                    'fault': 'none'}))
    post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                    'position': start, 'rpy': [0, 0, 0]}))


def test_a_preset_clicked_puts_the_phone_on_the_desk(shared_studio, page):
    page.get_by_test_id('preset-flat_on_desk').click(no_wait_after=True, force=True, timeout=90000)
    pos = _until(lambda: (lambda p: p if abs(p[2] - 0.7566) < 2e-3 else None)(
        model_state(shared_studio)[0]), what='the phone on the desk')
    # on the desk's top (0.75 m), flat: the quaternion's x and y are 0
    assert 2.52 < pos[0] < 4.12 and -2.5 < pos[1] < -1.7
    _p, q = model_state(shared_studio)
    assert abs(q[0]) < 1e-3 and abs(q[1]) < 1e-3
    page.get_by_test_id('preset-held_portrait').click(no_wait_after=True, force=True, timeout=90000)
    pos2 = _until(lambda: (lambda p: p if abs(p[2] - 1.25) < 1e-3 else None)(
        model_state(shared_studio)[0]), what='the phone in the hand')
    assert np.allclose(pos2[:2], pos[:2], atol=1e-3)


def test_a_walk_clicked_on_the_top_view_moves_and_is_recorded(shared_studio, page):
    start, _q = model_state(shared_studio)
    wps = [[start[0] - 0.5, start[1] + 0.4], [start[0] - 1.0, start[1] + 0.9]]
    code, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'record', 'on': True}))
    assert code == 200 and rep['recording'], rep
    page.get_by_test_id('walk-speed').fill('2', no_wait_after=True, force=True, timeout=90000)
    page.evaluate('document.querySelector("[data-testid=top-view]").scrollIntoView()')
    n = page.evaluate('studio.moves.topFrames')
    page.wait_for_function('studio.moves.topFrames > %d' % n, timeout=90000)
    # the top view shows the office from above: the desk's brown where the desk is
    top = png_pixels(data_url(page, 'document.querySelector("[data-testid=top-view]")'))
    b = page.evaluate('studio.moves.bounds')
    col = int((3.32 - 0.5 - b[0]) / (b[1] - b[0]) * top.shape[1])
    row = int((b[3] - (-2.1 - 0.3)) / (b[3] - b[2]) * top.shape[0])
    desk = top[row, col]
    assert desk[0] > desk[2] + 40, desk             # brown (0.55, 0.38, 0.22), lit
    for x, y in wps:
        p = page.evaluate('studio.moves.topPoint(%f, %f)' % (x, y))
        page.mouse.click(p['x'], p['y'])
    assert page.evaluate('studio.moves.waypoints.length') == 2
    page.get_by_test_id('walk').click(no_wait_after=True, force=True, timeout=90000)
    end = _until(lambda: (lambda p: p if np.hypot(p[0] - wps[1][0], p[1] - wps[1][1]) < 0.05
                          else None)(model_state(shared_studio)[0]), timeout=60,
                 what='the phone at the last waypoint')
    assert abs(end[2] - start[2]) < 0.03          # at the hand's height (the walking bounce)
    code, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'record', 'on': False}))
    line = next(ln for ln in rep['yaml'].splitlines() if 'action: walk' in ln)
    assert 'model: mobile_device' in line and 'speed: 2}' in line, line
    got = [float(v) for v in re.search(r'waypoints: \[\[(.*?)\]\]', line).group(1)
           .replace('], [', ', ').split(', ')]
    assert np.allclose(np.reshape(got, (2, 3))[:, :2], wps, atol=0.05), (line, wps)
    assert 'action: log, text: "the walk' in rep['yaml']     # the scenario lasts the walk


def test_the_access_points_icon_is_drawn_where_it_projects(page):
    page.evaluate("studio.orbit.target.set(5.6, 0.7, 2.2); "
                  "studio.camera.position.set(3.6, -2.3, 2.8); studio.orbit.update()")
    n = page.evaluate('studio.frames')
    page.wait_for_function('studio.frames > %d' % (n + 3), timeout=90000)
    p = page.evaluate("studio.moves.iconPoint('wifi', '%s')" % AP)
    assert p['visible'], p
    img = png_pixels(data_url(page, 'studio.renderer.domElement'))
    r = page.evaluate('(() => { const r = studio.renderer.domElement.getBoundingClientRect(); '
                      'return [r.left, r.top]; })()')
    cx, cy = int(round(p['x'] - r[0])), int(round(p['y'] - r[1]))
    patch = img[max(0, cy - 14):cy + 15, max(0, cx - 14):cx + 15].reshape(-1, 3)
    blue = np.all(np.abs(patch - [0, 150, 255]) < 30, axis=1).sum()
    assert blue > 40, (blue, patch[:5])
    # and not elsewhere: the corner of the view has none of it
    corner = img[:30, :30].reshape(-1, 3)
    assert np.all(np.abs(corner - [0, 150, 255]) < 30, axis=1).sum() == 0


def test_the_wifi_map_overlay_colours_the_floor(page):
    page.evaluate("studio.orbit.target.set(3.2, -2.0, 0); "
                  "studio.camera.position.set(3.2, -2.6, 11); studio.orbit.update()")
    n = page.evaluate('studio.frames')
    page.wait_for_function('studio.frames > %d' % (n + 3), timeout=90000)
    before = png_pixels(data_url(page, 'studio.renderer.domElement'))
    page.get_by_test_id('wifi-overlay').check(no_wait_after=True, force=True, timeout=90000)
    page.wait_for_function('studio.moves.overlayShown >= 1', timeout=90000)
    n = page.evaluate('studio.frames')
    page.wait_for_function('studio.frames > %d' % (n + 3), timeout=90000)
    after = png_pixels(data_url(page, 'studio.renderer.domElement'))
    status = page.get_by_test_id('wifi-map-status').text_content()
    assert 'dBm (2 AP)' in status, status
    changed = np.abs(after - before).sum(axis=2) > 60
    assert changed.mean() > 0.2, changed.mean()
    page.get_by_test_id('wifi-overlay').uncheck(no_wait_after=True, force=True, timeout=90000)
    assert page.evaluate('studio.moves.overlay.visible') is False


def test_a_fault_chosen_in_the_panel_stops_the_sensors_topic(shared_studio, page):
    topic = '/mobile_device/magnetic'
    sel = page.locator('[data-testid=fault-select][data-topic="%s"]' % topic)
    sel.wait_for(timeout=90000)

    def stamps():                     # the latest magnetic and IMU messages' stamps
        out = []
        for t in (topic, '/mobile_device/imu_sensor_data'):
            got = probe(shared_studio, 'latest %s header.stamp.secs header.stamp.nsecs' % t)
            out.append(got[0] + got[1] * 1e-9 if got else -1.0)
        return out
    _until(lambda: min(stamps()) > 0, timeout=90, what='both sensors')
    sel.select_option('drop', no_wait_after=True, force=True, timeout=90000)
    a = _until(lambda: (lambda s: s if s[1] - s[0] > 0.3 else None)(stamps()), timeout=60,
               what='the magnetometer to stop')
    time.sleep(0.5)
    b = stamps()
    assert b[0] == a[0] and b[1] > a[1], (a, b)
    sel.select_option('none', no_wait_after=True, force=True, timeout=90000)
    _until(lambda: stamps()[0] > b[0], timeout=90, what='the magnetometer again')


def test_bad_moves_are_one_error_and_nothing_moves(shared_studio, page):
    before, _q = model_state(shared_studio)
    for body, words in [
            ({'op': 'preset', 'model': 'mobile_device', 'name': 'on_the_moon'}, 'one of'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[1, 1, 1]], 'speed': 1},
             '2 to 100'),
            ({'op': 'walk', 'model': 'mobile_device', 'waypoints': [[1, 1, 1], [2, 2, 1]],
              'speed': 0}, '> 0')]:
        code, rep = post(shared_studio, json.dumps(dict(body, v=1)))
        assert code == 400 and not rep['ok'] and words in rep['error'], rep
    code, rep = post(shared_studio, '{"v": 1, "op": "walk", "model": "mobile_device", '
                     '"waypoints": [[1, 1, 1], [2, 2, 1]], "speed": NaN}')
    assert code == 400 and 'NaN' in rep['error']
    # one waypoint clicked: the page gets the one error back
    page.get_by_test_id('walk-clear').click(no_wait_after=True, force=True, timeout=90000)
    p = page.evaluate('studio.moves.topPoint(2.0, -1.0)')
    page.mouse.click(p['x'], p['y'])
    page.get_by_test_id('walk').click(no_wait_after=True, force=True, timeout=90000)
    # the studio refused it (its one log line; the page shows the error once it reads it)
    _until(lambda: 'walk.waypoints: expected a list of 2 to 100' in
           open(shared_studio['log']).read(), timeout=90, what="the walk's error")
    time.sleep(0.3)
    assert np.allclose(model_state(shared_studio)[0], before, atol=1e-3)
    assert page.errors == [] and page.outside == []


def _device(page, topic, field):
    """The device panel's latest value of a topic's field (None until it has one)."""
    return page.evaluate("(() => { const v = studio.device && studio.device[%r]; if (!v) "
                         "return null; const f = v.fields.find((f) => f[0] === %r); "
                         "return f ? f[1] : null; })()" % (topic, field))


def test_nfc_switch_walk_height_vibration_and_time_of_day(shared_studio, page):
    """The NFC switch publishes nfc/enable and is recorded as the runner's radio action; a
    walk's waypoint takes the height field's value; the vibration shows the
    motor's state (still: off); the time of day sets the world's time_of_day, and the
    phone's light sensor outdoors reads the sun's daylight: noon bright, midnight dark."""
    code, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'record', 'on': True}))
    assert code == 200 and rep['recording'], rep
    box = page.get_by_test_id('radio-nfc')
    assert box.is_enabled() and box.is_checked()
    box.uncheck(no_wait_after=True, force=True, timeout=90000)
    _until(lambda: _device(page, '/mobile_device/nfc/enable', 'data') == 0.0, timeout=60,
           what='nfc/enable false in the device panel')
    box.check(no_wait_after=True, force=True, timeout=90000)
    _until(lambda: _device(page, '/mobile_device/nfc/enable', 'data') == 1.0, timeout=60,
           what='nfc/enable true again')
    code, rep = post(shared_studio, json.dumps({'v': 1, 'op': 'record', 'on': False}))
    assert 'action: radio, ns: mobile_device, radio: nfc, enabled: false' in rep['yaml'], rep
    # the walk's height: a waypoint clicked takes the height field's (empty, as in the walk
    # test above: the phone's height now)
    page.evaluate('studio.moves.waypoints = []')
    page.get_by_test_id('walk-height').fill('1.1', no_wait_after=True, force=True, timeout=90000)
    p = page.evaluate('studio.moves.topPoint(2.0, -1.0)')
    page.mouse.click(p['x'], p['y'])
    wps = page.evaluate('studio.moves.waypoints')
    assert len(wps) == 1 and wps[0][2] == 1.1, wps
    page.evaluate('studio.moves.waypoints = []; '
                  'document.querySelector("[data-testid=walk-height]").value = ""')
    # the vibration motor is still: its state topic says so
    _until(lambda: page.get_by_test_id('out-vibration').text_content() == 'off', timeout=60,
           what='the vibration state')
    # the time of day, outdoors (east of the office's door), face up on the ground
    start, _q = model_state(shared_studio)
    post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                    'position': [9.0, -3.0, 0.02], 'rpy': [0, 0, 0]}))
    lux = lambda: _device(page, '/mobile_device/illuminance', 'illuminance')   # noqa: E731
    try:
        for hour, ok in (('12', lambda v: v > 30000), ('0', lambda v: v < 100)):
            page.get_by_test_id('time-of-day').select_option(hour, no_wait_after=True,
                                                             force=True, timeout=90000)
            assert page.get_by_test_id('env-time_of_day').input_value() == hour
            assert page.get_by_test_id('env-daylight').input_value() == ''
            page.get_by_test_id('env-set').click(no_wait_after=True, force=True, timeout=90000)
            _until(lambda: (lambda v: v is not None and ok(v))(lux()), timeout=60,
                   what='the light sensor at %s:00' % hour)
    finally:
        post(shared_studio, json.dumps({'v': 1, 'op': 'set_environment',
                                        'values': {'daylight': 10000}}))
        post(shared_studio, json.dumps({'v': 1, 'op': 'set_pose', 'model': 'mobile_device',
                                        'position': start, 'rpy': [0, 0, 0]}))
    assert page.errors == []
