"""The studio's time travel (sim_studio.timetravel) without a roscore: a small recording
written with testing_instance's own writer (MCAP and rosbag) and a report.json beside it,
opened, scrubbed, plotted and compared through the studio's command handler; runs streamed
from a stand-in run_scenario; bad input is one error and the studio keeps serving."""
import asyncio
import io
import json
import os
import sys
import textwrap

import pytest

from sim_studio import timetravel
from sim_studio.timetravel import (Recording, expectation_field, find_report, run_command,
                                   scenario_copy)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_studio_protocol import cmd, run, serve, studio  # noqa: E402

DURATION = 2.0


def yaw_quat(yaw):
    import math
    return [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]


def write_recording(path):
    """2 s of a run: meta, two events, model_states at 20 Hz (the phone turning about z at
    1 rad/s and rising 0.1 m/s), an IMU at 100 Hz (linear_acceleration.y = t), a 8x6 camera
    image every 0.5 s (its red level 50 * i), the app's Int32 output."""
    import rospy
    from geometry_msgs.msg import Pose
    from mobile_device_sim.msg import ModelStates
    from sensor_msgs.msg import Image, Imu
    from std_msgs.msg import Int32, String
    from testing_instance.io.mcap_io import open_writer
    from testing_instance.run.recording import EVENTS_TOPIC, META_TOPIC
    w = open_writer(str(path))
    T = rospy.Time.from_sec
    w.write(META_TOPIC, String(json.dumps({'duration': DURATION, 't0': 0.0, 'seed': 1,
                                           'inputs': ['/mobile_device/imu_sensor_data']})),
            T(1e-9))
    rows = []
    for i in range(0, 201):
        t = i / 100.0
        imu = Imu()
        imu.header.stamp = T(t)
        imu.linear_acceleration.y = t
        rows.append((t, '/mobile_device/imu_sensor_data', imu))
        if i % 5 == 0:
            ms = ModelStates()
            ms.name = ['desk', 'mobile_device']
            p = Pose()
            p.position.x, p.position.y, p.position.z = 3.0, -2.0, 1.0 + 0.1 * t
            (p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w) = yaw_quat(t)
            d = Pose()
            d.orientation.w = 1.0
            ms.pose = [d, p]
            rows.append((t, '/gazebo/model_states', ms))
        if i % 50 == 0:
            img = Image(height=6, width=8, encoding='rgb8', step=24)
            img.header.stamp = T(t)
            img.data = bytes([50 * (i // 50), 0, 0] * 48)
            rows.append((t, '/mobile_device/image_raw', img))
    rows.append((0.5, EVENTS_TOPIC, String(json.dumps(
        {'t': 0.5, 'id': 'turn', 'action': 'rotate', 'text': 'event'}))))
    rows += [(0.0, '/app/out', Int32(-1)), (1.2, '/app/out', Int32(90))]
    for t, topic, msg in sorted(rows, key=lambda r: (r[0], r[1])):
        w.write(topic, msg, T(max(t, 1e-9)))
    w.close()
    return str(path)


def write_report(d, status='FAIL'):
    """A report.json as run_scenario --report writes it (the fields time travel reads)."""
    rep = {'status': status, 'verdicts': [
        {'name': 'acc_up', 'status': 'PASS', 't': 1.5,
         'expected': 'eventually /mobile_device/imu_sensor_data.linear_acceleration.y 1.5 '
                     '+- 0.01 in [1.000, 2.000] s', 'actual': '1.5'},
        {'name': 'turned', 'status': status, 't': 1.2,
         'expected': 'eventually /app/out.data == 270 in [1.000, 1.800] s after turn',
         'actual': 'last 90'}],
        'plots': {'acc_up': {'window': [1.0, 2.0], 'band': ['band', 1.49, 1.51]},
                  'turned': {'window': [1.0, 1.8]}}}
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, 'report.json'), 'w') as f:
        json.dump(rep, f)
    with open(os.path.join(d, 'index.html'), 'w') as f:
        f.write('<html><body>the report</body></html>')


@pytest.fixture(scope='module')
def rec_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp('tt')
    write_recording(d / 'run.mcap')
    write_recording(d / 'run.bag')
    write_report(str(d / 'report'))
    b = d / 'b'
    b.mkdir()
    write_recording(b / 'other.mcap')
    write_report(str(b), status='PASS')
    (d / 'notes.txt').write_text('not a recording\n')
    return d


def ask(s, **kw):
    return run(s.handle_text(cmd(**kw)))


def test_a_recording_opens_with_its_topics_events_and_the_verdicts_of_its_report(rec_dir):
    s = studio()
    rep = ask(s, op='tt_open', path=str(rec_dir / 'run.mcap'))
    assert rep['ok'], rep
    r = rep['recording']
    assert r['t0'] == pytest.approx(0.0, abs=1e-6) and r['t1'] == pytest.approx(DURATION)
    assert r['poses'] and r['images'] == ['/mobile_device/image_raw']
    assert r['topics']['/mobile_device/imu_sensor_data']['n'] == 201
    assert 'linear_acceleration.y' in r['topics']['/mobile_device/imu_sensor_data']['fields']
    assert [(e['id'], e['t']) for e in r['events']] == [('turn', 0.5)]
    assert r['status'] == 'FAIL' and r['report'] == '/api/timetravel/report/0/index.html'
    v = {x['name']: x for x in r['verdicts']}
    assert (v['turned']['status'], v['turned']['t'], v['turned']['window']) == \
        ('FAIL', 1.2, [1.0, 1.8])
    assert (v['turned']['topic'], v['turned']['field']) == ('/app/out', 'data')
    assert v['acc_up']['field'] == 'linear_acceleration.y'
    # the meta's bulky lists stay on the server
    assert 'inputs' not in r['meta'] and r['meta']['seed'] == 1


@pytest.mark.parametrize('name', ['run.mcap', 'run.bag'])
def test_the_poses_and_frames_at_a_time_are_the_recorded_ones(rec_dir, name):
    s = studio()
    assert ask(s, op='tt_open', path=str(rec_dir / name))['ok']
    for t, expect_t in ((0.52, 0.5), (1.5, 1.5), (0.0, 0.0)):
        rep = ask(s, op='tt_at', t=t)
        assert rep['ok'], rep
        assert rep['poses_t'] == pytest.approx(expect_t, abs=1e-6)
        p = rep['poses']['mobile_device']
        assert p[2] == pytest.approx(1.0 + 0.1 * expect_t)
        assert p[3:] == pytest.approx(yaw_quat(expect_t))
        f = rep['frames']['/mobile_device/image_raw']
        assert f['t'] == pytest.approx(int(t * 2) / 2.0, abs=1e-6)
        assert f['url'] == '/api/timetravel/frame/0/%d/mobile_device/image_raw' % int(t * 2)


def test_a_frame_is_served_as_the_recorded_image(rec_dir):
    from PIL import Image
    s = studio()
    assert ask(s, op='tt_open', path=str(rec_dir))['ok']      # a folder: its recording
    url = ask(s, op='tt_at', t=1.1)['frames']['/mobile_device/image_raw']['url']

    async def fn(c):
        r = await c.get(url)
        bad = await c.get('/api/timetravel/frame/0/99/mobile_device/image_raw')
        other = await c.get('/api/timetravel/frame/0/0/mobile_device/imu_sensor_data')
        return r.status, r.content_type, await r.read(), bad.status, other.status
    st, ctype, body, bad, other = serve(s, fn)
    assert (st, ctype, bad, other) == (200, 'image/jpeg', 404, 404)
    img = Image.open(io.BytesIO(body)).convert('RGB')
    assert img.size == (8, 6)
    r, g, b = img.getpixel((4, 3))
    assert abs(r - 100) < 12 and g < 12 and b < 12          # frame 2: red 100


def test_a_series_is_the_field_over_a_window_thinned(rec_dir):
    s = studio()
    ask(s, op='tt_open', path=str(rec_dir / 'run.mcap'))
    rep = ask(s, op='tt_series', topic='/mobile_device/imu_sensor_data',
              field='linear_acceleration.y', start=0.5, end=1.0)
    (label, pts), = rep['series']
    assert label == 'linear_acceleration.y' and len(pts) == 51
    assert all(v == pytest.approx(t) for t, v in pts) and pts[0][0] == pytest.approx(0.5)
    thin = ask(s, op='tt_series', topic='/mobile_device/imu_sensor_data',
               field='linear_acceleration', points=40)['series']
    assert [x[0] for x in thin] == ['linear_acceleration[0]', 'linear_acceleration[1]',
                                    'linear_acceleration[2]']
    assert 8 <= len(thin[1][1]) <= 44 and thin[1][1][-1][1] == pytest.approx(2.0)


def test_two_runs_side_by_side(rec_dir):
    s = studio()
    ask(s, op='tt_open', path=str(rec_dir / 'run.mcap'))
    rep = ask(s, op='tt_open', path=str(rec_dir / 'b' / 'other.mcap'), slot=1)
    assert rep['ok'] and rep['slot'] == 1
    assert {v['name']: v['status'] for v in rep['recording']['verdicts']} == \
        {'acc_up': 'PASS', 'turned': 'PASS'}
    a = ask(s, op='tt_series', topic='/app/out', field='data')
    b = ask(s, op='tt_series', topic='/app/out', field='data', slot=1)
    assert a['series'] == b['series'] == [['data', [[0.0, -1.0], [1.2, 90.0]]]]
    assert ask(s, op='tt_close', slot=1)['ok']
    assert 'no recording open in slot 1' in ask(s, op='tt_at', t=1, slot=1)['error']


@pytest.mark.parametrize('fields,words', [
    ({'op': 'tt_open', 'path': '/no/such/run.mcap'}, 'no such recording'),
    ({'op': 'tt_open', 'path': 'NOTES'}, 'is not a recording'),
    ({'op': 'tt_open', 'path': 'B_DIR_EMPTY'}, 'without a recording'),
    ({'op': 'tt_open', 'path': 'RUN', 'slot': 2}, 'slot: expected 0'),
    ({'op': 'tt_at', 't': 7.5}, 'outside the recording'),
    ({'op': 'tt_at', 't': -1}, 'outside the recording'),
    ({'op': 'tt_at', 't': 'soon'}, 'expected a finite number'),
    ({'op': 'tt_series', 'topic': '/nope', 'field': 'data'}, 'no topic /nope'),
    ({'op': 'tt_series', 'topic': '/app/out', 'field': 'dta'}, "no field 'dta'"),
    ({'op': 'tt_series', 'topic': '/mobile_device/image_raw', 'field': 'encoding'},
     'is not numeric'),
    ({'op': 'tt_series', 'topic': '/app/out', 'field': 'data', 'start': 1, 'end': 0.5},
     'start < end'),
    ({'op': 'tt_run'}, 'needs the scenario'),
    ({'op': 'tt_run', 'file': '/no/such.yaml'}, 'no scenario file'),
    ({'op': 'tt_run', 'yaml': 'duration: 1\n', 'sweep': True}, 'no sweep: block'),
    ({'op': 'tt_run', 'yaml': 'duration: 1\n', 'cluster': 'h:6379'}, 'give sweep: true'),
])
def test_bad_input_is_one_error_and_the_studio_keeps_serving(rec_dir, tmp_path, fields,
                                                                words):
    s = studio()
    assert ask(s, op='tt_open', path=str(rec_dir / 'run.mcap'))['ok']
    names = {'NOTES': str(rec_dir / 'notes.txt'), 'B_DIR_EMPTY': str(tmp_path),
             'RUN': str(rec_dir / 'run.mcap')}
    if fields.get('path') in names:
        fields = dict(fields, path=names[fields['path']])
    rep = ask(s, **fields)
    assert not rep['ok'] and words in rep['error'], rep
    assert ask(s, op='tt_at', t=1.0)['ok']          # the open recording still answers
    assert s.timetravel['runs'] == {}


def test_the_expectation_field_and_the_report_beside_a_recording(rec_dir):
    assert expectation_field('always /a/b_c.d[0].e == 1 in [0, 1] s') == ('/a/b_c', 'd[0].e')
    assert expectation_field('Hz of /mobile_device/imu 100 +- 1') == ('/mobile_device/imu', None)
    assert expectation_field('nothing') == (None, None)
    d, rep = find_report(str(rec_dir / 'run.mcap'))
    assert d == str(rec_dir / 'report') and rep['status'] == 'FAIL'
    assert find_report(str(rec_dir / 'nothing' / 'x.mcap')) == (None, None)


def test_a_damaged_recording_opens_up_to_its_damage(rec_dir, tmp_path):
    data = (rec_dir / 'run.mcap').read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:len(data) * 2 // 3])
    r = Recording(str(cut))
    assert r.warning and 0.3 < r.t1 <= DURATION
    empty = tmp_path / 'empty.mcap'
    empty.write_bytes(data[:8])
    s = studio()
    rep = ask(s, op='tt_open', path=str(empty))
    assert not rep['ok'] and 'tt_open' in rep['error']


def test_the_run_copy_records_the_poses_and_finds_the_files_beside_the_scenario(tmp_path):
    src = tmp_path / 'src'
    src.mkdir()
    (src / 'app.py').write_text('print(1)\n')
    (src / 'sc.yaml').write_text('duration: 1  # short\napps: [{name: a, script: app.py}]\n')
    d1 = tmp_path / 'r1'
    d1.mkdir()
    out = scenario_copy(None, str(src / 'sc.yaml'), str(d1))
    text = open(out).read()
    assert out == str(d1 / 'sc.yaml') and text.startswith('duration: 1  # short\n')
    assert text.endswith('record: [/gazebo/model_states]\n')
    assert os.path.realpath(str(d1 / 'app.py')) == str(src / 'app.py')
    d2 = tmp_path / 'r2'
    d2.mkdir()
    import yaml
    out = scenario_copy('duration: 1\nrecord: [/x]\n', None, str(d2))
    assert yaml.safe_load(open(out))['record'] == ['/x', '/gazebo/model_states']
    assert os.path.basename(out) == 'scenario.yaml'


def test_the_command_lines_of_a_run_a_local_sweep_and_a_cluster_sweep():
    one = run_command('/d/s.yaml', '/d')
    assert one[1:] == [timetravel_runner(), '/d/s.yaml', '--record', '/d/run.mcap',
                       '--report', '/d/report', '--live']
    # run_scenario takes what the studio gives it
    from testing_instance.farm.command import parser
    a = parser('run_scenario').parse_args(one[2:])
    assert a.live and a.record == ['/d/run.mcap'] and a.report == '/d/report'
    local = run_command('/d/s.yaml', '/d', sweep=True, jobs=3)
    assert local[3:] == ['--sweep', '--out', '/d/sweep', '--json', '/d/sweep.json',
                         '--report', '/d/report', '--jobs', '3']
    cl = run_command('/d/s.yaml', '/d', sweep=True, cluster='ray://head:10001',
                     cpus_per_run=2)
    assert cl[-4:] == ['--cluster', 'ray://head:10001', '--cpus-per-run', '2']
    assert '--jobs' not in cl


def timetravel_runner():
    from sim_studio.server import RUN_SCENARIO
    return RUN_SCENARIO


FAKE_RUNNER = textwrap.dedent('''\
    import os, sys, time
    a = sys.argv[1:]
    def opt(k):
        return a[a.index(k) + 1] if k in a else None
    print('  t=0.500 s: turn (rotate)', flush=True)
    time.sleep(0.3)
    print('decided PASS acc_up: expected ...; actual 1.4; at t=1.400 s', flush=True)
    time.sleep(0.3)
    print('PASS acc_up: expected ...; actual 1.5; at t=1.500 s', flush=True)
    time.sleep(0.3)
    print('FAIL turned: expected ...; actual last 90; at t=1.200 s', flush=True)
    if opt('--report'):
        os.makedirs(opt('--report'))
        open(os.path.join(opt('--report'), 'index.html'), 'w').write('<p>report</p>')
    if opt('--record'):
        open(opt('--record'), 'wb').write(b'x')
    if opt('--json'):
        open(opt('--json'), 'w').write('{"total": 2, "passed": 1, "failed": 1, "errors": 0,'
                                       ' "runs": [{"name": "s[a=1]", "status": "PASS"}]}')
    sys.exit(1)
''')


def test_a_run_streams_its_lines_and_verdicts_then_its_report_and_recording(tmp_path):
    s = studio()
    s.run_dir = str(tmp_path / 'runs')
    runner = tmp_path / 'fake_run_scenario'
    runner.write_text(FAKE_RUNNER)
    timetravel.attach(s)
    s.timetravel['runner'] = str(runner)
    seen = []
    s.broadcast = lambda kind, obj, clients=None: seen.append((kind, json.loads(json.dumps(obj))))

    async def go():
        rep = await s.handle_text(cmd(op='tt_run', yaml='duration: 2\nsweep: {a: [1, 2]}\n',
                                      sweep=True, jobs=2))
        again = await s.handle_text(cmd(op='tt_run', yaml='duration: 2\n'))
        for _ in range(200):
            if s.timetravel['runs'][1].state == 'done':
                break
            await asyncio.sleep(0.05)
        return rep, again
    rep, again = run(go())
    assert rep['ok'] and rep['run'] == 1 and '--sweep' in rep['command'], rep
    assert not again['ok'] and 'a run is going on' in again['error']
    kinds = set(k for k, _ in seen)
    msgs = [m for _, m in seen]
    assert kinds == {'tt_run'}
    running = [m for m in msgs if m['state'] == 'running']
    # the verdicts arrived one by one while it ran: acc_up as it was decided (--live), then
    # its line at the end in its place, then turned
    assert [len(m['verdicts']) for m in running][-4:] == [0, 1, 1, 2]
    first = [m for m in running if m['verdicts']][0]['verdicts'][0]
    assert first == {'status': 'PASS', 'name': 'acc_up', 't': 1.4, 'live': True,
                     'line': 'PASS acc_up: expected ...; actual 1.4; at t=1.400 s'}
    assert running[-1]['verdicts'][0]['t'] == 1.5 and not running[-1]['verdicts'][0]['live']
    assert running[-1]['verdicts'][1] == {'status': 'FAIL', 'name': 'turned', 't': 1.2,
                                          'live': False,
                                          'line': running[-1]['lines'][-1].strip()}
    end = msgs[-1]
    assert (end['state'], end['status'], end['code']) == ('done', 'FAIL', 1)
    assert end['report'] == '/api/timetravel/runs/run1/report/index.html'
    assert end['summary']['passed'] == 1 and end['runs'][0]['name'] == 's[a=1]'
    copy = open(os.path.join(s.run_dir, 'timetravel', 'run1', 'scenario.yaml')).read()
    assert '/gazebo/model_states' in copy

    async def fn(c):
        r = await c.get(end['report'])
        bad = await c.get('/api/timetravel/runs/run1/../../../etc/passwd')
        bad2 = await c.get('/api/timetravel/runs/%2e%2e/%2e%2e/etc/passwd')
        return r.status, await r.text(), bad.status, bad2.status
    st, body, bad, bad2 = serve(s, fn)
    assert (st, bad, bad2) == (200, 404, 404) and 'report' in body
