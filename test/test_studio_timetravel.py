"""The studio's time travel in Chromium (sim_studio/timetravel.py, static/ext/timetravel.js)
on the shared studio: a run of auto_rotate_fails.yaml from the panel streams its lines and
verdicts and opens its report; its recording is scrubbed with the real mouse on the slider
(the 3D view shows the recorded phone pose at two positions), jump to the first failure
lands at the failing verdict's time, a second run is compared (and, when it recorded the
model poses, drawn as a translucent ghost in the 3D view where its poses differ), a bad path
is one error and ?recording=PATH opens a recording."""
import json
import os

import numpy as np
import pytest

from fixtures.studio import data_url, png_pixels

pytestmark = pytest.mark.rostest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENARIO = os.path.join(ROOT, 'testing_instance', 'examples', 'auto_rotate_fails.yaml')


@pytest.fixture(scope='module')
def ran(shared_studio, shared_page):
    """auto_rotate_fails.yaml run from the panel (run + report), to its end."""
    return run_from_panel(shared_page)


def run_from_panel(pg):
    pg.evaluate("studio.setView('free'); studio.live = true")
    pg.get_by_test_id('tt-file').fill(SCENARIO, timeout=90000)
    pg.get_by_test_id('tt-run').click(no_wait_after=True, timeout=90000)
    pg.wait_for_function("studio.tt.run && studio.tt.run.state === 'done'", timeout=300000)
    pg.wait_for_function("studio.tt.rec[0] && studio.tt.rec[0].poses", timeout=60000)
    return pg.evaluate("studio.tt.run")


def test_a_run_streams_its_verdicts_and_opens_its_report(shared_page, ran):
    pg = shared_page
    assert (ran['status'], ran['code']) == ('FAIL', 1), '\n'.join(ran['lines'])
    msgs = pg.evaluate('studio.tt.runMessages')
    running = [m for m in msgs if m['state'] == 'running']
    # the lines came while it ran (its timeline's events), not only at its end
    assert len(running) >= 2 and running[0]['lines'] < running[-1]['lines']
    assert len(ran['verdicts']) == 5
    text = pg.get_by_test_id('tt-run-verdicts').text_content()
    assert 'FAIL landscape' in text and 'PASS portrait' in text and 'run %d: FAIL' % ran['run'] in text
    # on the timeline: the FAIL at 1.98 s is drawn in red where it belongs
    report = pg.frame_locator('[data-testid=tt-report]')
    body = report.locator('body')
    body.wait_for(timeout=30000)
    assert 'landscape' in body.text_content() and 'FAIL' in body.text_content()
    assert ran['report'].startswith('/api/timetravel/runs/run')
    assert pg.outside == [] and pg.errors == []


def _click_slider(pg, frac):
    pg.evaluate("document.querySelector('[data-testid=tt-slider]')"
                ".scrollIntoView({block: 'center'})")
    box = pg.get_by_test_id('tt-slider').bounding_box()
    n = pg.evaluate('studio.tt.atReplies')
    pg.mouse.click(box['x'] + box['width'] * frac, box['y'] + box['height'] / 2)
    pg.wait_for_function('studio.tt.atReplies > %d && !studio.tt.busy && studio.tt.want '
                         '=== null' % n, timeout=60000)
    return pg.evaluate('parseFloat(document.querySelector("[data-testid=tt-slider]").value)')


def _recorded_phone(path, t):
    """The phone's pose in the last /gazebo/model_states at or before t (the project's
    reader)."""
    from testing_instance.io.mcap_io import open_reader
    best = None
    r = open_reader(path)
    for _topic, m, mt in r.read_messages(topics=['/gazebo/model_states']):
        if best is None or mt.to_sec() <= t + 1e-9:
            p = m.pose[m.name.index('mobile_device')]
            best = [p.position.x, p.position.y, p.position.z, p.orientation.x,
                    p.orientation.y, p.orientation.z, p.orientation.w]
    r.close()
    return best


def _phone_crop(pg):
    pg.evaluate('new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))')
    px = png_pixels(data_url(pg, "document.querySelector('[data-testid=viewport]')"))
    dpr = pg.evaluate('window.devicePixelRatio')
    p = pg.evaluate("(() => { const c = document.querySelector('[data-testid=viewport]')"
                    ".getBoundingClientRect(), s = studio.screenPoint('mobile_device'); "
                    "return [s.x - c.left, s.y - c.top]; })()")
    x, y = int(p[0] * dpr), int(p[1] * dpr)
    return px[max(0, y - 60):y + 60, max(0, x - 60):x + 60]


