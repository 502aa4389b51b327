"""The run's side of the world (worldside.py), without a master: what a dead part of the
world is called in the run's ERROR, the log a run shows, what is stopped at the end."""
import os
import subprocess
import sys
import types

import pytest

from testing_instance import procs
from testing_instance.procs import Proc
from testing_instance.results import RunError
from testing_instance.worldside import WorldSide


def _sc(**kw):
    return types.SimpleNamespace(timeout=30.0, phones=[{'ns': 'mobile_device'}], **kw)


def _dead_pid():
    p = subprocess.Popen([sys.executable, '-c', 'pass'])
    p.wait()
    return p.pid


def _exited_proc(tmp_path, code, text='world: could not load office.world'):
    p = Proc([sys.executable, '-c', 'print(%r); raise SystemExit(%d)' % (text, code)],
             dict(os.environ), str(tmp_path / 'world.log'))
    p.p.wait()
    return p


def test_env_points_at_the_runs_master_and_log_folder_unless_attached(tmp_path):
    ws = WorldSide(_sc(), str(tmp_path), port=11999)
    env = ws.env()
    assert env['ROS_MASTER_URI'] == ws.master_uri() == 'http://localhost:11999'
    assert env['ROS_LOG_DIR'] == str(tmp_path / 'log')
    os.environ['ROS_MASTER_URI'] = 'http://elsewhere:11311'
    try:
        att = WorldSide(_sc(), str(tmp_path), port=11999, attach=True)
        assert att.master_uri() == 'http://elsewhere:11311'
    finally:
        del os.environ['ROS_MASTER_URI']


def test_a_dead_world_node_is_named_with_its_ros_log(tmp_path):
    log = tmp_path / 'log' / 'run'
    log.mkdir(parents=True)
    (log / 'sim_world-2.log').write_text('[rospy.internal] loading\nsegfault in ODE\n')
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    pid = _dead_pid()
    ws.watch['the world node /sim_world'] = pid
    assert ws.any_gone()
    with pytest.raises(RunError) as e:
        ws.check(lambda: 2.5)
    assert str(e.value) == ('the world died at sim time 2.500 s (the world node /sim_world, '
                            'pid %d, is gone)' % pid)
    assert 'segfault in ODE' in e.value.log_lines


def test_a_dead_master_is_the_master_and_a_dead_launch_the_world(tmp_path):
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    ws.watch['the ROS master (rosmaster)'] = _dead_pid()
    with pytest.raises(RunError, match=r'^the ROS master died at sim time 1\.000 s'):
        ws.check(lambda: 1.0)
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    ws.proc = _exited_proc(tmp_path, 3)
    assert ws.gone()
    with pytest.raises(RunError) as e:
        ws.check(lambda: 0.25)
    assert str(e.value) == 'the world died at sim time 0.250 s (exit code 3)'
    assert e.value.log_lines == ['world: could not load office.world']
    emb = WorldSide(_sc(), str(tmp_path), port=1, embedded=True)
    emb.proc = ws.proc
    with pytest.raises(RunError, match=r'^the ROS master \(roscore\) died'):
        emb.check(lambda: 0.0)


def test_an_embedded_world_that_failed_or_was_shut_down_says_so(tmp_path):
    ws = WorldSide(_sc(), str(tmp_path), port=1, embedded=True)
    ws.host = object()
    ws.launch_plan = types.SimpleNamespace(world_name='/lab/sim_world')
    ws.rospy = types.SimpleNamespace(is_shutdown=lambda: False)
    ws.check(lambda: 0.0)                                 # all there: no error
    ws.rospy = types.SimpleNamespace(is_shutdown=lambda: True)
    with pytest.raises(RunError, match=r'the world node /lab/sim_world \(embedded in this '
                                       r'run\) was shut down at sim time 4\.000 s'):
        ws.check(lambda: 4.0)
    ws.failed.append(ZeroDivisionError('division by zero'))
    with pytest.raises(RunError, match=r'the embedded world stopped at sim time 4\.000 s: '
                                       r'ZeroDivisionError: division by zero'):
        ws.check(lambda: 4.0)


