"""The run's side of the world (worldside.py), without a master: what a dead part of the
world is called in the run's ERROR, the log a run shows, what is stopped at the end."""
import os
import re
import subprocess
import sys
import time
import types

import pytest

from testing_instance.world import procs
from testing_instance.world.procs import Proc
from testing_instance.scenario.results import RunError
from testing_instance.world.worldside import WorldSide


def _sc(**kw):
    return types.SimpleNamespace(timeout=30.0, phones=[{'ns': 'mobile_device'}], **kw)


def _core(master, port=1):
    """A procs.Core on ``port`` around ``master`` (a Proc), without starting anything."""
    core = procs.Core.__new__(procs.Core)
    core.master, core.rosout, core.port, core.taken = master, None, port, None
    return core


def _dead_pid():
    p = subprocess.Popen([sys.executable, '-c', 'pass'])
    p.wait()
    return p.pid


def _exited_proc(tmp_path, code, text='world: could not load office.world', log='world.log'):
    p = Proc([sys.executable, '-c', 'print(%r); raise SystemExit(%d)' % (text, code)],
             dict(os.environ), str(tmp_path / log))
    p.p.wait()
    return p


def test_env_points_at_the_runs_master_and_log_folder_unless_attached(tmp_path, monkeypatch):
    ws = WorldSide(_sc(), str(tmp_path), port=11999)
    env = ws.env()
    assert env['ROS_MASTER_URI'] == ws.master_uri() == 'http://localhost:11999'
    assert env['ROS_LOG_DIR'] == str(tmp_path / 'log')
    # monkeypatch gives the process its own value back (this test once deleted it, and the
    # tests that ran after it in the same process lost ROS_MASTER_URI: bench/flaky)
    monkeypatch.setenv('ROS_MASTER_URI', 'http://elsewhere:11311')
    att = WorldSide(_sc(), str(tmp_path), port=11999, attach=True)
    assert att.master_uri() == 'http://elsewhere:11311'


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
    emb.core = _core(_exited_proc(tmp_path, 1, 'Address already in use', log='rosmaster.log'))
    with pytest.raises(RunError) as e:
        emb.check(lambda: 0.0)
    assert str(e.value) == 'the ROS master died at sim time 0.000 s (exit code 1)'
    assert e.value.log_lines[0] == 'Address already in use'


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
    warm = types.SimpleNamespace(leave=lambda apps, scenario: left.append((apps, scenario)),
                                 save_log=saved.append)
    ws = WorldSide(_sc(name='first'), str(tmp_path), warm=warm)
    app = Proc([sys.executable, '-c', 'pass'], dict(os.environ), str(tmp_path / 'a.log'))
    ws.stop([('/app0', app)])
    # with the scenario's name: the next one names it if it has to SIGKILL an app of it
    assert left == [([('/app0', app)], 'first')] and saved == [str(tmp_path / 'world.log')]
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


def test_stop_names_a_launch_node_it_had_to_sigkill_by_its_ros_name(tmp_path, monkeypatch):
    """An embedded run's launch node deaf to its SIGINT is SIGKILLed and said by its ROS
    name (embed.LaunchPlan.start_nodes gives it), not by its executable's."""
    import functools
    monkeypatch.setattr(procs, 'stop_run', functools.partial(procs.stop_run, grace=1.0))
    ws = WorldSide(_sc(), str(tmp_path), embedded=True)
    deaf = ('import signal, sys, time; signal.signal(signal.SIGINT, signal.SIG_IGN); '
            'print("up", flush=True); time.sleep(60)')
    fine = 'import signal, time; signal.signal(signal.SIGINT, signal.default_int_handler); ' \
           'print("up", flush=True); time.sleep(60)'
    node = Proc([sys.executable, '-c', deaf], dict(os.environ), str(tmp_path / 'n.log'))
    node.node_name = '/lab/stubborn'
    plain = Proc([sys.executable, '-c', deaf], dict(os.environ), str(tmp_path / 'p.log'))
    app = Proc([sys.executable, '-c', fine], dict(os.environ), str(tmp_path / 'a.log'))
    for p in (node, plain, app):
        deadline = time.monotonic() + 10
        while 'up' not in (tmp_path / os.path.basename(p.log_path)).read_text() and \
                time.monotonic() < deadline:
            time.sleep(0.02)
    ws.launch_procs = [node, plain]
    said = ws.stop([('/app0', app)])
    # without a ROS name (a Proc made elsewhere): its executable's
    assert said == ['the launch node /lab/stubborn',
                    'the launch node %s' % os.path.basename(sys.executable)]
    assert not node.alive() and not plain.alive() and not app.alive()


