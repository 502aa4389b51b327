"""Integration tests of the testing instance: real roscore, real world, real apps.

- every example scenario passes and every deliberately failing variant fails with its
  message, run by the farm (--jobs 2; the session's, shared with the files that compare
  their own modes with it: fixtures/example_farm.py); serial runs agree with its verdicts
  (test_embedded.test_examples_get_the_same_verdicts_embedded);
- the same scenario and seed give identical recordings message by message, at real-time
  factor 0 and 1, and another seed does not;
- replaying a recording reproduces the app's outputs;
- a bad scenario file is an ERROR with file and line before anything starts; a world that
  dies mid-scenario is an ERROR with the world's last log lines.
Every world here runs at real_time_factor 0 with short sim-time windows.
"""
import glob
import os
import re
import subprocess

import pytest

from fixtures.scenario_cli import run_scenario

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EX = os.path.join(ROOT, 'testing_instance', 'examples')
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
TIMEOUT = 600

pytestmark = pytest.mark.rostest


def run(*args, timeout=TIMEOUT):
    return run_scenario(*args, timeout=timeout)


def verdicts(text, prefix=''):
    """{expectation name: status} of one run's lines (prefix: a farm's '[file] ')."""
    return {m.group(2): m.group(1) for m in re.finditer(
        r'^%s(PASS|FAIL|ERROR) (\w+):' % re.escape(prefix), text, re.M)}


def bag_messages(path, topics=None):
    import rosbag
    out = {}
    with rosbag.Bag(path) as b:
        for topic, msg, t, in b.read_messages(raw=True):
            if topics is None or topic in topics:
                out.setdefault(topic, []).append((t.to_nsec(), bytes(msg[1])))
    return out


def world_topics(path):
    import json
    import rosbag
    with rosbag.Bag(path) as b:
        for _t, msg, _s in b.read_messages(topics=['/scenario/meta']):
            return json.loads(msg.data)['inputs']


def test_bad_scenario_is_an_error_with_file_and_line(tmp_path):
    f = tmp_path / 'typo.yaml'
    f.write_text('duration: 2\ntimeline:\n  - {at: 0.5, action: mvoe_model, model: x}\n'
                 'expect:\n  - {topic: /x, always: {gt: 1}, window: [3, 1]}\n')
    rc, out = run(f, '--junit', tmp_path / 'j.xml', timeout=60)
    assert rc == 2, out
    assert "typo.yaml:3: timeline[0].action: unknown action 'mvoe_model'" in out
    assert "typo.yaml:5: expect[0].window: expected 0 <= start < end" in out
    assert 'Traceback' not in out
    assert '<error' in (tmp_path / 'j.xml').read_text()


def test_examples_farm_and_failure_reports(example_farm):
    # the session's farm over every example (fixtures/example_farm.py; test_embedded,
    # test_warm_farm and test_scenario_sweeps compare their own modes with it; the serial
    # runs that agree with it are test_embedded's examples run embedded)
    rc, out = example_farm.rc, example_farm.out
    assert rc == 1, out            # the failing variants fail, nothing is an error
    table = dict(re.findall(r'^(\S+\.yaml)\s+(PASS|FAIL|ERROR)\s', out, re.M))
    files = sorted(os.path.basename(p) for p in glob.glob(os.path.join(EX, '*.yaml')))
    assert sorted(table) == files, out
    for f, status in table.items():
        assert status == ('FAIL' if f.endswith('_fails.yaml') else 'PASS'), out
    # the failure reports say what was expected and what came
    assert re.search(r"\[qr_code_fails.yaml\] FAIL app_decodes: expected eventually "
                     r"/qr_app/result.data == 'QR-Code,http://www.tum.de' .*actual last "
                     r"'QR-Code,http://vmi.lmt.ei.tum.de'", out), out
    assert re.search(r"\[auto_rotate_fails.yaml\] FAIL landscape: expected eventually "
                     r"/rotate_app/rotation.data == 270 in \[1.800, 2.600\] s after landscape; "
                     r"actual last 90", out), out
    assert re.search(r"\[wifi_walk_fails.yaml\] FAIL west_ap_in_the_west_room: expected always "
                     r"/mobile_device/wifi/link.bssid == '00:1a:2b:3c:4d:01' .* after arrived; "
                     r"actual '00:1a:2b:3c:4d:02'", out), out
    assert len(glob.glob(str(example_farm.junit / '*.xml'))) == len(files)
    farm = verdicts(out, '[auto_rotate_fails.yaml] ')
    assert farm['landscape'] == 'FAIL' and farm['portrait'] == 'PASS'


