"""Recordings as MCAP and scenario reports (issue 20), with a real roscore, world and app.

One live run of the failing compass example records a rosbag and an MCAP file at once
(and writes its report); every message of the MCAP file equals the rosbag's; replaying the
MCAP file gives the same verdicts.
"""
import os
import re
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EX = os.path.join(ROOT, 'testing_instance', 'examples')
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')

pytestmark = pytest.mark.rostest


def run(*args, timeout=600):
    env = dict(os.environ)
    env.pop('ROS_MASTER_URI', None)
    env.setdefault('ROS_HOSTNAME', 'localhost')
    p = subprocess.run([sys.executable, NODE] + [str(a) for a in args], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=timeout, env=env)
    return p.returncode, p.stdout


def verdicts(text):
    return {m.group(2): m.group(1) for m in re.finditer(r'^(PASS|FAIL|ERROR) (\w+):', text,
                                                        re.M)}


@pytest.fixture(scope='module')
def compass(tmp_path_factory):
    d = tmp_path_factory.mktemp('compass')
    rc, out = run(os.path.join(EX, 'compass_fails.yaml'), '--record', d / 'run.bag',
                  '--record', d / 'run.mcap')
    return dict(dir=d, rc=rc, out=out)


def test_mcap_and_rosbag_of_one_run_hold_the_same_messages(compass):
    assert compass['rc'] == 1, compass['out']
    from testing_instance.mcap_io import open_reader
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
    assert sorted(bag) == sorted(mc)
    for topic in bag:
        assert sorted(bag[topic]) == sorted(mc[topic]), topic
    assert sum(len(v) for v in mc.values()) > 300


def test_replay_of_the_mcap_gives_the_same_verdicts(compass):
    rc, out = run(os.path.join(EX, 'compass_fails.yaml'), '--replay',
                  compass['dir'] / 'run.mcap')
    assert rc == 1, out
    live = verdicts(compass['out'])
    assert live == {'top_along_world_x': 'PASS', 'turned_left_by_90': 'FAIL',
                    'magnetometer_rate': 'PASS'}
    assert verdicts(out) == live, out


def test_replay_of_a_file_that_is_no_recording_is_one_error_line(tmp_path):
    junk = tmp_path / 'junk.mcap'
    junk.write_text('not a recording\n')
    rc, out = run(os.path.join(EX, 'compass_fails.yaml'), '--replay', junk, timeout=120)
    assert rc == 2, out
    assert re.search(r'^ERROR .*junk.mcap is not a recording \(neither a rosbag nor an MCAP '
                     r'file', out, re.M), out
    assert 'Traceback' not in out