def test_the_slider_scrubs_the_3d_view_through_the_recorded_poses(shared_page, ran):
    pg = shared_page
    path = ran['recording']
    pg.evaluate("studio.lookAt('mobile_device', [0.5, -0.7, 0.35])")
    seen = []
    for frac in (0.08, 0.45, 0.08):
        t = _click_slider(pg, frac)
        assert pg.evaluate('studio.live') is False
        rec = _recorded_phone(path, t)
        q = pg.evaluate('(() => { const o = studio.models.mobile_device; return [o.position.x, '
                        'o.position.y, o.position.z, o.quaternion.x, o.quaternion.y, '
                        'o.quaternion.z, o.quaternion.w]; })()')
        assert q == pytest.approx(rec, abs=1e-5), (t, q, rec)
        assert float(pg.get_by_test_id('tt-time').text_content()) == pytest.approx(t, abs=1e-3)
        seen.append((t, rec, _phone_crop(pg)))
    (ta, qa, a), (tb, qb, b), (_, _, a2) = seen
    assert ta < 0.45 < 1.1 < tb < 1.7          # flat, then upright (rotated at 0.5-0.8 s)
    assert abs(qa[4]) < 0.05 and abs(qb[4]) > 0.6
    diff = lambda u, v: np.abs(u.astype(int) - v.astype(int)).mean()  # noqa: E731
    assert diff(a, b) > 4 * max(diff(a, a2), 0.5), (diff(a, b), diff(a, a2))
    # the recorded camera frames follow the slider
    pg.wait_for_function("[...document.querySelectorAll('[data-testid=tt-frame]')]"
                         ".some((i) => i.naturalWidth > 0)", timeout=60000)


def test_jump_to_the_first_failure_lands_at_the_failing_verdict(shared_page, ran):
    pg = shared_page
    rep = json.load(open(os.path.join(os.path.dirname(ran['recording']), 'report',
                                      'report.json')))
    bad = min((v for v in rep['verdicts'] if v['status'] != 'PASS'), key=lambda v: v['t'])
    assert bad['name'] == 'landscape'
    n = pg.evaluate('studio.tt.atReplies')
    pg.get_by_test_id('tt-first-failure').click()
    pg.wait_for_function('studio.tt.atReplies > %d' % n, timeout=60000)
    assert pg.evaluate('studio.tt.t') == pytest.approx(bad['t'], abs=1e-6)
    assert float(pg.get_by_test_id('tt-slider').input_value()) == pytest.approx(bad['t'],
                                                                               abs=1e-3)
    row = pg.locator('[data-testid=tt-verdicts] tr[data-name=landscape] td.FAIL')
    assert row.count() == 1
    # the plot shows the failing expectation's field with its window
    assert pg.get_by_test_id('tt-field').input_value() == '/rotate_app/rotation data'
    plot = png_pixels(data_url(pg, "document.querySelector('[data-testid=tt-plot]')"))
    assert plot.std() > 3
    # the timeline's cursor is where the failure is
    tl = png_pixels(data_url(pg, "document.querySelector('[data-testid=tt-timeline]')"))
    r = pg.evaluate('studio.tt.rec[0]')
    x = int(round(4 + (bad['t'] - r['t0']) / (r['t1'] - r['t0']) * (tl.shape[1] - 8)))
    assert (tl[:, x - 1:x + 2] > 240).all(axis=2).any()


def test_a_second_run_is_compared_side_by_side(shared_page, ran, tmp_path):
    import rospy
    from std_msgs.msg import Int32, String
    from testing_instance.io.mcap_io import open_writer
    pg = shared_page
    path = str(tmp_path / 'fixed.mcap')
    w = open_writer(path)
    T = rospy.Time.from_sec
    w.write('/scenario/meta', String(json.dumps({'duration': 3.0, 'inputs': []})), T(1e-9))
    for t, v in ((0.0, -1), (0.7, 0), (2.0, 270)):
        w.write('/rotate_app/rotation', Int32(v), T(max(t, 1e-9)))
    w.close()
    with open(str(tmp_path / 'report.json'), 'w') as f:
        json.dump({'status': 'PASS', 'verdicts': [
            {'name': 'landscape', 'status': 'PASS', 't': 2.0, 'actual': '270',
             'expected': 'eventually /rotate_app/rotation.data == 270 in [1.8, 2.6] s'}],
            'plots': {}}, f)
    pg.get_by_test_id('tt-path-b').fill(path)
    pg.get_by_test_id('tt-open-b').click()
    pg.wait_for_function('studio.tt.series[1] !== null && studio.tt.rec[1] !== null',
                         timeout=60000)
    row = pg.locator('[data-testid=tt-verdicts] tr[data-name=landscape] td')
    assert [row.nth(i).get_attribute('class') for i in (1, 2)] == ['FAIL', 'PASS']
    assert pg.evaluate('studio.tt.series[1].series') == [
        ['data', [[0.0, -1.0], [0.7, 0.0], [2.0, 270.0]]]]


GHOST_DX = 0.25          # m: the compared run's phone beside this run's


def _moved_copy(src, dst, dx=GHOST_DX):
    """A copy of a recording's meta data and model poses with the phone dx m further along x
    in every /gazebo/model_states."""
    from testing_instance.io.mcap_io import open_reader, open_writer
    r, w = open_reader(src), open_writer(dst)
    try:
        for topic, m, t in r.read_messages(topics=['/scenario/meta', '/gazebo/model_states']):
            if topic == '/gazebo/model_states':
                m.pose[m.name.index('mobile_device')].position.x += dx
            w.write(topic, m, t)
    finally:
        r.close()
        w.close()