def test_same_seed_same_recording_at_any_real_time_factor(tmp_path, auto_rotate_recording):
    sc = os.path.join(EX, 'auto_rotate.yaml')
    # a: the session's run at real_time_factor 0 (the file's; fixtures/example_farm.py)
    rc, out, a = auto_rotate_recording
    assert rc == 0, out
    b, c = tmp_path / 'b.bag', tmp_path / 'c.bag'
    rc, out = run(sc, '--record', b, '--real-time-factor', 1)
    assert rc == 0, out
    rc, out = run(sc, '--record', c, '--real-time-factor', 0, '--seed', 99)
    assert rc == 0, out
    inputs = world_topics(a)
    assert '/mobile_device/imu_sensor_data' in inputs
    ma, mb, mc = (bag_messages(p, inputs) for p in (a, b, c))
    # every message and its recorded time: the world's, the app's and the events (the
    # headerless std_msgs ones too: the world's by the sim time it published them at, the
    # app's by the slice that collected them), only the meta (its real-time factor) differs
    everything = set(bag_messages(a)) - {'/scenario/meta'}
    assert {'/rotate_app/rotation', '/mobile_device/led/state'} <= everything
    whole_a, whole_b = bag_messages(a, everything), bag_messages(b, everything)
    assert sorted(whole_a) == sorted(whole_b)
    for topic in whole_a:
        assert len(whole_a[topic]) == len(whole_b[topic]), topic
        for i, (x, y) in enumerate(zip(whole_a[topic], whole_b[topic])):
            assert x == y, '%s message %d (time, bytes) differs between real_time_factor 0 ' \
                'and 1' % (topic, i)
    imu = '/mobile_device/imu_sensor_data'
    assert len(ma[imu]) == 301      # 100 Hz over [0, 3] s: lossless
    assert [m for _t, m in ma[imu]] != [m for _t, m in mc[imu]], 'another seed, other noise'
    ev = bag_messages(a, ['/scenario/events'])['/scenario/events']
    assert [t for t, _m in ev] == [500000000, 1800000000]   # actions at exact sim times


def test_replay_reproduces_the_app_outputs(tmp_path):
    sc = os.path.join(EX, 'qr_code.yaml')
    live, rep = tmp_path / 'live.bag', tmp_path / 'replay.bag'
    rc, out = run(sc, '--record', live)
    assert rc == 0, out
    rc, out = run(sc, '--replay', live, '--record', rep)
    assert rc == 0, out
    assert 'PASS app_decodes' in out
    outputs = ['/qr_app/result', '/qr_app/screen']
    a, b = bag_messages(live, outputs), bag_messages(rep, outputs)
    assert [m for _t, m in a['/qr_app/result']] == [m for _t, m in b['/qr_app/result']]
    # the screen is latched: which of its frames a subscriber sees first depends on when it
    # connected; what the app ends up showing, and when (stamp), must be the same
    import rosbag
    last = []
    for path in (live, rep):
        with rosbag.Bag(str(path)) as bag:
            shown = [m for _t, m, _s in bag.read_messages(topics=['/qr_app/screen'])][-1]
        last.append((shown.header.stamp.to_nsec(), shown.width, shown.height, bytes(shown.data)))
    assert last[0] == last[1]
    cam = '/mobile_device/image_raw'
    assert bag_messages(live, [cam]) == bag_messages(rep, [cam])   # the inputs, replayed


