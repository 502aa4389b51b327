"""The scenario's apps (apps.py), without a master: what is started, an app that finished
told from one that crashed, a missing script, and when the apps count as set up (connected
on both sides, then idle by evidence, with the run's master: real processes stand in for
them)."""
import os
import re
import signal
import subprocess
import sys
import time
import types

import pytest

from testing_instance.world.appwatch import AppWatch
from testing_instance.world.apps import Apps
from testing_instance.scenario.results import RunError


def _scenario(tmp_path, apps):
    return types.SimpleNamespace(apps=apps, dir=str(tmp_path), timeout=30.0,
                                 resolve=lambda p: os.path.join(str(tmp_path), p))


def _script(tmp_path, name, body):
    p = tmp_path / name
    p.write_text('import sys\n' + body + '\n')
    return name


def _wait_exit(apps):
    deadline = time.monotonic() + 30
    while any(p.alive() for _n, p in apps.procs) and time.monotonic() < deadline:
        time.sleep(0.01)


def test_apps_start_with_their_names_params_and_args_and_only_once(tmp_path):
    _script(tmp_path, 'echo.py', 'print(" ".join(sys.argv[1:])); sys.stdout.flush()')
    sc = _scenario(tmp_path, [{'script': 'echo.py', 'name': 'reader', 'args': ['--fast'],
                               'params': {'rate': 5, 'mode': 'qr'}}])
    out = []
    apps = Apps(sc, lambda: dict(os.environ), str(tmp_path), out.append)
    started = apps.launch(lambda q: None)
    assert len(started) == 1 and apps.names() == {'/reader'}
    assert apps.launch(lambda q: None) == []             # a second call starts nothing
    _wait_exit(apps)
    line = open(str(tmp_path / 'reader.log')).read().strip()
    assert line == '--fast _rate:=5 _mode:=qr __name:=reader'
    assert started[0].cmd[0] == sys.executable
    assert apps.watch is not None


def test_an_app_that_exits_0_has_finished_once_and_one_that_fails_is_the_runs_error(tmp_path):
    _script(tmp_path, 'done.py', 'sys.exit(0)')
    _script(tmp_path, 'bad.py', 'print("reading the frame failed"); sys.exit(3)')
    out = []
    apps = Apps(_scenario(tmp_path, [{'script': 'done.py', 'name': 'done'}]),
                lambda: dict(os.environ), str(tmp_path), out.append)
    apps.launch(lambda q: None)
    _wait_exit(apps)
    apps.check(1.5, lambda: 1.5)
    apps.check(2.0, lambda: 2.0)
    assert out == ['app /done finished at sim time 1.500 s (exit code 0)']
    bad = Apps(_scenario(tmp_path, [{'script': 'bad.py', 'name': 'bad'}]),
               lambda: dict(os.environ), str(tmp_path), out.append)
    bad.launch(lambda q: None)
    _wait_exit(bad)
    # before time started (the run's checks while the world loads): as await_ready says it
    with pytest.raises(RunError) as e:
        bad.check(0.0, lambda: 0.0)
    assert str(e.value) == 'app /bad exited at start (exit code 3)'
    assert 'reading the frame failed' in e.value.log_lines
    bad.ready = True                                     # (await_ready done)
    with pytest.raises(RunError) as e:
        bad.check(0.5, lambda: 0.75)
    assert str(e.value) == 'app /bad crashed at sim time 0.750 s (exit code 3)'
    assert 'reading the frame failed' in e.value.log_lines


def test_an_app_killed_by_a_signal_says_which(tmp_path):
    _script(tmp_path, 'sleepy.py', 'import time; time.sleep(60)')
    apps = Apps(_scenario(tmp_path, [{'script': 'sleepy.py'}]), lambda: dict(os.environ),
                str(tmp_path), print)
    (p,) = apps.launch(lambda q: None)
    assert apps.names() == {'/app0'}
    os.kill(p.p.pid, signal.SIGKILL)
    _wait_exit(apps)
    apps.ready = True
    with pytest.raises(RunError, match=r'app /app0 crashed .* \(killed by signal 9\)'):
        apps.check(0.0, lambda: 0.0)


def test_a_missing_script_is_an_error_naming_the_entry_and_starts_no_app(tmp_path):
    _script(tmp_path, 'fine.py', 'import time; time.sleep(60)')
    apps = Apps(_scenario(tmp_path, [{'script': 'fine.py'}, {'script': 'nowhere.py'}]),
                lambda: dict(os.environ), str(tmp_path), print)
    with pytest.raises(RunError, match=r'apps\[1\]\.script: no file .*nowhere\.py'):
        apps.launch(lambda q: None)
    assert apps.procs == [] and apps.watch is None and apps.waited is None


