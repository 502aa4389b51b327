"""Process faults under the runner (issue 19 item 1): the world SIGKILLed mid-scenario, an
app that crashes, an app that hangs (stops reading), the ROS master killed, an app that
floods a recorded topic at 10x its rate. Each run ends within a bound as ERROR naming the
process with its log tail (FAIL where an expectation decides: the flood), the JUnit file
(and the report) are written, the recording is closed and readable up to the fault, and no
process of the run is left behind. The app doing the fault (test/fixtures/fault_app.py)
writes the wall time of the fault; each test prints how long the fault took to become a
verdict ("fault to verdict")."""
import os
import re
import subprocess
import sys
import time
import uuid
import xml.etree.ElementTree as ET

import pytest

from testing_instance.world import procs

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
APP = os.path.join(HERE, 'fixtures', 'fault_app.py')
BOUND = 60.0             # wall s from the fault to the runner's exit
# what the runner waits out on purpose here, set small (10 s each by default): an app that
# leaves its connections unread is hung after HANG s; a process gets GRACE s to end on its
# SIGINT before SIGKILL
HANG, GRACE = 3, 3
SHORT = {'MDS_APP_HANG_AFTER': str(HANG), 'MDS_STOP_GRACE': str(GRACE)}

pytestmark = pytest.mark.rostest

SCENARIO = """\
name: fault_%(mode)s
duration: %(duration)g
timeout: 240
world: {args: {camera_rate: 1}}
apps:
  - {name: fault_app, script: %(app)s, params: {mode: %(mode)s, at: %(at)g, mark: %(mark)s}}
expect:
  - {name: imu_rate, topic: /mobile_device/imu_sensor_data, rate: {near: 100, tol: 10}}
"""


def left_behind(marker):
    """Processes still carrying the run's marker in their environment."""
    return procs.carrying(marker)


def run_fault(tmp_path, mode, duration=4.0, at=1.0, report=False, extra=(), short=False):
    """short: the hang and SIGINT waits of SHORT."""
    mark = tmp_path / 'fault_time'
    f = tmp_path / ('%s.yaml' % mode)
    f.write_text(SCENARIO % dict(mode=mode, duration=duration, at=at, mark=mark, app=APP))
    marker = 'MDS_FAULT_TEST=%s' % uuid.uuid4().hex
    env = dict(os.environ)
    env.pop('ROS_MASTER_URI', None)
    env.setdefault('ROS_HOSTNAME', 'localhost')
    env['MDS_FAULT_TEST'] = marker.split('=')[1]
    if short:
        env.update(SHORT)
    bag, junit = tmp_path / 'run.bag', tmp_path / 'junit.xml'
    args = [sys.executable, NODE, str(f), '--record', str(bag), '--junit', str(junit)]
    if report:
        args += ['--report', str(tmp_path / 'report')]
    args += list(extra)
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=400, env=env)
    t_end = time.time()
    out = p.stdout
    assert mark.exists(), 'the fault never happened:\n' + out
    latency = t_end - float(mark.read_text())
    print('%s: fault to verdict %.1f s of wall time (exit %d)' % (mode, latency, p.returncode))
    assert latency < BOUND, out
    assert 'Traceback' not in '\n'.join(ln for ln in out.splitlines()
                                        if not ln.startswith('  |')), out
    # the JUnit file is written
    suite = ET.parse(str(junit)).getroot()
    # the recording is closed and readable up to the fault
    import rosbag
    with rosbag.Bag(str(bag)) as b:
        n = sum(1 for _ in b.read_messages())
    assert n > 0, out
    # nothing left behind
    time.sleep(0.5)
    assert left_behind(marker) == [], (left_behind(marker), out)
    return p.returncode, out, suite, bag


def error_line(out):
    return [ln for ln in out.splitlines() if ln.startswith('ERROR ')]


def test_the_world_killed_mid_scenario(tmp_path):
    # the sim_world node as a process of its own (embedded, the world is the runner)
    rc, out, suite, _ = run_fault(tmp_path, 'kill_world', extra=['--world-node'])
    assert rc == 2, out
    assert re.search(r'^ERROR the world died at sim time 1\.\d+ s', out, re.M), out
    assert 'last lines of the world/app log' in out
    # no line per topic about the master the world took down with it
    assert 'registrations are now out of sync' not in out, out
    assert suite.get('errors') != '0'


def test_an_app_that_crashes(tmp_path):
    rc, out, suite, _ = run_fault(tmp_path, 'crash', report=True)
    assert rc == 2, out
    assert re.search(r'^ERROR app /fault_app crashed at sim time 1\.\d+ s \(exit code 1\)',
                     out, re.M), out
    assert 'RuntimeError: fault_app: crashed on purpose' in out     # its log tail
    page = (tmp_path / 'report' / 'index.html').read_text()
    assert 'app /fault_app crashed' in page and 'crashed on purpose' in page
    assert 'run' in [tc.get('name') for tc in suite.iter('testcase')]


def test_an_app_that_hangs(tmp_path):
    rc, out, _suite, _ = run_fault(tmp_path, 'hang', duration=40.0, at=0.5, short=True)
    assert rc == 2, out
    m = re.search(r'^ERROR app /fault_app hangs: it stopped reading its topics \(\d+ bytes '
                  r'wait on its connections, unread for (\d+) s of wall time\)', out, re.M)
    assert m and HANG <= int(m.group(1)) < HANG + 10, out