def test_world_dying_mid_scenario_is_an_error_with_its_log(tmp_path):
    f = tmp_path / 'dies.yaml'
    f.write_text('duration: 3\nworld: {launch: %s}\nexpect:\n'
                 '  - {topic: /mobile_device/imu_sensor_data, rate: {gt: 50}}\n'
                 % os.path.join(HERE, 'rostest', 'scenario_dying_world.launch'))
    # the killer is a launch node, not an app: the lockstep does not wait for it, and at
    # real_time_factor 0 the world steps on while it calls rosnode kill (under stress-ng
    # it died at sim time 2.0 s in 1 of 4 loaded runs): any time before the end is the world's death
    rc, out = run(f, '--world-node')
    assert rc == 2, out
    assert re.search(r'ERROR the world died at sim time [012]\.\d+ s', out), out
    assert 'last lines of the world/app log' in out and 'world_killer' in out, out
    # embedded (the default): rosnode kill /sim_world shuts the runner's own node down
    rc, out = run(f)
    assert rc == 2, out
    assert re.search(r'ERROR the world node /sim_world \(embedded in this run\) was shut '
                     r'down at sim time [012]\.\d+ s', out), out
    assert 'world_killer: killing /sim_world' in out, out     # the launch nodes' log tails


ACTIONS = """\
name: every_action
duration: 3.0
world: {args: {camera_rate: 1}}
timeline:
  - {at: 0.5, action: press_button, button: power, duration: 0.2}
  - {at: 0.5, action: touch, x: 100, y: 200, duration: 0.1}
  - {at: 0.5, action: charger, plugged: true}
  - {at: 0.5, action: radio, radio: wifi, enabled: false}
  - {at: 0.5, action: show_image, file: %(png)s}
  - {id: ramp, at: 0.5, action: set_environment, values: {indoor_temperature: 30.0}, ramp: 1.0}
  - {at: 0.5, action: playback, name: humidity, series: [[0, 20], [0.5, 60], [1.0, 80]]}
  - {id: drop, at: 1.0, action: fault, sensor: imu_controller, fault: drop}
  - {at: 2.0, action: fault, sensor: imu_controller, fault: none}
  - {at: 2.5, action: publish, topic: /probe, type: std_msgs/String, msg: {data: hello}}
expect:
  - {name: button, topic: /mobile_device/buttons, field: button, eventually: {equals: power},
     window: [0.5, 0.6]}
  - {name: touch, topic: /mobile_device/touch, count: {min: 1}, window: [0.5, 0.7]}
  - {name: charging, topic: /mobile_device/power_state, field: AC_present,
     eventually: {gt: 0}, window: [0.5, 1.0]}
  - {name: not_charging_before, topic: /mobile_device/power_state, field: AC_present,
     always: {equals: 0}, window: [0.0, 0.45]}
  - {name: wifi_off, topic: /mobile_device/wifi/link, field: enabled,
     eventually: {equals: false}, window: [0.5, 2.0]}
  - {name: warm, topic: /mobile_device/temperature, field: temperature,
     eventually: {near: 30.0, tol: 0.5}, window: [1.5, 3.0]}
  - {name: not_warm_before, topic: /mobile_device/temperature, field: temperature,
     always: {lt: 25.0}, window: [0.0, 0.45]}
  - {name: humid, topic: /mobile_device/humidity, field: relative_humidity,
     eventually: {near: 0.8, tol: 0.05}, window: [1.6, 3.0]}
  - {name: imu_dropped, topic: /mobile_device/imu_sensor_data, count: {equals: 0},
     window: [1.02, 1.98]}
  - {name: imu_back, topic: /mobile_device/imu_sensor_data, rate: {near: 100, tol: 1},
     window: [2.05, 3.0]}
"""


def test_every_action_reaches_the_world(tmp_path):
    f = tmp_path / 'actions.yaml'
    f.write_text(ACTIONS % {'png': os.path.join(ROOT, 'sim_world', 'worlds', 'media',
                                                'qr_paper.png')})
    rc, out = run(f)
    assert rc == 0, out
    # a refused action is an ERROR naming the event and the world's answer
    f.write_text(ACTIONS.replace('sensor: imu_controller, fault: drop',
                                 'sensor: no_such_sensor, fault: drop') % {'png': 'x.png'})
    rc, out = run(f)
    assert rc == 2, out
    assert "ERROR drop (fault): SetSensorFault: model 'mobile_device' has no sensor " \
           "'no_such_sensor'" in out, out