def test_without_apps_nothing_is_started_or_waited_for(tmp_path, monkeypatch):
    import rosgraph

    def no_master(*a, **k):
        raise AssertionError('the master was asked with no app to wait for')
    monkeypatch.setattr(rosgraph, 'Master', no_master)
    apps = Apps(_scenario(tmp_path, []), lambda: dict(os.environ), str(tmp_path), print)
    assert apps.launch(lambda q: None) == [] and apps.names() == set()
    apps.await_ready()            # no master look-ups: they waited for the GIL at start-up
    apps.wait_answered(lambda s: None)                    # returns at once
    apps.check(0.0, lambda: 0.0)


class _Graph(object):
    """A master and the nodes' slave APIs: /reader subscribes the world's /imu (and an
    /other node's /chat); its side of /imu is connected at once, the world's side from
    look ``world_from`` on."""

    def __init__(self, world_from):
        self.looks = 0
        self.world_from = world_from

    def getSystemState(self):
        self.looks += 1
        pubs = [['/imu', ['/sim_world']], ['/chat', ['/other']], ['/reader/out', ['/reader']]]
        subs = [['/imu', ['/reader']], ['/chat', ['/reader']]]
        return pubs, subs, []

    def lookupNode(self, name):
        return name

    def bus_info(self, node):
        if node == '/reader':
            return [[1, '/sim_world', 'i', 'TCPROS', '/imu', True],
                    [2, '/other', 'i', 'TCPROS', '/chat', True]]
        out = [[7, '/scenario_runner', 'o', 'TCPROS', '/imu', True]]
        if self.looks >= self.world_from:
            out.append([8, '/reader', 'o', 'TCPROS', '/imu', True])
        return out


def _await(tmp_path, monkeypatch, graph, world, within=10.0, said=None, procs_=None,
           master_pid=None, limit=2.0):
    import xmlrpc.client

    class Proxy(object):
        def __init__(self, uri):
            self.uri = uri

        def getBusInfo(self, caller):
            if self.uri == '/gone':
                raise OSError('connection refused')
            return 1, '', graph.bus_info(self.uri)
    monkeypatch.setattr(xmlrpc.client, 'ServerProxy', Proxy)
    apps = Apps(_scenario(tmp_path, [{'script': 'x.py', 'name': 'reader'}]),
                lambda: dict(os.environ), str(tmp_path),
                print if said is None else said.append, lambda: world, lambda: master_pid)
    apps.watch = AppWatch(procs_ or [], limit=limit)
    t0 = time.monotonic()
    apps._wait_connections(graph, time.monotonic() + within)
    return time.monotonic() - t0


def test_an_apps_subscription_to_a_world_topic_is_waited_for_on_the_worlds_side(
        tmp_path, monkeypatch):
    graph = _Graph(world_from=6)
    assert _await(tmp_path, monkeypatch, graph, '/sim_world') < 5.0
    # waited for the world's side: there at look 6; set up at look 7, the topics unchanged
    # and the app idle in between
    assert graph.looks == 7
    # without that wait it went on at the second look (the app's side, topics unchanged)
    graph = _Graph(world_from=6)
    _await(tmp_path, monkeypatch, graph, None)
    assert graph.looks == 2


def test_a_world_node_that_does_not_answer_is_not_waited_for(tmp_path, monkeypatch):
    graph = _Graph(world_from=99)
    graph.lookupNode = lambda name: '/gone' if name == '/sim_world' else name
    assert _await(tmp_path, monkeypatch, graph, '/sim_world') < 5.0 and graph.looks == 2


def test_an_app_not_set_up_by_the_deadline_is_said_and_time_starts(tmp_path, monkeypatch):
    said = []
    graph = _Graph(world_from=10 ** 6)            # the world never takes the connection
    assert _await(tmp_path, monkeypatch, graph, '/sim_world', 0.3, said) < 5.0
    assert len(said) == 1 and re.fullmatch(
        r'WARNING app /reader not set up within 0 s of wall time \(subscriptions not '
        r'connected\); time starts anyway', said[0]), said


class _Late(_Graph):
    """/reader registers its subscription to /imu only once ``flag`` exists."""

    def __init__(self, flag):
        _Graph.__init__(self, world_from=0)
        self.flag = flag

    def getSystemState(self):
        pubs, subs, srv = _Graph.getSystemState(self)
        return pubs, subs if os.path.exists(self.flag) else [], srv


class _Proc(object):
    def __init__(self, code):
        self.p = subprocess.Popen([sys.executable, '-c', code])

    def alive(self):
        return self.p.poll() is None


SPIN_THEN_FLAG = '''import sys, time
t = time.monotonic()
while time.monotonic() - t < 0.5:
    pass
open(sys.argv[1] if len(sys.argv) > 1 else %r, 'w').close()
time.sleep(60)
'''