def test_the_ros_master_killed(tmp_path):
    rc, out, _suite, _ = run_fault(tmp_path, 'kill_master')
    assert rc == 2, out
    assert re.search(r'^ERROR the ROS master (died|stopped answering) at sim time 1\.\d+ s',
                     out, re.M), out


def test_an_app_flooding_a_recorded_topic(tmp_path):
    rc, out, suite, bag = run_fault(tmp_path, 'flood', duration=3.0)
    assert rc == 1, out                                # the rate expectation decides
    assert re.search(r'^FAIL imu_rate: .* actual \d{3}\.\d Hz', out, re.M), out
    import rosbag
    from_app = from_world = 0
    with rosbag.Bag(str(bag)) as b:
        for _t, m, _s in b.read_messages(topics=['/mobile_device/imu_sensor_data']):
            if m.header.frame_id == 'flood':
                from_app += 1
            else:
                from_world += 1
    # every world message of the window is there (100 Hz), and the whole flood: ten for
    # each world message the app received after 1 s (the last slice's may be in flight
    # when the app is last waited for)
    assert from_world >= 300 - 2, (from_world, out)
    assert from_app >= 10 * (from_world - 100) - 20, (from_app, from_world, out)
    assert 'handshake: ' in out and ' 0 dropped by its queues' in out, out


def test_an_app_that_does_not_end_on_its_sigint_is_killed_and_said(tmp_path):
    # the verdicts stand; the GRACE s the run's end waited are explained in one line
    rc, out, _suite, _ = run_fault(tmp_path, 'deaf', short=True)
    assert rc == 0, out
    assert re.search(r'^PASS imu_rate:', out, re.M), out
    assert re.findall(r'^WARNING .*$', out, re.M) == [
        'WARNING app /fault_app did not end within %d s of its SIGINT: SIGKILLed with its '
        'process group' % GRACE], out


def test_a_deaf_app_in_a_warm_farm_is_said_by_the_scenario_that_waited_for_it(tmp_path):
    """In a warm farm the next scenario waits for the last one's apps to leave the graph
    (WarmHost.settle): the GRACE s it waited for a deaf one are its start-up's, explained in
    its output, naming the app and the scenario it belonged to; the farm's last
    scenario's is said after the summary table, as the worker ends."""
    a, b, c = tmp_path / 'deaf.yaml', tmp_path / 'after.yaml', tmp_path / 'last.yaml'
    a.write_text(SCENARIO % dict(mode='deaf', duration=1.0, at=0.5, mark=tmp_path / 'm',
                                 app=APP))
    # the same app deaf in the farm's last scenario: said as the farm ends
    c.write_text(a.read_text().replace('name: fault_deaf', 'name: last_deaf'))
    b.write_text('name: after\nduration: 0.5\nworld: {args: {camera_rate: 1}}\nexpect:\n'
                 '  - {name: imu_rate, topic: /mobile_device/imu_sensor_data, '
                 'rate: {near: 100, tol: 10}}\n')
    marker = uuid.uuid4().hex
    env = dict(os.environ, MDS_FAULT_TEST=marker, **SHORT)
    env.pop('ROS_MASTER_URI', None)
    env.setdefault('ROS_HOSTNAME', 'localhost')
    p = subprocess.run([sys.executable, NODE, '--jobs', '1', str(a), str(b), str(c)],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=300, env=env)
    out = p.stdout
    assert p.returncode == 0, out
    assert re.search(r'^\[deaf.yaml\] PASS imu_rate:', out, re.M), out
    assert re.search(r'^\[after.yaml\] PASS imu_rate:', out, re.M), out
    assert re.search(r'^\[last.yaml\] PASS imu_rate:', out, re.M), out
    assert re.findall(r'^.*WARNING .*$', out, re.M) == [
        '[after.yaml] WARNING app /fault_app of scenario fault_deaf did not end within %d s '
        'of its SIGINT: SIGKILLed with its process group (this start-up waited for it)'
        % GRACE,
        'WARNING app /fault_app of scenario last_deaf did not end within %d s of its SIGINT: '
        'SIGKILLed with its process group (at the farm\'s end)' % GRACE], out
    assert out.rstrip().endswith('(at the farm\'s end)'), out      # after the table
    # the wait is the second scenario's start-up's
    up = float(re.search(r'^\[after.yaml\] start-up: ([\d.]+) s', out, re.M).group(1))
    assert up >= GRACE - 0.5, out
    time.sleep(0.5)
    assert left_behind(marker) == []


def test_a_killed_runner_leaves_no_world_behind(tmp_path):
    """run_scenario itself SIGKILLed (a CI job cancelled, a Ray node removed): its master,
    world and apps go too (found: a removed Ray node's run left its roslaunch running)."""
    import signal
    f = tmp_path / 'long.yaml'
    f.write_text('name: long\nduration: 600\nreal_time_factor: 1\n'
                 'world: {args: {camera_rate: 1}}\napps:\n'
                 '  - {name: fault_app, script: %s, params: {mode: none}}\n' % APP)
    marker = uuid.uuid4().hex
    env = dict(os.environ, MDS_FAULT_TEST=marker)
    env.pop('ROS_MASTER_URI', None)
    env.setdefault('ROS_HOSTNAME', 'localhost')
    p = subprocess.Popen([sys.executable, NODE, str(f)], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, env=env)
    deadline = time.monotonic() + 120
    while len(left_behind(marker)) < 4:              # runner, roslaunch, master, world...
        assert p.poll() is None and time.monotonic() < deadline, p.stdout.read()
        time.sleep(0.5)
    time.sleep(3.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    deadline = time.monotonic() + 30
    while left_behind(marker) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert left_behind(marker) == []
