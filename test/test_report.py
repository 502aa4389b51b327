"""Recordings as MCAP and scenario reports (issue 20), with a real roscore, world and app,
and the reports looked at in a real browser (Debian's chromium driven by Playwright).

- one live run of the failing compass example (plus an expectation on the magnetometer's
  own field) records a rosbag and an MCAP file at once and writes its report: every message
  of the MCAP file equals the rosbag's;
- replaying the MCAP file with --report gives the same verdicts and the same plotted points
  (the world's stamped topics exactly; the app's unstamped outputs are timed by their
  arrival, within a slice, as the README says);
- in Chromium: the verdict rows and statuses are on the page, every plot has drawn pixels
  of its series, every image loaded, the failing plot shows the deciding time and the band
  where they belong, and the page asked for nothing outside its folder; the QR example's
  reports (failing and passing) and a farm index page too.
"""
import io
import json
import os
import re

import pytest

from fixtures.scenario_cli import run_scenario

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EX = os.path.join(ROOT, 'testing_instance', 'examples')
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
CHROMIUM = os.environ.get('MDS_CHROMIUM', '/usr/bin/chromium')

pytestmark = pytest.mark.rostest

EXTRA = """\
  - name: magnetic_x_small
    topic: /mobile_device/magnetic
    field: magnetic_field.x
    always: {between: [-0.001, 0.001]}
"""


def run(*args, timeout=600):
    return run_scenario(*args, timeout=timeout)


def verdicts(text):
    return {m.group(2): m.group(1) for m in re.finditer(r'^(PASS|FAIL|ERROR) (\w+):', text,
                                                        re.M)}


@pytest.fixture(scope='module')
def compass(tmp_path_factory):
    d = tmp_path_factory.mktemp('compass')
    sc = open(os.path.join(EX, 'compass_fails.yaml')).read().replace(
        'script: compass_app.py', 'script: %s' % os.path.join(EX, 'compass_app.py'))
    (d / 'compass_fails.yaml').write_text(sc + EXTRA)
    rc, out = run(d / 'compass_fails.yaml', '--record', d / 'run.bag', '--record',
                  d / 'run.mcap', '--report', d / 'live')
    return dict(dir=d, rc=rc, out=out, scenario=d / 'compass_fails.yaml')


@pytest.fixture(scope='module')
def compass_replay(compass):
    d = compass['dir']
    rc, out = run(compass['scenario'], '--replay', d / 'run.mcap', '--report', d / 'replay')
    return dict(rc=rc, out=out)


@pytest.fixture(scope='module')
def qr_reports(tmp_path_factory):
    d = tmp_path_factory.mktemp('qr')
    res = {}
    for name in ('qr_code_fails', 'qr_code'):
        rc, out = run(os.path.join(EX, name + '.yaml'), '--report', d / name)
        res[name] = dict(rc=rc, out=out, dir=d / name)
    return res


def test_mcap_and_rosbag_of_one_run_hold_the_same_messages(compass):
    assert compass['rc'] == 1, compass['out']
    from testing_instance.io.mcap_io import open_reader
    got = {}
    for name in ('run.bag', 'run.mcap'):
        r = open_reader(str(compass['dir'] / name))
        per_topic = {}
        for topic, raw, t in r.read_messages(raw=True):
            per_topic.setdefault(topic, []).append((t.to_nsec(), raw))
        r.close()
        got[name] = per_topic
    bag, mc = got['run.bag'], got['run.mcap']
    assert '/compass_app/azimuth' in bag and '/mobile_device/magnetic' in bag
    assert '/mobile_device/image_raw' in bag and '/flycam/image_raw' in bag  # the report's
    assert sorted(bag) == sorted(mc)
    for topic in bag:
        assert sorted(bag[topic]) == sorted(mc[topic]), topic
    assert sum(len(v) for v in mc.values()) > 300


