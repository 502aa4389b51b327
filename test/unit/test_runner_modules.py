"""testing_instance's shape: sub-packages by job, each importing only those below it; the
runner's pieces need no runner; actions are objects; and the pieces' own behaviour."""
import ast
import json
import os
import signal
import sys
import time

import pytest
import rosbag
import rospy
from std_msgs.msg import String

from testing_instance.run import recording, runner
from testing_instance.scenario import results
from testing_instance.world import procs

# the sources (the package's __init__ may be catkin's devel shim)
PKG = os.path.dirname(os.path.dirname(runner.__file__))

#: the floors of the package, bottom up: a module imports only its own room and the rooms
#: below it (the report stands between the world and the run; the entry point's shim of the
#: pytest plugin on top)
FLOORS = [('scenario', 'io'), ('world',), ('report',), ('run',), ('farm',), ('pytest_plugin',)]


def _room(rel):
    """The room of a module path inside the package: its sub-package, or its own name."""
    return rel.split(os.sep)[0] if os.sep in rel else rel[:-3]


def _sources():
    for dirpath, _dirs, files in os.walk(PKG):
        for f in sorted(files):
            if f.endswith('.py'):
                p = os.path.join(dirpath, f)
                yield os.path.relpath(p, PKG), ast.parse(open(p).read())


def _rooms_imported(rel, tree):
    """The rooms module ``rel`` imports (relative imports, and absolute ones of the package)."""
    here = os.path.dirname(rel).split(os.sep) if os.path.dirname(rel) else []
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = here[:len(here) - (node.level - 1)] if node.level > 1 else list(here)
            parts = base + (node.module.split('.') if node.module else [])
            if parts:
                out.add(parts[0])
            else:
                out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and (node.module or '').startswith(
                'testing_instance.'):
            out.add(node.module.split('.')[1])
    return out


def _floor(room):
    for i, rooms in enumerate(FLOORS):
        if room in rooms:
            return i
    raise AssertionError('module or sub-package %r is on no floor of FLOORS' % room)


def test_every_room_imports_only_itself_and_the_rooms_below():
    up = []
    for rel, tree in _sources():
        room = _room(rel)
        if room == '__init__':
            continue
        for other in _rooms_imported(rel, tree) - {room}:
            if _floor(other) >= _floor(room):
                up.append('%s imports %s' % (rel, other))
    assert up == []


def test_the_runners_pieces_do_not_import_the_runner():
    for rel, tree in _sources():
        if rel == os.path.join('run', 'runner.py') or _room(rel) == 'farm':
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                assert node.module is None or not node.module.endswith('runner'), rel


# rospy and the standard library's own, which no module of ours can reach otherwise
LIBRARY_PRIVATE = {'os._exit', 'rospy.names._set_caller_id', 'ray._private'}


def test_no_module_reaches_into_another_objects_private_members():
    """The runner's pieces talk through public names: ``x._name`` only on self or cls
    (and the few library internals in LIBRARY_PRIVATE)."""
    found = []
    for rel, tree in _sources():
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr.startswith('_') and \
                    not node.attr.startswith('__'):
                base = node.value
                if isinstance(base, ast.Name) and base.id in ('self', 'cls'):
                    continue
                text = ast.unparse(node)
                if not any(text.startswith(ok) for ok in LIBRARY_PRIVATE):
                    found.append('%s:%d %s' % (rel, node.lineno, text))
    assert found == []


def test_runner_keeps_its_public_names():
    assert runner.Result is results.Result and runner.RunError is results.RunError
    assert runner.write_junit is results.write_junit and runner.free_port is procs.free_port
    assert (runner.EXIT_PASS, runner.EXIT_FAIL, runner.EXIT_ERROR) == (0, 1, 2)
    assert runner.META_TOPIC == recording.META_TOPIC == '/scenario/meta'


def test_read_meta_of_a_bag_with_and_without_meta(tmp_path):
    p = str(tmp_path / 'a.bag')
    with rosbag.Bag(p, 'w') as b:
        b.write('/other', String('x'), rospy.Time(1))
        b.write(recording.META_TOPIC, String(json.dumps({'seed': 7, 'inputs': ['/imu']})),
                rospy.Time(2))
    with rosbag.Bag(p) as b:
        assert recording.read_meta(b) == {'seed': 7, 'inputs': ['/imu']}
    q = str(tmp_path / 'b.bag')
    with rosbag.Bag(q, 'w') as b:
        b.write('/other', String('x'), rospy.Time(1))
    with rosbag.Bag(q) as b:
        assert recording.read_meta(b) is None


