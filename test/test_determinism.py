"""Same seed, same data, through ROS (issue 9): sim_world with the office and the phone is
started twice with one seed, paused, and the phone's IMU is recorded with `rostopic echo -p`
from the first step on; once at real_time_factor 0 with nothing else subscribed, once at
real_time_factor 1 while the phone camera is subscribed too. Every message with the same
stamp must be byte-identical (field by field as rostopic prints it); a different seed must
differ. Each run has its own master port."""
import csv
import io
import os
import signal
import subprocess
import time
import xmlrpc.client

import pytest
from sim_world.netutil import master_port  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IMU = '/mobile_device/imu_sensor_data'


def _env(port):
    env = dict(os.environ)
    env['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    env['ROS_HOSTNAME'] = 'localhost'
    return env


def _wait(cond, timeout, what):
    end = time.time() + timeout
    while time.time() < end:
        if cond():
            return
        time.sleep(0.3)
    raise AssertionError('timed out waiting for ' + what)


def _record(seed, rtf, extra_topic=None, sim_seconds=2.0):
    port = master_port()
    env = _env(port)
    launch = subprocess.Popen(
        ['roslaunch', '-p', str(port), 'mobile_device_sim', 'office.launch', 'paused:=true',
         'seed:=%d' % seed, 'real_time_factor:=%g' % rtf, 'flycam:=false'],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    procs = []
    try:
        master = xmlrpc.client.ServerProxy(env['ROS_MASTER_URI'])

        def system_state():
            """{topic: publishers}, {topic: subscribers} from the master (a rostopic
            process per look was a second of Python start-up each)."""
            try:
                pubs, subs, _srvs = master.getSystemState('/determinism_test')[2]
            except OSError:
                return {}, {}
            return dict(pubs), dict(subs)

        def advertised():
            pubs = system_state()[0]
            return IMU in pubs and (extra_topic is None or extra_topic in pubs)
        _wait(advertised, 90, 'the phone to be spawned')
        out = io.StringIO()
        echo = subprocess.Popen(['rostopic', 'echo', '-p', IMU], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                start_new_session=True)
        procs.append(echo)
        if extra_topic:
            procs.append(subprocess.Popen(['rostopic', 'hz', extra_topic], env=env,
                                          stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, start_new_session=True))

        def subscribed():
            return any(n.startswith('/rostopic') for n in system_state()[1].get(IMU, ()))
        _wait(subscribed, 30, 'rostopic echo to subscribe')
        time.sleep(1.0)
        subprocess.run(['rosservice', 'call', '/gazebo/unpause_physics'], env=env, check=True,
                       capture_output=True, timeout=30)
        # 100 Hz IMU: 2 s of sim time = 200 messages (the watchdog is wall time, generous)
        lines = []
        end = time.time() + 120
        while time.time() < end:
            line = echo.stdout.readline()
            if not line:
                break
            lines.append(line)
            if len(lines) > sim_seconds * 100 + 1:
                break
        out.write(''.join(lines))
        return out.getvalue()
    finally:
        for p in procs + [launch]:
            try:
                os.killpg(p.pid, signal.SIGINT)
            except ProcessLookupError:
                pass
        for p in procs + [launch]:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)


def _by_stamp(text):
    rows = list(csv.reader(io.StringIO(text)))
    head = rows[0]
    keep = [i for i, h in enumerate(head) if h not in ('%time', 'field.header.seq')]
    stamp = head.index('field.header.stamp')
    return {r[stamp]: tuple(r[i] for i in keep) for r in rows[1:] if len(r) == len(head)}


@pytest.mark.slow
def test_same_seed_same_imu_messages_at_any_rate_and_subscriptions():
    a = _by_stamp(_record(42, 0.0))
    b = _by_stamp(_record(42, 1.0, extra_topic='/mobile_device/image_raw'))
    c = _by_stamp(_record(43, 0.0))
    common = sorted(set(a) & set(b), key=int)
    assert len(common) >= 100, (len(a), len(b), len(common))
    assert int(common[0]) <= 20000000            # from the first 20 ms of sim time on
    diff = [s for s in common if a[s] != b[s]]
    assert not diff, 'messages differ at stamps %s:\n%s\n%s' % (diff[:3], a[diff[0]],
                                                                  b[diff[0]])
    other = sorted(set(a) & set(c), key=int)
    assert len(other) >= 100
    assert sum(a[s] != c[s] for s in other) > 0.9 * len(other)