def test_the_compared_run_is_drawn_as_a_ghost(shared_page, ran, tmp_path):
    pg = shared_page
    path = str(tmp_path / 'moved.mcap')
    _moved_copy(ran['recording'], path)
    pg.get_by_test_id('tt-path-b').fill(path)
    pg.get_by_test_id('tt-open-b').click()
    pg.wait_for_function('studio.tt.rec[1] && studio.tt.rec[1].path === %s && '
                         'studio.tt.rec[1].poses' % json.dumps(path), timeout=60000)
    assert pg.get_by_test_id('tt-ghost').is_checked()
    n = pg.evaluate('studio.tt.ghost.replies')
    t = _click_slider(pg, 0.45)
    pg.wait_for_function('studio.tt.ghost.replies > %d && !studio.tt.ghost.busy && '
                         'Math.abs(studio.tt.ghost.t - %r) < 1e-6' % (n, t), timeout=60000)
    # the scene graph: the ghost phone where the compared recording has it at that time,
    # beside this run's phone; the furniture (where both runs have it) has no ghost
    g = pg.evaluate("studio.tt.ghost.pose('mobile_device')")
    assert g == pytest.approx(_recorded_phone(path, t), abs=1e-5), (t, g)
    here = pg.evaluate('(() => { const o = studio.models.mobile_device; '
                       'return [o.position.x, o.position.y, o.position.z]; })()')
    assert g[0] - here[0] == pytest.approx(GHOST_DX, abs=1e-5) and g[1:3] == pytest.approx(
        here[1:], abs=1e-5)
    assert pg.evaluate('studio.tt.ghost.shown') == ['mobile_device']
    # and drawn: the view where the ghost is changes when the toggle hides it, and only there
    pg.evaluate("studio.lookAt('mobile_device', [%r, -0.9, 0.4])" % (GHOST_DX / 2))
    at = pg.evaluate("(() => { const c = studio.renderer.domElement, r = "
                     "c.getBoundingClientRect(), p = new THREE.Vector3(%r, %r, %r)"
                     ".project(studio.camera); return [(p.x + 1) / 2 * r.width, "
                     "(1 - p.y) / 2 * r.height]; })()" % tuple(g[:3]))
    dpr = pg.evaluate('window.devicePixelRatio')
    x, y = int(at[0] * dpr), int(at[1] * dpr)

    def view():
        """The 60 x 60 pixels of the view around the ghost and its top left 40 x 40, as
        drawn two frames later."""
        return [np.array(v, float) for v in pg.evaluate(
            """([x, y]) => new Promise((r) => requestAnimationFrame(() =>
              requestAnimationFrame(() => {
                const c = document.createElement('canvas'), g = c.getContext('2d');
                c.width = c.height = 60;
                const px = (sx, sy, n) => {
                  g.clearRect(0, 0, 60, 60);
                  g.drawImage(studio.renderer.domElement, sx, sy, n, n, 0, 0, n, n);
                  return Array.from(g.getImageData(0, 0, n, n).data);
                };
                r([px(Math.max(0, x - 30), Math.max(0, y - 30), 60), px(0, 0, 40)]);
              })))""", [x, y])]
    on = view()
    pg.get_by_test_id('tt-ghost').uncheck()
    off = view()
    pg.get_by_test_id('tt-ghost').check()
    near, corner = [np.abs(a - b).mean() for a, b in zip(on, off)]
    assert near > 3 and corner < 0.5, (near, corner)


def test_bad_input_is_one_error_and_a_link_opens_a_recording(shared_studio, shared_page, ran,
                                                            tmp_path):
    pg = shared_page
    bad = tmp_path / 'notes.txt'
    bad.write_text('hello\n')
    before = pg.evaluate('studio.tt.opened')
    pg.get_by_test_id('tt-path').fill(str(bad))
    pg.get_by_test_id('tt-open').click()
    pg.wait_for_function("document.querySelector('[data-testid=tt-msg]').textContent"
                         ".includes('is not a recording')", timeout=60000)
    assert pg.evaluate('studio.tt.opened') == before
    rep = pg.evaluate("studio.send({op: 'tt_at', t: 99})")
    assert not rep['ok'] and 'outside the recording' in rep['error']
    t = _click_slider(pg, 0.3)                    # the open run still scrubs
    assert pg.evaluate('studio.tt.t') == pytest.approx(t, abs=1e-6)
    pg.get_by_test_id('tt-live').click()
    assert pg.evaluate('studio.live') is True
    # a report's (or a script's) link: /?recording=PATH
    other = pg.context.browser.new_page(viewport={'width': 1280, 'height': 760})
    try:
        other.goto(shared_studio['url'] + '?recording=' + ran['recording'],
                   wait_until='domcontentloaded')
        other.wait_for_function('window.studio && studio.tt.rec[0] && studio.tt.atReplies > 0',
                                timeout=60000)
        assert other.evaluate('studio.tt.rec[0].path') == ran['recording']
        assert other.evaluate('studio.live') is False
    finally:
        other.close()
    assert pg.errors == []