def test_live_and_replay_reports_hold_the_same_verdicts_and_points(compass, compass_replay):
    assert compass_replay['rc'] == 1, compass_replay['out']
    live = verdicts(compass['out'])
    assert live == {'top_along_world_x': 'PASS', 'turned_left_by_90': 'FAIL',
                    'magnetometer_rate': 'PASS', 'magnetic_x_small': 'PASS'}, compass['out']
    assert verdicts(compass_replay['out']) == live, compass_replay['out']
    a, b = (json.load(open(str(compass['dir'] / k / 'report.json')))
            for k in ('live', 'replay'))
    assert a['mode'] == 'live' and b['mode'] == 'replay'
    assert [(v['name'], v['status']) for v in a['verdicts']] == \
        [(v['name'], v['status']) for v in b['verdicts']]
    assert sorted(a['plots']) == sorted(b['plots']) == sorted(live)
    # the world's stamped topics: the very same points and deciding messages
    for name in ('magnetic_x_small', 'magnetometer_rate'):
        assert a['plots'][name] == b['plots'][name], name
        assert len(a['plots'][name]['series'][0][1]) >= 150
    ta = {v['name']: v['t'] for v in a['verdicts']}
    tb = {v['name']: v['t'] for v in b['verdicts']}
    assert ta['magnetic_x_small'] == tb['magnetic_x_small']
    # the app runs again in the replay (its two inputs race each other): as many points
    # (give or take one a slice late at the ends), the same band, the deciding message
    # within a slice
    for name in ('top_along_world_x', 'turned_left_by_90'):
        pa, pb = a['plots'][name], b['plots'][name]
        na, nb = len(pa['series'][0][1]), len(pb['series'][0][1])
        assert na > 100 and abs(na - nb) <= 2, (name, na, nb)
        assert pa['band'] == pb['band'] and pa['window'] == pb['window']
        assert abs(pa['decider'][0] - pb['decider'][0]) <= 0.05 + 1e-9, (pa['decider'],
                                                                          pb['decider'])
        assert abs(ta[name] - tb[name]) <= 0.05 + 1e-9


def test_unwritable_report_folder_changes_nothing_else(tmp_path, compass):
    blocker = tmp_path / 'file'
    blocker.write_text('x')
    rc, out = run(compass['scenario'], '--replay', compass['dir'] / 'run.mcap', '--report',
                  blocker / 'rep')
    assert rc == 1, out
    assert verdicts(out) == verdicts(compass['out'])
    bad = [ln for ln in out.splitlines() if ln.startswith('report: cannot write the report')]
    assert len(bad) == 1, out
    assert 'Traceback' not in out


def test_replay_of_a_file_that_is_no_recording_is_one_error_line(tmp_path):
    junk = tmp_path / 'junk.mcap'
    junk.write_text('not a recording\n')
    rc, out = run(os.path.join(EX, 'compass_fails.yaml'), '--replay', junk, timeout=120)
    assert rc == 2, out
    assert re.search(r'^ERROR .*junk.mcap is not a recording \(neither a rosbag nor an MCAP '
                     r'file', out, re.M), out
    assert 'Traceback' not in out


@pytest.fixture(scope='module')
def farm(tmp_path_factory):
    """A farm of a run that errs (a topic typo) and one that passes, with --report."""
    d = tmp_path_factory.mktemp('farm')
    (d / 'typo.yaml').write_text(
        'duration: 0.5\nworld: {args: {camera_rate: 1}}\nexpect:\n'
        '  - {name: topic_typo, topic: /mobile_device/imu_sensor_dat, rate: {gt: 1}}\n'
        '  - {name: upright_z, topic: /mobile_device/imu_sensor_data,\n'
        '     field: linear_acceleration.z, always: {gt: 5}}\n')
    (d / 'fine.yaml').write_text(
        'duration: 0.5\nseed: 3\nworld: {args: {camera_rate: 1}}\nexpect:\n'
        '  - {name: imu_rate, topic: /mobile_device/imu_sensor_data, rate: {near: 100, '
        'tol: 1}}\n')
    rc, out = run('--jobs', '2', d / 'typo.yaml', d / 'fine.yaml', '--report', d / 'out')
    return dict(rc=rc, out=out, dir=d / 'out')