def test_missing_topic_and_field_are_errors_naming_them(tmp_path):
    f = tmp_path / 'typos.yaml'
    f.write_text('duration: 0.5\nworld: {args: {camera_rate: 1}}\nexpect:\n'
                 '  - {name: topic_typo, topic: /mobile_device/imu_sensor_dat, rate: {gt: 1}}\n'
                 '  - {name: field_typo, topic: /mobile_device/imu_sensor_data,\n'
                 '     field: linear_acceleraton.z, always: {gt: 0}}\n'
                 '  - {name: fine, topic: /mobile_device/imu_sensor_data, count: {min: 40}}\n')
    rc, out = run(f)
    assert rc == 2, out
    assert 'ERROR topic_typo: expected Hz of /mobile_device/imu_sensor_dat > 1 in [0.000, ' \
           '0.500] s; actual topic /mobile_device/imu_sensor_dat never appeared (similar ' \
           'topics: ' in out, out
    assert "ERROR field_typo: expected always /mobile_device/imu_sensor_data." \
           "linear_acceleraton.z > 0 in [0.000, 0.500] s; actual field 'linear_acceleraton.z' " \
           "does not exist on sensor_msgs/Imu: Imu has no field 'linear_acceleraton'" in out, out
    assert 'PASS fine:' in out


def test_verdicts_and_recordings_do_not_depend_on_machine_load(tmp_path, auto_rotate_recording):
    """The slice handshake has no wall-clock quiet period to miss: the example with an app
    gives the same verdicts and the same recorded messages at the same times, while two
    CPU hogs (stress-ng --cpu 2) compete for the machine's cores."""
    from fixtures.hogs import cpu_hogs
    sc = os.path.join(EX, 'auto_rotate.yaml')
    rc, out_calm, calm = auto_rotate_recording      # the session's run, no hogs
    assert rc == 0, out_calm
    loaded = tmp_path / 'loaded.bag'
    with cpu_hogs():
        rc, out_loaded = run(sc, '--record', loaded)
    assert rc == 0, out_loaded
    assert verdicts(out_calm) == verdicts(out_loaded)
    a, b = bag_messages(calm), bag_messages(loaded)
    a.pop('/scenario/meta', None)
    b.pop('/scenario/meta', None)
    assert sorted(a) == sorted(b)
    for topic in a:        # the messages and their recorded times (headerless ones too)
        assert a[topic] == b[topic], \
            '%s differs under load (%d vs %d messages)' % (topic, len(a[topic]), len(b[topic]))


@pytest.mark.parametrize('mode', ['--embedded', '--world-node'])
def test_an_apps_answer_reaches_the_world_at_the_slice_boundary(tmp_path, mode):
    """The in-call app turns the display off when the proximity reading of tick 1.1 says
    near. The battery, which draws for the display while it is on, measures at that same
    tick: it must not see the app's answer there (the app answered after the tick; on a
    quiet machine it used to arrive while the world was still in it), only at the next
    measurement (sim_world.transport's gate holds inputs while the world steps)."""
    import rosbag
    bag = tmp_path / 'incall.bag'
    rc, out = run(os.path.join(EX, 'incall_proximity.yaml'), mode, '--record', bag)
    assert rc == 0, out
    with rosbag.Bag(str(bag)) as b:
        power = {round(ts.to_sec(), 3): m.power_consumption for _t, m, ts in
                 b.read_messages(topics=['/mobile_device/power_state'])}
        near = [round(ts.to_sec(), 3) for _t, m, ts in
                b.read_messages(topics=['/mobile_device/proximity']) if m.range < 0.05]
        off = [round(ts.to_sec(), 3) for _t, m, ts in
               b.read_messages(topics=['/mobile_device/display/enable']) if not m.data]
    assert near and off == [near[0]], (near, off)      # answered in the reading's slice
    t = near[0]
    on = power[round(t - 0.1, 3)]
    assert power[t] == pytest.approx(on), power         # the tick of the reading: still on
    assert power[round(t + 0.1, 3)] < on - 0.1, power   # the next measurement: off