def test_the_log_tail_is_the_worlds_own_log(tmp_path):
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    assert ws.log_tail() == []
    ws.proc = _exited_proc(tmp_path, 1, 'the last line')
    assert ws.log_tail() == ['the last line']
    warm = WorldSide(_sc(), str(tmp_path), warm=types.SimpleNamespace(
        log_tail=lambda: ['warm world line']))
    assert warm.log_tail() == ['warm world line']


def test_stop_leaves_a_warm_world_and_hands_it_the_apps(tmp_path):
    left, saved = [], []
    warm = types.SimpleNamespace(leave=left.extend, save_log=saved.append)
    ws = WorldSide(_sc(), str(tmp_path), warm=warm)
    app = Proc([sys.executable, '-c', 'pass'], dict(os.environ), str(tmp_path / 'a.log'))
    ws.stop([('/app0', app)])
    assert left == [('/app0', app)] and saved == [str(tmp_path / 'world.log')]
    app.p.wait()


def test_stop_ends_a_launched_worlds_apps_and_launch(tmp_path):
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    ws.proc = Proc([sys.executable, '-c', 'import time; time.sleep(60)'], dict(os.environ),
                   str(tmp_path / 'world.log'))
    app = Proc([sys.executable, '-c', 'import time; time.sleep(60)'], dict(os.environ),
               str(tmp_path / 'a.log'))
    ws.stop([('/app0', app)])
    assert not app.alive() and not ws.proc.alive()
    assert not procs.alive(app.p.pid)


def test_the_master_and_the_world_node_are_found_below_roslaunch(tmp_path):
    """find_watched: the rosmaster and the sim_world node below the world's process, by
    their command lines (roslaunch keeps running when either dies: they are watched)."""
    (tmp_path / 'rosmaster').write_text('import time\ntime.sleep(60)\n')
    launcher = tmp_path / 'launch.py'
    launcher.write_text(
        'import subprocess, sys, time\n'
        'a = subprocess.Popen([sys.executable, %r, "--core"])\n'
        'b = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", '
        '"__name:=sim_world"])\n'
        'print(a.pid, b.pid, flush=True)\n'
        'time.sleep(60)\n' % str(tmp_path / 'rosmaster'))
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    ws.proc = Proc([sys.executable, str(launcher)], dict(os.environ), str(tmp_path / 'l.log'))
    try:
        import time
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and not open(str(tmp_path / 'l.log')).read():
            time.sleep(0.02)
        master, node = (int(x) for x in open(str(tmp_path / 'l.log')).read().split())
        ws.find_watched()
        assert ws.watch == {procs.MASTER: master, procs.WORLD_NODE: node}
        ws.check(lambda: 0.0)                     # all alive
        os.kill(node, 9)
        deadline = time.monotonic() + 10
        while procs.alive(node) and time.monotonic() < deadline:
            time.sleep(0.02)
        with pytest.raises(RunError, match='the world died at sim time 0.500 s '
                                           r'\(the world node /sim_world, pid %d' % node):
            ws.check(lambda: 0.5)
    finally:
        procs.kill_tree(ws.proc)


def test_the_sim_time_waits_for_rosout_to_start_which_then_needs_no_clock(monkeypatch):
    """An embedded run's roscore starts rosout; /use_sim_time is set once rosout publishes
    /rosout_agg (a roscpp node reads it once, at its start, and only with it subscribes to
    /clock). A master that answers nothing yet, then rosout's other topics only, is asked
    again; a rosout that never comes costs at most the deadline."""
    import time
    answers = [OSError('connection refused'),
               ([['/rosout', ['/app']]], [], []),
               ([['/rosout', ['/app']], ['/rosout_agg', ['/rosout']]], [], [])]
    asked = []

    class Master(object):
        def getSystemState(self):
            asked.append(time.monotonic())
            a = answers[min(len(asked), len(answers)) - 1]
            if isinstance(a, Exception):
                raise a
            return a
    WorldSide.rosout_started(Master(), time.monotonic() + 5.0)
    assert len(asked) == 3
    answers[:] = [([['/rosout', ['/app']]], [], [])]          # never
    del asked[:]
    t0 = time.monotonic()
    WorldSide.rosout_started(Master(), t0 + 0.2)
    assert 0.19 <= time.monotonic() - t0 < 1.0 and len(asked) > 3