def test_tail_of_a_log(tmp_path):
    p = tmp_path / 'l.log'
    p.write_text('\n'.join(str(i) for i in range(40)) + '\n')
    assert procs.tail(str(p), 3) == ['37', '38', '39']
    assert procs.tail(str(tmp_path / 'missing.log')) == []


def test_replay_and_the_clocks_use_only_the_runners_public_api():
    """replay.py and the clocks drive the run through the Runner's public names."""
    for rel, var in ((os.path.join('run', 'replay.py'), 'r'), (os.path.join('run', 'clock.py'), 'r')):
        tree = ast.parse(open(os.path.join(PKG, rel)).read())
        private = sorted({n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)
                          and isinstance(n.value, ast.Name) and n.value.id == var
                          and n.attr.startswith('_')})
        assert private == [], rel
    for name in ('start_master', 'init_ros', 'open_recording', 'start_apps', 'start_at',
                 'subscribe_all', 'write_meta', 'check_world', 'drain', 'answered',
                 'stamp_held', 'start_after', 'master_uri', 'run_timeline'):
        assert hasattr(runner.Runner, name), name


def test_one_loop_runs_live_and_replayed_runs():
    """The live run and the replay both go through Runner.run_timeline; neither the runner
    nor replay.py has a loop of its own over sim time."""
    for rel in (os.path.join('run', 'replay.py'), os.path.join('run', 'runner.py')):
        text = open(os.path.join(PKG, rel)).read()
        assert 'run_timeline(' in text, rel
    loops = [rel for rel, tree in _sources() if rel.startswith('run' + os.sep)
             for node in ast.walk(tree) if isinstance(node, ast.While)
             and 'step_to' in ast.unparse(node)]
    assert loops == [os.path.join('run', 'runner.py')]


def test_every_scenario_action_is_an_object_of_its_own_class():
    from testing_instance.run import actions
    from testing_instance.scenario import format as scenario
    assert set(actions.KINDS) == set(scenario.ACTIONS)
    for name, cls in actions.KINDS.items():
        assert issubclass(cls, actions.Action) and cls.name == name
        ev = {'id': 'e', 'action': name}
        assert isinstance(actions.action_of(ev), cls) and actions.action_of(ev).ev is ev
    assert not issubclass(runner.Runner, actions.Action) and not hasattr(runner.Runner, '_act_walk')


def test_an_action_acts_through_its_hands():
    """An action calls the world's services, publishes and schedules only through Hands: a
    rotation reads the pose now, then puts its steps on the agenda; an error answer is the
    run's error naming the action."""
    from types import SimpleNamespace
    from testing_instance.run.actions import Hands, action_of
    from testing_instance.scenario.results import RunError
    calls, later = [], []

    def proxy(name, typ):
        def call(*args):
            calls.append((name, typ, args))
            pose = SimpleNamespace(position=SimpleNamespace(x=1.0, y=2.0, z=3.0),
                                   orientation=SimpleNamespace(x=0.0, y=0.0, z=0.0, w=1.0))
            return SimpleNamespace(success=name != '/gazebo/delete_model', pose=pose,
                                   status_message='no model x')
        return call
    world = SimpleNamespace(srv_types=dict(get='Get', set='Set', delete='Del'), proxy=proxy,
                            log_tail=lambda: [])
    sc = SimpleNamespace(phones=[{'ns': 'mobile_device'}])
    h = Hands(sc, world, lambda t, fn, what: later.append((t, what)))
    action_of({'id': 'turn', 'action': 'rotate', 'model': 'm', 'rpy': [0, 0, 1.57],
               'duration': 0.1, 'interval': 0.05}).apply(h, 2.0)
    assert calls == [('/gazebo/get_model_state', 'Get', ('m', ''))]
    assert [round(t, 3) for t, _w in later] == [2.05, 2.1] and later[0][1] == 'turn'
    with pytest.raises(RunError, match=r'^gone \(delete_model\): no model x$'):
        action_of({'id': 'gone', 'action': 'delete_model', 'name': 'x'}).apply(h, 3.0)


def test_an_actions_publisher_is_woken_by_its_subscriber_connecting_not_by_polling():
    import threading
    import time
    from testing_instance.run.actions import _Connected
    c, n = _Connected(), [0]

    def connect():
        time.sleep(0.05)
        n[0] = 1
        c.peer_subscribe('/charger', None, None)
    th = threading.Thread(target=connect)
    t0 = time.monotonic()
    th.start()
    assert c.wait(lambda: n[0], 10.0)
    assert time.monotonic() - t0 < 5.0
    th.join()
    assert c.wait(lambda: n[0], 0.0)                 # already connected: at once
    assert not _Connected().wait(lambda: 0, 0.05)    # nobody: gives up at the timeout