def test_the_master_and_the_world_node_below_roslaunch_are_watched(tmp_path):
    """find_watched: the run's own master (procs.Core), and the sim_world node below the
    world's roslaunch, found by its command line among roslaunch's other children
    (roslaunch keeps running when either dies: they are watched)."""
    launcher = tmp_path / 'launch.py'
    launcher.write_text(
        'import subprocess, sys, time\n'
        'a = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", '
        '"__name:=spawner"])\n'
        'b = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)", '
        '"__name:=sim_world"])\n'
        'print(a.pid, b.pid, flush=True)\n'
        'time.sleep(60)\n')
    ws = WorldSide(_sc(), str(tmp_path), port=1)
    ws.core = _core(Proc([sys.executable, '-c', 'import time; time.sleep(60)'],
                         dict(os.environ), str(tmp_path / 'm.log')))
    master = ws.core.master.p.pid
    ws.proc = Proc([sys.executable, str(launcher)], dict(os.environ), str(tmp_path / 'l.log'))
    try:
        import time
        deadline = time.monotonic() + 20
        # the line is whole once it ends in a newline (print may write it in pieces,
        # e.g. under PYTHONUNBUFFERED)
        while time.monotonic() < deadline and \
                not open(str(tmp_path / 'l.log')).read().endswith('\n'):
            time.sleep(0.02)
        _spawner, node = (int(x) for x in open(str(tmp_path / 'l.log')).read().split())
        ws.watch.update(ws.core.pids())          # start_master's
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
        ws.core.kill()


class _Master(object):
    """rosgraph.Master's calls a run makes while its master starts, recorded."""
    def __init__(self, pids=()):
        self.pids = list(pids)
        self.calls = []

    def getPid(self):
        self.calls.append(('getPid',))
        p = self.pids.pop(0) if len(self.pids) > 1 else self.pids[0]
        if isinstance(p, Exception):
            raise p
        return p

    def setParam(self, name, value):
        self.calls.append(('setParam', name, value))


def test_the_runs_master_is_the_one_it_started_not_one_on_the_same_port(tmp_path, monkeypatch):
    """wait_master asks the master for its pid until its own answers. Another pid on the
    port, or the rosmaster's own "Unable to start XML-RPC server" line, means the port is
    taken: a rosmaster that cannot bind does not exit (it waits for its server for ever),
    so the run says so at once instead of waiting for its deadline. A rosmaster that
    exits is named with its code and output."""
    import time
    import rosgraph
    ws = WorldSide(_sc(), str(tmp_path), port=1)

    def sleeper(log):
        return _core(Proc([sys.executable, '-c', 'import time; time.sleep(60)'],
                          dict(os.environ), str(tmp_path / log)))
    ws.core = sleeper('m.log')
    own = ws.core.master.p.pid
    fake = _Master([OSError('connection refused'), OSError('connection refused'), own])
    monkeypatch.setattr(rosgraph, 'Master', lambda *a, **kw: fake)
    try:
        assert ws.wait_master(time.monotonic() + 10.0) is fake
        assert len(fake.calls) == 3
    finally:
        ws.core.kill()
    def error(log, within, said=''):
        """The RunError of wait_master on a fresh stand-in master that printed ``said``."""
        ws.core = sleeper(log)
        with open(ws.core.master.log_path, 'w') as f:
            f.write(said)
        try:
            with pytest.raises(RunError) as e:
                ws.wait_master(time.monotonic() + within)
        finally:
            ws.core.kill()
        return str(e.value)
    # another job's master answers on the port
    fake.pids, fake.calls = [OSError('connection refused'), 1], []   # init's pid
    t0 = time.monotonic()
    assert error('m2.log', 30.0) == ('the ROS master could not take port 1: another master '
                                     '(pid 1) answers there')
    assert time.monotonic() - t0 < 10.0 and len(fake.calls) == 2
    # nothing answers, and the rosmaster printed that it cannot bind (any other listener)
    fake.pids = [OSError('connection refused')]
    assert error('m3.log', 30.0, 'ERROR: Unable to start XML-RPC server, port 1 is already '
                 'in use\n') == ('the ROS master could not take port 1: Unable to start '
                                 'XML-RPC server, port 1 is already in use')
    # nothing answers, nothing said: the time waited (not the scenario's timeout)
    said = error('m4.log', 0.5)
    assert re.fullmatch(r'the ROS master did not answer on port 1 in 0\.[5-9] s', said), said
    ws.core = _core(_exited_proc(tmp_path, 1, 'port in use', log='rosmaster.log'))
    fake.pids = [own + 1]
    with pytest.raises(RunError) as e:
        ws.wait_master(time.monotonic() + 10.0)
    assert str(e.value) == 'the ROS master exited while starting (code 1)'
    assert e.value.log_lines == ['port in use']