def test_a_second_scenario_on_an_attached_world_has_its_windows_from_its_start(tmp_path):
    """An attached world that ran a scenario before is at that one's end (sim time 2): the
    next scenario's expectation windows start where its timeline starts, as the first's
    did (they were absolute: its window [0, 1] saw no message)."""
    from fixtures.rosworld import office_world
    from fixtures.scenario_cli import NODE, scenario_env
    import sys
    sc = os.path.join(HERE, 'data', 'scenario_attach_imu.yaml')
    with office_world(tmp_path, 'paused:=true', 'real_time_factor:=0') as env:
        outs = []
        for _ in range(2):
            p = subprocess.run([sys.executable, NODE, '--attach', sc], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=300,
                               env=scenario_env(ROS_MASTER_URI=env['ROS_MASTER_URI']))
            assert p.returncode == 0, p.stdout
            outs.append(p.stdout)
    assert 'PASS imu_in_first_second' in outs[1], outs[1]
    assert re.search(r'in \[2\.0\d\d, 3\.0\d\d\] s', outs[1]), outs[1]


@pytest.mark.parametrize('mode', ['--embedded', '--world-node'])
def test_the_worlds_answers_to_apps_are_timed_where_the_world_sent_them(tmp_path, mode):
    """The NFC proxy hands an app's nfc/outgoing on at once, while the world is paused at a
    slice's end, after its step answer: the incoming message reaches the runner before any
    step answer lists its time. It is timed at that slice's end, and the next answer's time
    for it is not used again: the second exchange's OK used to take the first one's 1.10 s
    (a stale time left in the queue), and under load the runner's lagging /clock gave the
    first one 1.05 s (bench/load, a warm farm)."""
    import rosbag
    text = open(os.path.join(EX, 'nfc_vcard.yaml')).read()
    text = text.replace('duration: 4.0', 'duration: 4.5').replace(
        'script: nfc_app.py', 'script: %s' % os.path.join(EX, 'nfc_app.py'))
    text = text.replace('expect:\n', '  - {id: again, at: 3.5, action: set_model_state, '
                        'model: mobile_device_b,\n     position: [4.0, -4.0, 1.03], '
                        'rpy: [3.14159265, 0, 0]}\nexpect:\n', 1)
    sc = tmp_path / 'nfc_twice.yaml'
    sc.write_text(text)
    bag = tmp_path / 'nfc.bag'
    rc, out = run(str(sc), mode, '--record', bag)
    assert rc == 0, out
    with rosbag.Bag(str(bag)) as b:
        got = {topic: [(round(ts.to_sec(), 3), m.data) for _t, m, ts in
                       b.read_messages(topics=[topic])]
               for topic in ('/mobile_device/nfc/incoming', '/mobile_device_b/nfc/incoming')}
        connected = [round(ts.to_sec(), 3) for _t, m, ts in b.read_messages(
            topics=['/mobile_device/nfc/notification']) if m.status == 'connected']
    assert connected == [1.1, 3.6], connected            # the NFC ticks after each touch
    assert got['/mobile_device/nfc/incoming'] == [(1.1, 'OK'), (3.6, 'OK')], got
    assert [t for t, _d in got['/mobile_device_b/nfc/incoming']] == [1.1, 3.6], got


NODE_APP = """\
name: node_app
seed: 1
real_time_factor: 0
duration: 2.0
world: {launch: office, args: {camera_rate: 10}}
apps:
  - {name: reader, node: %s,
     params: {image_topic: /mobile_device/image_raw, barcode_topic: /reader/barcode}}
expect:
  - name: node_decodes
    topic: /reader/barcode
    field: data
    eventually: {equals: "QR-Code,http://vmi.lmt.ei.tum.de"}
"""


def test_a_node_app_runs_as_rosrun_would_run_it(tmp_path):
    """``node: pkg/type``: the package's barcode_reader (a Python node, run as a script app
    is) decodes the thesis's QR code from the phone's camera; a node that is not there is
    the run's ERROR with rosrun's words."""
    f = tmp_path / 'node_app.yaml'
    f.write_text(NODE_APP % 'mobile_device_sim/barcode_reader')
    rc, out = run(f)
    assert rc == 0, out
    assert re.search(r'^PASS node_decodes:', out, re.M), out
    f.write_text(NODE_APP % 'mobile_device_sim/no_such_node_x')
    rc, out = run(f)
    assert rc == 2, out
    # (seen by await_ready, or by the run's checks while the world loads: the same words)
    assert re.search(r'^ERROR app /reader exited at start \(exit code \d+\)', out,
                     re.M), out
    assert 'no_such_node_x' in out, out