def test_an_actions_message_is_in_the_subscribers_sockets_when_publish_returns(monkeypatch):
    """Action publishers are synchronous (rospy: no queue_size; its warning about that is
    kept quiet): a queued publisher's thread could write after the next step request, and
    the world took a radio switched off at sim time 0 a slice late. Publishing marks the
    next step as following inputs (WorldClock.step)."""
    import warnings
    from testing_instance.run.actions import Hands
    made = []

    class Pub(object):
        def __init__(self, topic, cls, **kw):
            warnings.warn('The publisher should be created with an explicit keyword '
                          "argument 'queue_size'", SyntaxWarning)
            made.append((topic, kw))
            self.sent = []

        def get_num_connections(self):
            return 1

        def publish(self, msg):
            self.sent.append(msg)
    monkeypatch.setattr(rospy, 'Publisher', Pub)
    a = Hands(None, None, None)
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        a.publish('/mobile_device/wifi/enable', String('off'))
        a.publish('/mobile_device/wifi/enable', String('on'))
    assert [(t, kw['queue_size'], kw['latch']) for t, kw in made] == [
        ('/mobile_device/wifi/enable', None, True)]
    assert [m.data for m in a.pubs[('/mobile_device/wifi/enable', 'std_msgs/String')].sent] \
        == ['off', 'on']
    assert a.inputs_sent


@pytest.mark.parametrize('embedded', [True, False])
def test_a_step_after_an_action_waits_for_an_embedded_worlds_receive_threads(embedded):
    """An embedded world is this process: before a step that follows the actions' messages
    the runner waits until its receive threads have handled what was written to their
    sockets (transport.settle), so the world takes the input at this slice boundary. A world
    node's step request waits for its own receive threads (transport.close_gate): the runner
    does not look. Without an action since the last step, no look."""
    import time
    from types import SimpleNamespace
    from test_stepgate import busy_receiver
    from testing_instance.run.clock import WorldClock
    sock, done, th = busy_receiver('/mobile_device/wifi/enable')
    seen = []

    def step_srv(**kw):
        seen.append(list(done))
        return SimpleNamespace(success=True, topics=[], counts=[], dropped=[])
    r = SimpleNamespace(embedded=embedded, hands=SimpleNamespace(inputs_sent=True),
                        step_srv=step_srv, rospy=SimpleNamespace(get_name=lambda: '/sim_world'),
                        sc=SimpleNamespace(pipeline=False, apps=[], slice=0.05),
                        intake=SimpleNamespace(note_times=lambda answer: None))
    clock = WorldClock(r)
    try:
        time.sleep(0.05)
        sock.send(b'off')                   # what the synchronous publisher wrote
        time.sleep(0.05)
        clock.step(0.05)
        assert seen == [[b'off']] if embedded else seen == [[]]
        assert not r.hands.inputs_sent
        while not done:
            time.sleep(0.01)
        sock.send(b'on')
        time.sleep(0.05)
        clock.step(0.1)                     # no action since the last step: no look
        assert seen[-1] == [b'off']
    finally:
        sock.close()
        th.join(5)
    assert not th.is_alive()


def test_poll_looks_again_soon_then_less_often_and_gives_up_at_the_deadline(monkeypatch):
    import time
    sleeps = []
    now = [100.0]
    monkeypatch.setattr(time, 'sleep', lambda s: (sleeps.append(s), now.__setitem__(
        0, now[0] + s)))
    monkeypatch.setattr(time, 'monotonic', lambda: now[0])
    looks = []
    assert procs.poll(lambda: looks.append(1) or len(looks) >= 4, 200.0) is True
    assert sleeps == [0.001, 0.002, 0.004]           # ready after 7 ms: seen at 7 ms
    del sleeps[:]
    assert procs.poll(lambda: False, now[0] + 0.1) is False
    assert sleeps[:6] == [0.001, 0.002, 0.004, 0.008, 0.016, 0.02]   # at most every 20 ms
    assert abs(sum(sleeps) - 0.1) < 1e-9             # and not past the deadline
    del sleeps[:]
    assert procs.poll(lambda: True, 0.0) is True and sleeps == []


RESPAWNER = r'''
import os, subprocess, sys, time
# as roscore does with rosout (respawn="true"): a child started again as soon as it dies
kid = subprocess.Popen(['sleep', sys.argv[1]], start_new_session=True)
print(kid.pid, flush=True)
while True:
    if kid.poll() is not None:
        kid = subprocess.Popen(['sleep', '60'], start_new_session=True)
        print(kid.pid, flush=True)
    time.sleep(0.001)
'''


