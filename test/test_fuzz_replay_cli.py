"""Damaged recordings through the real `run_scenario --replay` CLI (issue 19 item 3; the
unit-level fuzzer is test/unit/test_fuzz_recordings.py): a file that is no recording, or
bit-flipped beyond use, is one ERROR line naming it, exit 2, no traceback, before a master
starts; an MCAP file cut short is replayed up to the cut with one WARNING line, and the
expectations are judged on what was read."""
import os
import re
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
sys.path.insert(0, os.path.join(HERE, 'unit'))

pytestmark = pytest.mark.rostest

SCENARIO = """\
name: replay_damaged
duration: 1.0
expect:
  - {name: upright, topic: /mobile_device/imu_sensor_data, field: linear_acceleration.z,
     eventually: {near: 9.81, tol: 0.1}}
  - {name: some_imu, topic: /mobile_device/imu_sensor_data, count: {ge: 5}}
"""


def run(*args, timeout=180):
    env = dict(os.environ)
    env.pop('ROS_MASTER_URI', None)
    env['ROS_HOSTNAME'] = 'localhost'
    p = subprocess.run([sys.executable, NODE] + [str(a) for a in args], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=timeout, env=env)
    return p.returncode, p.stdout


@pytest.fixture(scope='module')
def files(tmp_path_factory):
    from test_fuzz_recordings import write_recording
    d = tmp_path_factory.mktemp('replay')
    (d / 'sc.yaml').write_text(SCENARIO)
    write_recording(str(d / 'whole.mcap'), n=300, chunk=2048)
    write_recording(str(d / 'whole.bag'), n=300)
    return d


def test_no_recording_and_a_ruined_bag_are_one_error_line(files):
    junk = files / 'junk.bag'
    junk.write_bytes(b'#ROSBAG V2.0\n' + bytes(range(256)) * 3)
    ruined = files / 'ruined.bag'
    data = bytearray((files / 'whole.bag').read_bytes())
    for i in range(13, len(data), 97):          # flip a bit every 97 bytes
        data[i] ^= 0x10
    ruined.write_bytes(bytes(data))
    for bad in (junk, ruined, files / 'missing.mcap'):
        rc, out = run(files / 'sc.yaml', '--replay', bad)
        assert rc == 2, out
        errors = [ln for ln in out.splitlines() if ln.startswith('ERROR ')]
        assert len(errors) == 1 and str(bad) in errors[0], out
        assert 'Traceback' not in out, out


def test_an_mcap_cut_short_replays_up_to_the_cut_with_one_warning(files):
    blob = (files / 'whole.mcap').read_bytes()
    cut = files / 'cut.mcap'
    cut.write_bytes(blob[:len(blob) // 3])
    rc, out = run(files / 'sc.yaml', '--replay', cut)
    assert 'Traceback' not in out, out
    warnings = [ln for ln in out.splitlines() if ln.startswith('WARNING ')]
    assert len(warnings) == 1 and str(cut) in warnings[0], out
    m = re.search(r'replaying the (\d+) messages read before the damage', warnings[0])
    assert m and 5 < int(m.group(1)) < 300, warnings
    assert re.search(r'^PASS upright:', out, re.M) and re.search(r'^PASS some_imu:', out,
                                                                 re.M), out
    assert rc == 0, out
