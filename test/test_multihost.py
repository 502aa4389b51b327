"""Nodes on several hosts (issue 14; thesis chapter 5.2 ran its nodes on several machines).

Two network namespaces joined by a veth pair stand for two hosts, 10.213.7.1 (the world) and
10.213.7.2 (the apps). Host A runs the master, sim_world with the office world and the phone
(office.launch); host B runs the barcode reader, the C subscriber tinyros_echo and rospy
subscribers, all with ROS_IP set to their own address and ROS_MASTER_URI pointing at host A.
The test checks that the QR code is decoded across the hosts, that the phone camera arrives
at its rate in sim time (from the stamps), and that a sensor topic (the IMU) arrives.

It skips, saying why, where namespaces cannot be made (no `ip` tool, not root).
"""
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TAG = '%d' % (os.getpid() % 100000)
NS_A, NS_B = 'mds_a%s' % TAG, 'mds_b%s' % TAG
VA, VB = 'mdsa%s' % TAG, 'mdsb%s' % TAG
IP_A, IP_B = '10.213.7.1', '10.213.7.2'
MASTER = 'http://%s:11311' % IP_A

RATE_SCRIPT = r'''
import sys, rospy
from sensor_msgs.msg import Image
stamps = []
def cb(m):
    stamps.append(m.header.stamp.to_sec())
rospy.init_node('camera_rate', disable_signals=True)
rospy.Subscriber('/mobile_device/image_raw', Image, cb, queue_size=100, buff_size=2**26)
import time
end = time.time() + 90
while len(stamps) < 40 and time.time() < end:
    time.sleep(0.1)
print(' '.join('%.6f' % s for s in stamps))
'''


def _ip(*args, check=True):
    return subprocess.run(['ip'] + list(args), capture_output=True, text=True, check=check)


def _can_make_namespaces():
    if shutil.which('ip') is None:
        return 'the ip tool (iproute2) is not installed'
    if os.geteuid() != 0:
        return 'network namespaces need root (ip netns add)'
    r = _ip('netns', 'add', NS_A + 'probe', check=False)
    if r.returncode != 0:
        return 'ip netns add failed: %s' % r.stderr.strip()
    _ip('netns', 'del', NS_A + 'probe', check=False)
    return None


@pytest.fixture(scope='module')
def hosts():
    why = _can_make_namespaces()
    if why:
        pytest.skip('multi-host test not run: ' + why)
    try:
        _ip('netns', 'add', NS_A)
        _ip('netns', 'add', NS_B)
        _ip('link', 'add', VA, 'type', 'veth', 'peer', 'name', VB)
        _ip('link', 'set', VA, 'netns', NS_A)
        _ip('link', 'set', VB, 'netns', NS_B)
        for ns, dev, ip in ((NS_A, VA, IP_A), (NS_B, VB, IP_B)):
            _ip('-n', ns, 'addr', 'add', ip + '/24', 'dev', dev)
            _ip('-n', ns, 'link', 'set', dev, 'up')
            _ip('-n', ns, 'link', 'set', 'lo', 'up')
        yield
    finally:
        for ns in (NS_A, NS_B):
            _ip('netns', 'del', ns, check=False)


def _env(own_ip):
    env = dict(os.environ)
    env.pop('ROS_HOSTNAME', None)          # ROS_HOSTNAME would win over ROS_IP
    env['ROS_IP'] = own_ip
    env['ROS_MASTER_URI'] = MASTER
    return env


def _start(ns, own_ip, cmd, **kw):
    return subprocess.Popen(['ip', 'netns', 'exec', ns] + cmd, env=_env(own_ip),
                            start_new_session=True, **kw)


def _run(ns, own_ip, cmd, timeout):
    return subprocess.run(['ip', 'netns', 'exec', ns] + cmd, env=_env(own_ip),
                          capture_output=True, text=True, timeout=timeout)


def _stop(p):
    try:
        os.killpg(p.pid, signal.SIGINT)
        p.wait(20)
    except ProcessLookupError:
        pass
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(5)


@pytest.mark.slow
def test_world_on_one_host_apps_on_the_other(hosts, tmp_path):
    log = open(tmp_path / 'host_a.log', 'w')
    world = _start(NS_A, IP_A, ['roslaunch', '-p', '11311', 'mobile_device_sim', 'office.launch',
                                'flycam:=false', 'seed:=1'], stdout=log, stderr=subprocess.STDOUT)
    procs = [world]
    try:
        # host B sees the phone's topics through the master on host A
        end = time.time() + 120
        while True:
            r = _run(NS_B, IP_B, ['rostopic', 'list'], 30)
            if '/mobile_device/image_raw' in r.stdout.split() and \
                    '/mobile_device/imu_sensor_data' in r.stdout.split():
                break
            assert world.poll() is None, open(tmp_path / 'host_a.log').read()[-3000:]
            assert time.time() < end, 'host B never saw the phone topics: %s %s' % (
                r.stdout, r.stderr)
            time.sleep(1)
        reader = _start(NS_B, IP_B, ['rosrun', 'mobile_device_sim', 'barcode_reader',
                                     'image:=/mobile_device/image_raw'],
                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(reader)
        # the QR code, decoded on host B from the camera of host A
        r = _run(NS_B, IP_B, ['rostopic', 'echo', '-n', '1', '/barcode'], 120)
        assert 'QR-Code,http://vmi.lmt.ei.tum.de' in r.stdout, r.stdout + r.stderr
        # the C subscriber (tinyros_echo) on host B gets frames from host A
        r = _run(NS_B, IP_B, ['rosrun', 'mobile_device_sim', 'tinyros_echo',
                              '/mobile_device/image_raw', '-v', '-q', '-n', '5', '-t', '60'], 90)
        assert r.returncode == 0, r.stdout + r.stderr
        frames = [l for l in r.stdout.splitlines() if '480' in l and '800' in l]
        assert len(frames) >= 5, r.stdout
        # the camera's rate in sim time, from the stamps that arrive on host B
        r = _run(NS_B, IP_B, [sys.executable, '-c', RATE_SCRIPT], 120)
        stamps = [float(s) for s in r.stdout.split()]
        assert len(stamps) >= 40, r.stdout + r.stderr
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        assert sorted(gaps)[len(gaps) // 2] == pytest.approx(1 / 30.0, abs=0.002)
        # a sensor topic arrives on host B
        r = _run(NS_B, IP_B, ['rostopic', 'echo', '-n', '1',
                              '/mobile_device/imu_sensor_data/linear_acceleration/z'], 60)
        assert abs(float(r.stdout.split()[0]) - 9.81) < 0.3, r.stdout + r.stderr
    finally:
        for p in reversed(procs):
            _stop(p)
        log.close()