def _spinner(flag, in_thread=False):
    """A process that computes for 0.5 s and then creates ``flag`` (in a thread of its
    own with ``in_thread``: a master serves requests in threads, its main thread only
    looks whether it should stop, and is not watched)."""
    code = SPIN_THEN_FLAG % str(flag)
    if in_thread:
        code = 'import threading\nthreading.Thread(target=exec, args=(%r,)).start()\n' % code
    p = _Proc(code)
    time.sleep(0.2)                          # the interpreter is up: it spins now
    return p


def test_an_app_at_work_between_its_registrations_is_not_set_up(tmp_path, monkeypatch):
    """The app registered its output, then computes (a thread running) before it subscribes:
    a 20 ms quiet period took it for set up; the evidence waits for its subscription."""
    flag = tmp_path / 'subscribed'
    app = _spinner(flag)
    try:
        graph = _Late(str(flag))
        _await(tmp_path, monkeypatch, graph, '/sim_world', procs_=[('/reader', app)])
        assert flag.exists() and graph.looks >= 3, graph.looks
    finally:
        app.p.kill()
        app.p.wait()


def test_an_app_waiting_for_the_master_is_not_set_up(tmp_path, monkeypatch):
    """The app is idle (its registration sent), the run's master at work on it: waited for."""
    flag = tmp_path / 'subscribed'
    app = _Proc('import time; time.sleep(60)')
    busy_master = _spinner(flag, in_thread=True)
    try:
        graph = _Late(str(flag))
        _await(tmp_path, monkeypatch, graph, '/sim_world', procs_=[('/reader', app)],
               master_pid=busy_master.p.pid)
        assert flag.exists(), graph.looks
    finally:
        for p in (app, busy_master):
            p.p.kill()
            p.p.wait()


def test_an_app_at_work_for_good_is_waited_for_at_most_the_watchs_limit(tmp_path, monkeypatch):
    """Set up (connected, topics unchanged) but never idle (it spins): one WARNING after
    the app watch's per-slice limit, then time starts (the slices' watch goes on)."""
    spinning = _Proc('while True:\n    pass')
    said = []
    try:
        graph = _Graph(world_from=0)
        took = _await(tmp_path, monkeypatch, graph, '/sim_world', said=said,
                      procs_=[('/reader', spinning)], limit=0.3)
    finally:
        spinning.p.kill()
        spinning.p.wait()
    assert 0.3 <= took < 5.0
    assert len(said) == 1 and re.fullmatch(
        r'WARNING app /reader at work after 0\.\d s with its topics unchanged; time starts',
        said[0]), said


def test_a_python_node_app_is_found_as_rosrun_finds_it():
    from testing_instance.world.apps import python_node
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    # devel space holds catkin's relay to the source script: the script itself is run
    assert python_node('mobile_device_sim', 'barcode_reader') == \
        os.path.join(root, 'simvid', 'nodes', 'barcode_reader')
    assert python_node('rostopic', 'rostopic') == '/usr/lib/rostopic/rostopic'  # no relay
    assert python_node('rosout', 'rosout') is None                # compiled: rosrun runs it
    assert python_node('mobile_device_sim', 'tinyros_echo') is None
    assert python_node('no_such_package_x', 'node') is None        # rosrun says why
    assert python_node('mobile_device_sim', 'no_such_node_x') is None


def test_a_python_node_app_runs_as_a_script_app_and_another_through_rosrun(tmp_path,
                                                                          monkeypatch):
    import testing_instance.world.apps as apps_mod
    _script(tmp_path, 'node.py', 'print(" ".join(sys.argv)); sys.stdout.flush()')
    monkeypatch.setattr(apps_mod, 'python_node', lambda pkg, typ: str(tmp_path / 'node.py')
                        if typ == 'py_node' else None)
    sc = _scenario(tmp_path, [{'node': 'pkg/py_node', 'name': 'a', 'params': {'k': 1}},
                              {'node': 'pkg/c_node', 'name': 'b'}])
    apps = Apps(sc, lambda: dict(os.environ), str(tmp_path), [].append)
    apps.prestart()
    assert [n for n, _p in apps.procs] == ['/a']           # started with the run
    assert 'preapp.py' in apps.procs[0][1].cmd[1]
    monkeypatch.setattr(apps_mod, 'Proc', lambda cmd, *a, **k: types.SimpleNamespace(
        cmd=cmd, alive=lambda: False))
    monkeypatch.setattr(apps_mod, 'AppWatch', lambda *a, **k: object())
    started = apps.launch(lambda q: None)
    assert started[1].cmd == ['rosrun', 'pkg', 'c_node', '__name:=b']
    deadline = time.monotonic() + 30
    while started[0].alive() and time.monotonic() < deadline:
        time.sleep(0.01)
    started[0].finish(time.monotonic())
    assert open(str(tmp_path / 'a.log')).read().strip() == \
        '%s _k:=1 __name:=a' % (tmp_path / 'node.py')
