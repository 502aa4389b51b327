"""Storage faults under the runner (issue 19 item 2): recording to a full filesystem (a
small tmpfs) and to a folder removed mid-run. The verdicts are still printed, the run exits
2 with an ERROR line naming the recording, nothing prints a traceback, and what was written
stays readable: the bag cut short by the full filesystem is reindexed in place, the bag of
the removed folder is saved whole elsewhere. The unit tests of the writer itself (no ROS)
are at the end."""
import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from fixtures.scenario_cli import scenario_env

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')
sys.path.insert(0, os.path.join(ROOT, 'testing_instance', 'src'))

SMALL_KIB = 2000

SCENARIO = """\
name: storage
duration: %(duration)g
real_time_factor: %(rtf)g
timeout: 240
world: {args: {camera_rate: 1}}
expect:
  - {name: imu_rate, topic: /mobile_device/imu_sensor_data, rate: {near: 100, tol: 10}}
"""


env = scenario_env


@pytest.fixture
def small_fs(tmp_path):
    """A small tmpfs (SMALL_KIB): a few of rosbag's 768 KiB chunks fit."""
    d = tmp_path / 'full'
    d.mkdir()
    p = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=%dk' % SMALL_KIB, 'tmpfs', str(d)],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if p.returncode != 0:
        pytest.skip('cannot mount a tmpfs here (needs root): %s' % p.stdout.strip())
    try:
        yield d
    finally:
        subprocess.run(['umount', '-l', str(d)])


def scenario(tmp_path, duration, rtf=0):
    f = tmp_path / 'storage.yaml'
    f.write_text(SCENARIO % dict(duration=duration, rtf=rtf))
    return f


def no_traceback(out):
    assert 'Traceback' not in out, out
    assert 'bad callback' not in out, out


@pytest.mark.rostest
def test_recording_to_a_full_filesystem(tmp_path, small_fs):
    bag = small_fs / 'run.bag'
    junit = tmp_path / 'junit.xml'
    p = subprocess.run([sys.executable, NODE, str(scenario(tmp_path, 30.0)), '--record',
                        str(bag), '--junit', str(junit)], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=400, env=env())
    out = p.stdout
    no_traceback(out)
    assert p.returncode == 2, out
    assert re.search(r'^PASS imu_rate: ', out, re.M), out           # the verdict stands
    m = re.search(r'^ERROR the recording (\S+) could not be written at sim time (\d+\.\d+) s: '
                  r'No space left on device \(its filesystem is full\); (\d+) messages up to '
                  r'sim time (\d+\.\d+) s stay readable \(reindexed\)$', out, re.M)
    assert m, out
    assert m.group(1) == str(bag)
    fault_t, n, end_t = float(m.group(2)), int(m.group(3)), float(m.group(4))
    assert 0 < fault_t < 30.0 and 0 < end_t <= fault_t, out
    import rosbag
    with rosbag.Bag(str(bag)) as b:                # readable with no reindex of its own
        ts = [t.to_sec() for _tp, _m, t in b.read_messages()]
    assert len(ts) == n > 100 and abs(ts[-1] - end_t) < 1e-3
    assert 'could not be written' in junit.read_text()


@pytest.mark.rostest
def test_recording_to_a_folder_removed_mid_run(tmp_path):
    gone = tmp_path / 'gone'
    bag = gone / 'run.bag'
    salvage = tmp_path / 'salvage'
    e = env()
    e['SCENARIO_SALVAGE_DIR'] = str(salvage)
    p = subprocess.Popen([sys.executable, NODE, str(scenario(tmp_path, 6.0, rtf=1)),
                          '--record', str(bag)], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, env=e)
    deadline = time.monotonic() + 120
    while not bag.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    time.sleep(2.0)                       # some seconds of sim time into the recording
    shutil.rmtree(str(gone))
    out, _ = p.communicate(timeout=300)
    no_traceback(out)
    assert p.returncode == 2, out
    assert re.search(r'^PASS imu_rate: ', out, re.M), out
    m = re.search(r'^ERROR the folder of the recording (\S+) was removed during the run '
                  r'\(noticed at sim time \d+\.\d+ s\); the whole recording \((\d+) messages\) '
                  r'is saved as (\S+)$', out, re.M)
    assert m, out
    assert m.group(1) == str(bag) and not gone.exists()
    assert os.path.dirname(m.group(3)) == str(salvage)
    import rosbag
    with rosbag.Bag(m.group(3)) as b:
        ts = [t.to_sec() for tp, _m, t in b.read_messages()
              if tp == '/mobile_device/imu_sensor_data']
        total = b.get_message_count()
    assert total == int(m.group(2))
    assert ts and ts[-1] > 5.5           # to the end of the run, not to the removal


# -- the writer alone (no ROS master) -------------------------------------------------------

def _msgs(n):
    import rospy
    from std_msgs.msg import String
    for i in range(n):
        yield '/a', String('x' * 200), rospy.Time.from_sec(1.0 + i * 0.01)


def test_writer_on_a_full_filesystem_keeps_what_fit(tmp_path, small_fs):
    from testing_instance.io.mcap_io import GuardedWriter
    w = GuardedWriter([str(small_fs / 'a.bag')])
    for topic, msg, t in _msgs(20000):         # ~4.6 MB into 2 MB: never raises
        w.write(topic, msg, t)
    problems = w.close()
    assert len(problems) == 1 and 'No space left on device' in problems[0], problems
    import rosbag
    with rosbag.Bag(str(small_fs / 'a.bag')) as b:
        n = b.get_message_count()
    assert 1000 < n < 20000 and ('%d messages up to' % n) in problems[0]


def test_writer_both_formats_one_fails(tmp_path, small_fs):
    """--record on two files: the one on the full filesystem fails, the other is whole."""
    from testing_instance.io.mcap_io import GuardedWriter, open_reader
    ok = tmp_path / 'ok.mcap'
    w = GuardedWriter([str(small_fs / 'b.bag'), str(ok)])
    for topic, msg, t in _msgs(20000):
        w.write(topic, msg, t)
    problems = w.close()
    assert len(problems) == 1 and str(small_fs / 'b.bag') in problems[0], problems
    r = open_reader(str(ok))
    assert sum(1 for _ in r.read_messages()) == 20000
    r.close()


def test_writer_that_cannot_create_its_file_says_so(tmp_path):
    from testing_instance.io.mcap_io import GuardedWriter, RecordingError
    (tmp_path / 'file').write_text('not a folder')
    with pytest.raises(RecordingError) as e:
        GuardedWriter([str(tmp_path / 'file' / 'run.bag')])
    assert str(e.value).startswith('cannot create the recording %s' % (tmp_path / 'file'))


def test_writer_in_a_removed_folder_saves_the_whole_recording(tmp_path):
    from testing_instance.io.mcap_io import GuardedWriter
    d = tmp_path / 'gone'
    w = GuardedWriter([str(d / 'c.bag')], salvage_dir=str(tmp_path / 'kept'))
    msgs = list(_msgs(3000))
    for topic, msg, t in msgs[:1000]:
        w.write(topic, msg, t)
    shutil.rmtree(str(d))
    for topic, msg, t in msgs[1000:]:
        w.write(topic, msg, t)
    problems = w.close()
    assert len(problems) == 1 and re.search(
        r'was removed during the run \(noticed at sim time 1\d\.\d+ s\)', problems[0]), problems
    kept = problems[0].rsplit(' ', 1)[1]
    import rosbag
    with rosbag.Bag(kept) as b:
        assert b.get_message_count() == 3000