def test_the_core_sets_sim_time_and_starts_rosout_without_it(tmp_path, monkeypatch):
    """Core.up: /use_sim_time and roscore's own parameters are set, then rosout starts
    with /use_sim_time remapped away (a roscpp node that reads it true subscribes to
    /clock, which the world would then send it every tick)."""
    started = []

    class FakeProc(object):
        def __init__(self, cmd, env, log_path):
            started.append((cmd, list(fake.calls)))
    monkeypatch.setattr(procs, 'Proc', FakeProc)
    fake = _Master()
    core = procs.Core(11999, {}, str(tmp_path))
    assert started[0][0] == ['rosmaster', '--core', '-p', '11999', '-w', '3']
    core.up(fake)
    cmd, params_then = started[1]
    assert os.path.basename(cmd[0]) == 'rosout'
    assert cmd[1:] == ['__name:=rosout', '/use_sim_time:=/rosout/no_sim_time']
    names = [c[1] for c in params_then]
    assert names[0] == '/use_sim_time' and params_then[0][2] is True
    assert set(names) == {'/use_sim_time', '/run_id', '/rosdistro', '/rosversion'}


class _FakeMaster(object):
    """A ROS master's XML-RPC API as far as an attached run asks it (getPid, lookupService);
    /gazebo/step_world is listed from ``world_at`` (monotonic s) on."""

    def __init__(self, world_at=None):
        import threading
        import time
        from xmlrpc.server import SimpleXMLRPCServer
        self.world_at, self.looks = world_at, 0
        self.server = SimpleXMLRPCServer(('localhost', 0), logRequests=False, allow_none=True)
        self.server.register_function(lambda caller: [1, 'pid', os.getpid()], 'getPid')

        def lookup(caller, name):
            self.looks += 1
            if self.world_at is not None and time.monotonic() >= self.world_at \
                    and name == '/gazebo/step_world':
                return [1, 'uri', 'rosrpc://localhost:1']
            return [-1, 'no provider', '']
        self.server.register_function(lookup, 'lookupService')
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()
        self.uri = 'http://localhost:%d' % self.server.server_address[1]

    def stop(self):
        self.server.shutdown()
        self.server.server_close()


def _attached(tmp_path, uri, monkeypatch):
    monkeypatch.setenv('ROS_MASTER_URI', uri)
    return WorldSide(_sc(), str(tmp_path), attach=True)


def test_attached_without_a_master_is_one_error_naming_the_uri(tmp_path, monkeypatch):
    import time
    uri = 'http://localhost:%d' % procs.free_port()
    ws = _attached(tmp_path, uri, monkeypatch)
    t0 = time.monotonic()
    with pytest.raises(RunError) as e:
        ws._find_attached(time.monotonic() + 30, master_grace=0.5)
    assert str(e.value).startswith('--attach: no ROS master answers at %s (ROS_MASTER_URI) '
                                   'within 0.5 s' % uri)
    assert time.monotonic() - t0 < 10            # rospy alone would retry for ever


def test_attached_waits_for_the_world_before_its_node_is_made(tmp_path, monkeypatch):
    import time
    m = _FakeMaster(world_at=time.monotonic() + 0.4)
    try:
        ws = _attached(tmp_path, m.uri, monkeypatch)
        ws._find_attached(time.monotonic() + 10, master_grace=5)
        assert time.monotonic() >= m.world_at and m.looks >= 2
    finally:
        m.stop()
    m = _FakeMaster(world_at=None)               # a master, but no world ever
    try:
        ws = _attached(tmp_path, m.uri, monkeypatch)
        with pytest.raises(RunError) as e:
            ws._find_attached(time.monotonic() + 1.0, master_grace=0.3)
        assert str(e.value).startswith('--attach: the ROS master at %s lists no '
                                       '/gazebo/step_world within' % m.uri)
        assert str(e.value).endswith('no world to attach to')
    finally:
        m.stop()


def test_attached_without_ros_master_uri_uses_rosgraphs_default(tmp_path, monkeypatch):
    import rosgraph
    monkeypatch.delenv('ROS_MASTER_URI', raising=False)
    ws = WorldSide(_sc(), str(tmp_path), attach=True)
    assert ws.master_uri() == rosgraph.get_master_uri()
    assert ws.master_uri().rstrip('/') == 'http://localhost:11311'