def _kill_slowly_then_check_nothing_is_left(tmp_path, monkeypatch, kill, first='60'):
    import signal
    import sys
    import time
    marker = 'RESPAWN_TEST_%d_%s' % (os.getpid(), kill)
    env = dict(os.environ, **{marker: '1'})
    script = tmp_path / 'respawner.py'
    script.write_text(RESPAWNER)
    p = procs.Proc([sys.executable, str(script), first], env, str(tmp_path / 'r.log'))
    try:
        deadline = time.monotonic() + 10
        while not open(str(tmp_path / 'r.log')).read().strip() and \
                time.monotonic() < deadline:
            time.sleep(0.01)
        if first == '60':
            assert len(procs.descendants(p.p.pid)) == 2
        real_kill = os.kill

        def slow_kill(pid, sig):
            # a runner thread descheduled between two kills (the GIL, a busy machine)
            real_kill(pid, sig)
            if sig == signal.SIGKILL:
                time.sleep(0.05)
        monkeypatch.setattr(os, 'kill', slow_kill)
        kill(p)
        monkeypatch.setattr(os, 'kill', real_kill)
        time.sleep(0.1)
        left = procs.carrying(marker)
        assert left == [], 'left behind: %s (started: %s)' % (
            left, open(str(tmp_path / 'r.log')).read().split())
    finally:
        for pid, _c in procs.carrying(marker):
            os.kill(pid, 9)


def test_killing_a_tree_leaves_no_respawned_child_behind(tmp_path, monkeypatch):
    """kill_tree stops the root first: a parent that restarts its dead child (roscore's
    rosout) gets no chance to, even when the killer is slow between two kills."""
    _kill_slowly_then_check_nothing_is_left(tmp_path, monkeypatch, procs.kill_tree)


def test_stopping_a_run_leaves_no_respawned_child_of_the_launch_behind(tmp_path,
                                                                      monkeypatch):
    """stop_run's end of a launch (once its world node is gone): the same for roslaunch,
    whose tree is listed again at the end: here its first child ends by itself while the
    node shuts down (0.3 s), and the one started instead is not in the first list."""
    import subprocess
    nodes = []

    def stop(p):
        # a world node that takes 0.3 s to shut down after its SIGINT
        nodes.append(subprocess.Popen(['bash', '-c', 'trap "" INT; echo up; sleep 0.3'],
                                      stdout=subprocess.PIPE))
        assert nodes[0].stdout.readline() == b'up\n'        # SIGINT is ignored now
        procs.stop_run([], launch=p, node=nodes[0].pid, grace=5.0)
    try:
        _kill_slowly_then_check_nothing_is_left(tmp_path, monkeypatch, stop, first='0.1')
    finally:
        for n in nodes:
            n.kill()
            n.wait()
            n.stdout.close()


def test_a_launch_on_the_runs_core_reads_an_empty_roscore_and_keeps_the_logging(tmp_path):
    """procs.launch_env: roslaunch --wait reads roscore.xml from ROS_ETC_DIR even when it
    starts no master; there it finds an empty one (no rosout, no rosversion commands). The
    logging configuration rospy would have found is named (ROS_HOME's first), unless one
    is named already."""
    import roslaunch.config
    import roslaunch.xmlloader
    etc, home = tmp_path / 'etc', tmp_path / 'home'
    (home / 'config').mkdir(parents=True)
    etc.mkdir()
    (etc / 'python_logging.conf').write_text('[loggers]\n')
    env = procs.launch_env({'ROS_ETC_DIR': str(etc), 'ROS_HOME': str(tmp_path / 'none')},
                           str(tmp_path / 'run'))
    assert env['ROS_ETC_DIR'] == str(tmp_path / 'run' / 'etc_ros')
    assert env['ROS_PYTHON_LOG_CONFIG_FILE'] == str(etc / 'python_logging.conf')
    old = os.environ.get('ROS_ETC_DIR')
    os.environ['ROS_ETC_DIR'] = env['ROS_ETC_DIR']
    try:
        config = roslaunch.config.ROSLaunchConfig()
        roslaunch.config.load_roscore(roslaunch.xmlloader.XmlLoader(), config, verbose=False)
        assert config.nodes_core == [] and config.params == {}
    finally:
        if old is None:
            del os.environ['ROS_ETC_DIR']
        else:
            os.environ['ROS_ETC_DIR'] = old
    (home / 'config' / 'python_logging.yaml').write_text('version: 1\n')
    env = procs.launch_env({'ROS_ETC_DIR': str(etc), 'ROS_HOME': str(home)},
                           str(tmp_path / 'run'))
    assert env['ROS_PYTHON_LOG_CONFIG_FILE'] == str(home / 'config' / 'python_logging.yaml')
    env = procs.launch_env({'ROS_ETC_DIR': str(etc), 'ROS_PYTHON_LOG_CONFIG_FILE': '/x.conf'},
                           str(tmp_path / 'run'))
    assert env['ROS_PYTHON_LOG_CONFIG_FILE'] == '/x.conf'