def test_farm_report_index_and_error_log_tails(farm):
    assert farm['rc'] == 2, farm['out']
    assert 'report: %s' % (farm['dir'] / 'index.html') in farm['out']
    page = (farm['dir'] / 'index.html').read_text()
    assert '2 runs: 1 PASS, 0 FAIL, 1 ERROR' in page
    assert '<a href="fine/index.html">fine</a>' in page and '<td>3</td>' in page
    err = (farm['dir'] / 'typo' / 'index.html').read_text()
    assert 'id="logs"' in err and '<h3>world.log</h3>' in err
    assert 'sim_world' in err[err.index('id="logs"'):]
    assert '\x1b[' not in err
    d = json.load(open(str(farm['dir'] / 'typo' / 'report.json')))
    assert {v['name']: v['status'] for v in d['verdicts']} == {'topic_typo': 'ERROR',
                                                              'upright_z': 'PASS'}
    assert d['plots']['upright_z']['band'] == ['above', 5.0, None]
    assert 'topic_typo' not in d['plots']
    assert d['verdicts'][0]['note'] == 'no plot: fewer than two messages'


# -- in a real browser -------------------------------------------------------------------------
@pytest.fixture(scope='module')
def browser():
    from playwright.sync_api import sync_playwright
    assert os.access(CHROMIUM, os.X_OK), 'Debian\'s chromium is missing (tools/apt-packages.txt)'
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=['--no-sandbox'])
        yield b
        b.close()


def open_report(browser, folder, page_name='index.html'):
    """Load a report in Chromium; returns (page, requests it made)."""
    page = browser.new_page(viewport={'width': 1200, 'height': 900})
    requests = []
    page.on('request', lambda req: requests.append(req.url))
    page.goto('file://%s' % os.path.join(str(folder), page_name))
    page.wait_for_load_state('load')
    return page, requests


def png_pixels(png):
    import numpy as np
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(png)).convert('RGB')).astype(int)


def near(px, rgb, tol=40):
    import numpy as np
    return (np.abs(px - np.array(rgb)).sum(axis=-1) <= tol)


def check_report(browser, folder):
    data = json.load(open(os.path.join(str(folder), 'report.json')))
    page, requests = open_report(browser, folder)
    # the verdict rows and their statuses, as rendered
    rows = page.locator('tr.verdict')
    got = [(rows.nth(i).get_attribute('data-name'),
            rows.nth(i).locator('td.status').inner_text().strip())
           for i in range(rows.count())]
    assert got == [(v['name'], v['status']) for v in data['verdicts']]
    assert page.locator('h1 .badge').inner_text().strip() == data['status']
    # every plot drew its series (the series colour) inside its plot area
    plots = page.locator('div.plot')
    assert plots.count() == len(data['plots'])
    for i in range(plots.count()):
        px = png_pixels(plots.nth(i).locator('svg.plot-svg').screenshot())
        assert px.shape[1] >= 700, px.shape
        inner = px[14:196, 64:704]
        assert near(inner, (9, 105, 218), 60).sum() > 100, \
            'plot %s: no series pixels' % plots.nth(i).get_attribute('data-name')
        assert len({tuple(p) for p in inner.reshape(-1, 3)[::7]}) > 10
    # every image loaded
    imgs = page.locator('img')
    for i in range(imgs.count()):
        ok = imgs.nth(i).evaluate('e => e.complete && e.naturalWidth > 0')
        assert ok, imgs.nth(i).get_attribute('src')
    # nothing outside the report's folder
    base = 'file://%s/' % os.path.abspath(str(folder))
    assert requests and all(u.startswith(base) for u in requests), requests
    return page, data


