"""Clean shutdown (issue 19 item 5): the end of `tools/demo --exit`, Ctrl-C on roslaunch and
the end of a rostest print no FATAL or ERROR line and need no SIGTERM/SIGKILL escalation.
(Before: every `tools/demo --exit` ended with `[FATAL] sim_world: the world loop stopped:
ROSException: publish() to a closed topic`.)"""
import os
import re
import signal
import subprocess
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BAD = re.compile(r'\[(FATAL|ERROR)\]|escalating to SIG|Traceback')

pytestmark = pytest.mark.rostest


def bad_lines(text):
    return [ln for ln in text.splitlines() if BAD.search(ln)]


def env():
    e = dict(os.environ)
    e.setdefault('ROS_HOSTNAME', 'localhost')
    return e


def test_demo_exit_is_clean():
    p = subprocess.run([os.path.join(ROOT, 'tools', 'demo'), '--exit'], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True, timeout=600, env=env())
    assert p.returncode == 0, p.stdout[-4000:]
    assert bad_lines(p.stdout) == [], p.stdout[-4000:]


def test_ctrl_c_on_roslaunch_is_clean():
    from sim_world.netutil import master_port
    port = master_port()
    e = env()
    e['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    p = subprocess.Popen(['roslaunch', '--port', str(port), 'mobile_device_sim', 'office.launch',
                          'flycam:=false'], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, env=e, start_new_session=True)
    try:
        deadline = time.time() + 120
        up = False
        while time.time() < deadline and p.poll() is None:
            r = subprocess.run(['rosservice', 'list'], capture_output=True, text=True, env=e)
            if '/gazebo/get_model_state' in r.stdout:
                up = True
                break
            time.sleep(0.5)
        assert up, 'the world did not come up'
        time.sleep(2.0)                       # the world steps and publishes
        t0 = time.time()
        os.killpg(p.pid, signal.SIGINT)       # Ctrl-C in the terminal
        out, _ = p.communicate(timeout=60)
        assert time.time() - t0 < 30
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    assert bad_lines(out) == [], out[-4000:]


def test_end_of_a_rostest_is_clean():
    # the office world stepping at real_time_factor 0 while rostest ends it, and a
    # publishtest that ends the test once the IMU and camera publish (test/data: not one of
    # the suite's rostests, test_rostest runs those)
    p = subprocess.run(['rostest', '--text', os.path.join(HERE, 'data', 'clean_end.test')],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=600, env=env())
    assert p.returncode == 0, p.stdout[-4000:]
    assert bad_lines(p.stdout) == [], p.stdout[-4000:]