def test_a_launch_imports_roslaunch_first_and_talks_only_to_the_master_it_is_given(tmp_path):
    """procs.Launch: roslaunch's Python start runs while the run's master starts, but it
    talks to no master until go(uri): not to the one its environment names (another job's
    on a port taken first), then to the given one; without go it ends with the run."""
    import signal
    import socket
    import time
    from testing_instance.world import procs
    env_master, given = socket.socket(), socket.socket()
    for s in (env_master, given):
        s.bind(('127.0.0.1', 0))
        s.listen(8)
        s.settimeout(0.2)
    launch_file = tmp_path / 'p.launch'
    launch_file.write_text('<launch><param name="x" value="1"/></launch>\n')
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % env_master.getsockname()[1],
               ROS_HOME=str(tmp_path), ROS_LOG_DIR=str(tmp_path))
    p = procs.Launch([str(launch_file)], procs.launch_env(env, str(tmp_path)),
                     str(tmp_path / 'world.log'))
    try:
        assert p.cmd[-3:] == ['--wait', '--skip-log-check', str(launch_file)]
        deadline = time.monotonic() + 1.5
        while time.monotonic() < deadline:        # waiting for go: no master is asked
            with pytest.raises(socket.timeout):
                env_master.accept()
        assert p.alive()
        p.go('http://127.0.0.1:%d' % given.getsockname()[1])
        deadline, conn = time.monotonic() + 30, None
        while conn is None and time.monotonic() < deadline and p.alive():
            try:
                conn, _addr = given.accept()      # roslaunch --wait asks the given master
            except socket.timeout:
                pass
        assert conn is not None, open(tmp_path / 'world.log').read()
        conn.close()
        with pytest.raises(socket.timeout):
            env_master.accept()
    finally:
        p.stop(grace=5.0)
        env_master.close()
        given.close()
    assert not p.alive()
    # without go: it ends quietly when the run stops it (SIGINT), also when it came with
    # SIGINT ignored (a runner in the background of a non-interactive shell: CI)
    old = signal.getsignal(signal.SIGINT)
    try:
        for ignored in (False, True):
            signal.signal(signal.SIGINT, signal.SIG_IGN if ignored else old)
            q = procs.Launch([str(launch_file)], procs.launch_env(env, str(tmp_path)),
                             str(tmp_path / 'w2.log'))
            time.sleep(1.0)
            q.stop(grace=10.0)
            assert q.p.returncode == 0, (ignored, open(tmp_path / 'w2.log').read())
    finally:
        signal.signal(signal.SIGINT, old)



def test_stop_run_returns_the_apps_it_had_to_sigkill(tmp_path):
    """An app that ignores its SIGINT is SIGKILLed at the grace and returned (the run says
    it); one that ends on its SIGINT is not."""
    deaf = procs.Proc([sys.executable, '-c', 'import signal, time\n'
                       'signal.signal(signal.SIGINT, signal.SIG_IGN)\n'
                       'print("ready", flush=True)\ntime.sleep(60)\n'],
                      dict(os.environ), str(tmp_path / 'deaf.log'))
    # (its SIGINT handler set: a suite started in the background of a non-interactive
    # shell, as CI is, hands its children SIGINT ignored, and Python then keeps it so)
    fine = procs.Proc([sys.executable, '-c', 'import signal, time\n'
                       'signal.signal(signal.SIGINT, signal.default_int_handler)\n'
                       'print("ready", flush=True)\ntime.sleep(60)\n'],
                      dict(os.environ), str(tmp_path / 'fine.log'))
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and not all(
            (tmp_path / n).read_text() for n in ('deaf.log', 'fine.log')):
        time.sleep(0.02)
    killed = procs.stop_run([deaf, fine], grace=3.0)
    assert killed == [deaf]
    assert deaf.p.returncode == -signal.SIGKILL and fine.p.returncode != -signal.SIGKILL