def test_failing_compass_report_in_chromium(browser, compass):
    page, data = check_report(browser, compass['dir'] / 'live')
    assert page.locator('img').count() >= 6          # camera and flycam at the events
    # the failing plot: the deciding time as a red line where t=1.7 s lies, the band
    # 60.5..76.5 as a green strip where those values lie
    p = data['plots']['turned_left_by_90']
    assert p['decider'][0] == 1.7 and p['band'] == ['band', 60.5, 76.5]
    px = png_pixels(page.locator('#plot-turned_left_by_90 svg.plot-svg').screenshot())
    from testing_instance.report import MB, ML, MR, MT, PLOT_H, PLOT_W
    iw, ih = PLOT_W - ML - MR, PLOT_H - MT - MB
    x_d = int(round(ML + 1.7 / 3.0 * iw))
    red = near(px[MT + 20:MT + ih - 2, x_d - 1:x_d + 2], (207, 34, 46), 60)
    assert red.any(axis=1).mean() > 0.9, 'no deciding line at t=1.7 s'
    elsewhere = near(px[MT + 20:MT + ih - 2, x_d + 30:x_d + 33], (207, 34, 46), 60)
    assert elsewhere.any(axis=1).mean() < 0.1
    vals = [v for _t, v in p['series'][0][1]] + [60.5, 76.5]
    lo, hi = min(vals), max(vals)
    lo, hi = lo - (hi - lo) * 0.08, hi + (hi - lo) * 0.08

    def y(v):
        return int(round(MT + (hi - v) / (hi - lo) * ih))
    x_out = ML + 20                                   # before the window: white + band
    band_px = px[y(74):y(63), x_out]
    assert near(band_px, (209, 235, 216), 30).mean() > 0.8, band_px[:5]
    above = px[y(150):y(120), x_out]
    assert not near(above, (209, 235, 216), 30).any()
    page.close()


def test_qr_reports_in_chromium_and_the_readme_screenshot(browser, qr_reports):
    fails, ok = qr_reports['qr_code_fails'], qr_reports['qr_code']
    assert fails['rc'] == 1 and ok['rc'] == 0, fails['out'] + ok['out']
    page, data = check_report(browser, fails['dir'])
    assert {v['name']: v['status'] for v in data['verdicts']}['app_decodes'] == 'FAIL'
    row = page.locator('tr.verdict[data-name="app_decodes"] td.note').inner_text()
    assert 'not numeric' in row
    # the barcode zbar found and the checked screen region are outlined on the frames
    assert page.locator('#check-camera_sees_code polygon.barcode').count() == 1
    assert page.locator('#check-app_shows_result rect.region').count() == 1
    px = png_pixels(page.locator('#check-camera_sees_code .imgbox').screenshot())
    assert near(px, (255, 0, 255), 80).sum() > 50, 'barcode outline not drawn'
    shot = os.environ.get('MDS_REPORT_SCREENSHOT')    # docs/report_qr_fails.png is made so
    if shot:
        page.set_viewport_size({'width': 1000, 'height': 1500})
        page.evaluate('window.scrollTo(0, 0)')
        page.screenshot(path=shot, full_page=True,
                        clip={'x': 0, 'y': 0, 'width': 1000, 'height': 2200})
    page.close()
    page, data = check_report(browser, ok['dir'])
    assert data['status'] == 'PASS'
    page.close()


def test_farm_reports_in_chromium(browser, farm):
    page, requests = open_report(browser, farm['dir'])
    assert page.locator('tr.run').count() == 2
    page.close()
    page, _data = check_report(browser, farm['dir'] / 'typo')
    assert page.locator('#logs pre.log').count() >= 1
    assert page.locator('#logs').inner_text().count('sim_world') >= 1
    page.close()
    base = 'file://%s/' % farm['dir']
    assert all(u.startswith(base) for u in requests), requests


def test_farm_index_in_chromium(browser, tmp_path, qr_reports, compass):
    from testing_instance.report import write_index
    import shutil
    runs = []
    for name, d in (('qr_code_fails', qr_reports['qr_code_fails']['dir']),
                    ('qr_code', qr_reports['qr_code']['dir']),
                    ('compass_fails', compass['dir'] / 'live')):
        shutil.copytree(str(d), str(tmp_path / name))
        st = json.load(open(str(tmp_path / name / 'report.json')))['status']
        runs.append(dict(name=name, status=st, wall=1.0, report=str(tmp_path / name)))
    write_index(str(tmp_path), runs, 3.0)
    page, requests = open_report(browser, tmp_path)
    rows = page.locator('tr.run')
    assert rows.count() == 3
    assert page.locator('p.totals').inner_text().startswith('3 runs: 1 PASS, 2 FAIL, 0 ERROR')
    page.locator('a', has_text='compass_fails').click()
    page.wait_for_load_state('load')
    assert page.locator('tr.verdict').count() == 4
    base = 'file://%s/' % tmp_path
    assert all(u.startswith(base) for u in requests), requests
    page.close()
