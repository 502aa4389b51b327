"""Warm worlds without a roscore: the farm's pool and its workers' protocol (with fake
workers), the dealing of scenarios to workers by world, the world key, and the reload
request's checks and start poses of sim_world's WorldHost."""
import math
import os
import stat
import sys
import types

import pytest

from testing_instance.farm import warm
from testing_instance.run.runner import world_key
from testing_instance.scenario.format import load

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EX = os.path.join(ROOT, 'testing_instance', 'examples')

FAKE_WORKER = r'''#!%(py)s
import json, os, sys
# a fake run_scenario --warm-worker: argv [NODE, '--warm-worker']; each job's argv[0] says
# what to do: pass, fail, die (the worker process dies mid-job)
assert sys.argv[2:] == ['--warm-worker'], sys.argv
for line in sys.stdin:
    job = json.loads(line)
    what = os.path.basename(job['argv'][0])
    if os.environ.get('FAKE_WORKER_LOG'):
        with open(os.environ['FAKE_WORKER_LOG'], 'a') as log:
            log.write('%%d %%s %%s\n' %% (os.getpid(), 'prepare' if job.get('prepare')
                                          else 'run', job['argv'][0]))
    if job.get('prepare'):          # a spare worker launches the world of argv
        if what.startswith('x'):    # a world whose launch kills the worker
            os._exit(7)
        print(json.dumps({'id': job['id'], 'exit': 0}), flush=True)
        continue
    print(json.dumps({'id': job['id'], 'line': 'worker %%d runs %%s' %% (os.getpid(), what)}),
          flush=True)
    if what == 'die':
        sys.stderr.write('the fake worker dies\n')
        sys.stderr.flush()
        os._exit(9)
    print(json.dumps({'id': job['id'], 'started': True}), flush=True)    # at sim time 0
    print('not json: ignored', flush=True)
    print(json.dumps({'id': job['id'], 'line': 'PASS x: %%s' %% what}), flush=True)
    print(json.dumps({'id': job['id'], 'exit': 0 if what == 'pass' else 1}), flush=True)
'''


@pytest.fixture
def fake_python(tmp_path):
    p = tmp_path / 'fake_worker'
    p.write_text(FAKE_WORKER % {'py': sys.executable})
    p.chmod(p.stat().st_mode | stat.S_IEXEC)
    return str(p)


def run_pool(fake_python, names, jobs, monkeypatch):
    monkeypatch.setattr(warm, '_key_of', lambda argv: 'world-' + argv[0][0])
    got = []
    warm.Pool(jobs, python=fake_python).run([(n, [n]) for n in names],
                                            lambda *r: got.append(r))
    return got


def test_pool_runs_every_item_and_relays_its_lines(fake_python, monkeypatch):
    got = run_pool(fake_python, ['pass', 'fail', 'pass'], 2, monkeypatch)
    assert sorted((t, rc) for t, rc, _text, _w in got) == [('fail', 1), ('pass', 0),
                                                           ('pass', 0)]
    for tag, _rc, text, wall in got:
        lines = text.splitlines()
        assert lines[0].startswith('worker ') and lines[0].endswith('runs ' + tag)
        assert lines[1] == 'PASS x: ' + tag and len(lines) == 2     # non-JSON ignored
        assert wall >= 0


def test_pool_reuses_its_workers(fake_python, monkeypatch):
    got = run_pool(fake_python, ['pass'] * 5, 2, monkeypatch)
    workers = {text.split()[1] for _t, _rc, text, _w in got}
    assert len(got) == 5 and 1 <= len(workers) <= 2


def test_a_dying_worker_costs_its_scenario_only(fake_python, monkeypatch):
    got = run_pool(fake_python, ['pass', 'die', 'pass', 'fail'], 1, monkeypatch)
    by = {}
    for tag, rc, text, _w in got:
        by.setdefault(tag, []).append((rc, text))
    assert [rc for rc, _t in by['pass']] == [0, 0] and by['fail'][0][0] == 1
    rc, text = by['die'][0]
    assert rc == 2
    assert 'ERROR the warm worker died (exit code 9)' in text
    assert '| the fake worker dies' in text


def test_pick_keeps_a_worker_on_its_world_and_spreads_the_others():
    w1, w2 = types.SimpleNamespace(key='A'), types.SimpleNamespace(key=None)
    pending = [(0, 'a0', 'A'), (1, 'b0', 'B'), (2, 'a1', 'A'), (3, 'c0', 'C')]
    assert warm._pick(w1, pending, [w1, w2])[1] == 'a0'
    # w2 has no world: it takes one nobody has, not w1's
    assert warm._pick(w2, pending, [w1, w2])[1] == 'b0'
    w2.key = 'B'
    assert warm._pick(w2, pending, [w1, w2])[1] == 'c0'
    # only w1's world is left: w2 takes it too (both keep working)
    assert warm._pick(w2, pending, [w1, w2])[1] == 'a1'
    assert pending == []


def test_sort_by_world_groups_the_examples_by_their_world():
    files = sorted(os.path.join(EX, f) for f in os.listdir(EX) if f.endswith('.yaml'))
    items = warm.sort_by_world([(f, [f]) for f in files])
    assert sorted(tag for _k, tag, _a in items) == files
    keys = [k for k, _t, _a in items]
    # each world's scenarios are next to each other
    assert len(set(keys)) == len([k for i, k in enumerate(keys) if i == 0 or k != keys[i - 1]])
    assert len(set(keys)) >= 3          # office (camera 1 Hz), office (10 Hz), battery_world
    bad = warm.sort_by_world([('x', ['/no/such.yaml'])])
    assert bad == [(None, 'x', ['/no/such.yaml'])]


def test_world_key_leaves_out_seed_rate_and_phone_pose(tmp_path):
    def key(text):
        f = tmp_path / 'k.yaml'
        f.write_text('duration: 1\n' + text)
        return world_key(load(str(f)))
    base = key('world: {args: {camera_rate: 1}}\n')
    assert key('seed: 9\nreal_time_factor: 1\nworld: {args: {camera_rate: 1}}\n'
               'phones: [{ns: mobile_device, position: [1, 2, 3], rpy: [0, 0, 1]}]\n') == base
    assert key('world: {args: {camera_rate: 2}}\n') != base
    assert key('world: {physics: bullet, args: {camera_rate: 1}}\n') != base
    f = tmp_path / 'k.yaml'
    assert world_key(load(str(f)), report='/tmp/r') != base      # the flycam


# -- sim_world's side: /gazebo/reload_world ------------------------------------------------
def spawn_request(x=1.0, y=2.0, z=3.0, yaw=0.0):
    from mobile_device_sim.srv import SpawnModelRequest
    from sim_world.transforms import Pose
    r = SpawnModelRequest()
    r.model_name, r.model_xml = 'mobile_device', '<robot/>'
    r.initial_pose = Pose.from_xyz_rpy((x, y, z), (0, 0, yaw)).to_msg()
    return r


def test_with_pose_gives_what_spawn_model_gives():
    from sim_world.node import _with_pose
    req = spawn_request()
    assert _with_pose(req, {}) is req
    moved = _with_pose(req, {'x': 4.0, 'Y': 0.7})
    want = spawn_request(x=4.0, yaw=0.7).initial_pose       # what the launch would send
    assert moved.initial_pose == want
    assert req.initial_pose == spawn_request().initial_pose   # the remembered one is kept
    # only the position: the quaternion stays bit for bit
    q = spawn_request(yaw=0.3)
    assert _with_pose(q, {'z': 9}).initial_pose.orientation == q.initial_pose.orientation


class _Host(object):
    from sim_world.node import WorldHost
    _plan = WorldHost._plan

    def __init__(self):
        self.world = types.SimpleNamespace(seed=5, models={'mobile_device': 1, 'desk': 2})
        self.rtf = 0.0
        self.start_models = None
        self.api = types.SimpleNamespace(spawned={'mobile_device': ('urdf', spawn_request()),
                                                  'gone': ('sdf', spawn_request())},
                                         real_time_factor=None)   # before the run loop


def req(seed=-1, rtf=-1.0, poses=''):
    return types.SimpleNamespace(seed=seed, real_time_factor=rtf, start_poses=poses)


def test_reload_plan_defaults_and_remembered_models():
    h = _Host()
    plan = h._plan(req())
    assert plan['seed'] == 5 and plan['rtf'] == 0.0 and plan['poses'] == {}
    # the models spawned and still there start again; deleted ones do not
    assert [n for n, _k, _r in plan['start']] == ['mobile_device']
    plan = h._plan(req(seed=0, rtf=1.0, poses='{mobile_device: {x: 1, Y: 0.5}}'))
    assert plan['seed'] == 0 and plan['rtf'] == 1.0
    assert plan['poses'] == {'mobile_device': {'x': 1, 'Y': 0.5}}
    assert h._plan(req(poses='{"mobile_device": {"z": 2.5}}'))['poses']['mobile_device'] == \
        {'z': 2.5}
    # the pace /gazebo/set_physics_properties set (the run loop's) is the one a reload keeps
    h.api.real_time_factor = 2.0
    assert h._plan(req())['rtf'] == 2.0


@pytest.mark.parametrize('r, why', [
    (req(seed=-2), 'seed must be >= 0 (or -1: keep 5), got -2'),
    (req(rtf=math.nan), 'real_time_factor must be a number'),
    (req(poses='[1, 2'), 'start_poses is not YAML'),
    (req(poses='[1, 2]'), 'start_poses must be a mapping'),
    (req(poses='{desk: {x: 1}}'), "no remembered model 'desk' (these start again: "
                                  "mobile_device)"),
    (req(poses='{mobile_device: {roll: 1}}'), 'give a mapping of x, y, z, R, P, Y'),
    (req(poses='{mobile_device: 3}'), 'give a mapping of x, y, z, R, P, Y'),
    (req(poses='{mobile_device: {x: .nan}}'), 'mobile_device.x must be a finite number'),
    (req(poses='{mobile_device: {x: true}}'), 'mobile_device.x must be a finite number'),
    (req(poses='{mobile_device: {x: "1"}}'), 'mobile_device.x must be a finite number'),
])
def test_reload_plan_refuses_bad_requests(r, why):
    with pytest.raises(ValueError) as e:
        _Host()._plan(r)
    assert why in str(e.value)


def test_a_warm_world_grown_by_half_is_relaunched(monkeypatch):
    h = warm.WarmHost(run_dir='/nonexistent-warm-dir')
    h.node_pid = os.getpid()
    sizes = iter([300000, 400000, 449000, 451000])
    monkeypatch.setattr(warm.procs, 'rss_kb', lambda pid: next(sizes))
    assert [h._grown() for _ in range(4)] == [False, False, False, True]
    assert h.rss_base == 300000
    monkeypatch.undo()
    assert warm.procs.rss_kb(os.getpid()) > 1000 and warm.procs.rss_kb(None) is None


def test_a_spare_worker_launches_the_next_world_while_one_runs(fake_python, monkeypatch,
                                                               tmp_path):
    """--jobs 1: one scenario at a time, and one worker more launches the world of the
    next scenario no worker has; that worker then runs its scenarios (no relaunch). (By
    default only when the jobs leave a CPU idle.)"""
    log = tmp_path / 'workers.log'
    monkeypatch.setenv('FAKE_WORKER_LOG', str(log))
    monkeypatch.setattr(warm, '_key_of', lambda argv: 'world-' + argv[0][0])
    names = ['a1', 'a2', 'a3', 'b1', 'b2', 'c1']
    got = []
    warm.Pool(1, python=fake_python, spare=True).run([(n, [n]) for n in names],
                                                     lambda *r: got.append(r))
    assert sorted(t for t, _rc, _x, _w in got) == names
    assert all(rc == 1 and 'PASS x: ' + t in x for t, rc, x, _w in got)   # the fake's exit
    rows = [ln.split() for ln in log.read_text().splitlines()]
    runs = {name: pid for pid, what, name in rows if what == 'run'}
    prepared = {(pid, name[0]) for pid, what, name in rows if what == 'prepare'}
    # b's and c's worlds were launched ahead, by the workers that then ran them
    assert (runs['b1'], 'b') in prepared and (runs['c1'], 'c') in prepared
    assert runs['b1'] == runs['b2'] and runs['a1'] == runs['a2'] == runs['a3']
    # the first world's scenarios ran in order, one at a time, in one worker
    assert [n for _p, w, n in rows if w == 'run'] == names
    # a worker whose world was done became the spare instead of a new worker: 2 in all
    assert len({pid for pid, _w, _n in rows}) == 2


def test_without_a_spare_no_world_is_launched_ahead(fake_python, monkeypatch, tmp_path):
    log = tmp_path / 'workers.log'
    monkeypatch.setenv('FAKE_WORKER_LOG', str(log))
    monkeypatch.setattr(warm, '_key_of', lambda argv: 'world-' + argv[0][0])
    got = []
    warm.Pool(1, python=fake_python, spare=False).run([(n, [n]) for n in ['a1', 'b1']],
                                                     lambda *r: got.append(r))
    assert len(got) == 2
    rows = [ln.split() for ln in log.read_text().splitlines()]
    assert [w for _p, w, _n in rows] == ['run', 'run'] and len({p for p, _w, _n in rows}) == 1


LEAVER = r'''
import os, signal, sys, time
flag, linger = sys.argv[1], float(sys.argv[2])
def on_int(*_a):
    open(flag, 'w').close()         # "unregistered": out of the graph at once
    time.sleep(linger)              # ... and a slow exit (rospy's takes 0.65 s)
    os._exit(0)
if linger >= 0:
    signal.signal(signal.SIGINT, on_int)
else:
    signal.signal(signal.SIGINT, signal.SIG_IGN)     # never leaves
open(flag + '.up', 'w').close()
while True:
    time.sleep(0.05)
'''


class FakeMaster(object):
    """lookupNode: the app's URI until its flag file exists (it unregistered)."""

    def __init__(self, flags):
        self.flags = flags

    def lookupNode(self, name):
        if os.path.exists(self.flags[name]):
            raise Exception('unknown node %s' % name)
        return 'http://localhost:1/' + name


def leaver(tmp_path, name, linger):
    import time as _t
    from testing_instance.world.procs import Proc
    script = tmp_path / 'leaver.py'
    script.write_text(LEAVER)
    flag = str(tmp_path / name.strip('/'))
    p = Proc([sys.executable, str(script), flag, str(linger)], dict(os.environ),
             flag + '.log')
    t0 = _t.monotonic()
    while not os.path.exists(flag + '.up') and _t.monotonic() - t0 < 10:
        _t.sleep(0.01)
    return p, flag


def settled_host(tmp_path, monkeypatch, flags):
    host = warm.WarmHost(run_dir=str(tmp_path / 'host'))
    host.port = 1
    monkeypatch.setattr(host, '_master', lambda: FakeMaster(flags))
    monkeypatch.setattr(warm, '_forget_gone', lambda m, keep: None)
    return host


def test_settle_waits_until_an_app_left_the_graph_not_until_it_exited(tmp_path, monkeypatch):
    import time as _t
    p, flag = leaver(tmp_path, '/slow_app', 2.0)
    host = settled_host(tmp_path, monkeypatch, {'/slow_app': flag})
    host.leave([('/slow_app', p)])
    t0 = _t.monotonic()
    assert host.settle() == []                 # nothing killed: nothing to say
    assert _t.monotonic() - t0 < 1.5          # not the 2 s of its exit
    assert os.path.exists(flag) and p.alive()  # it left the graph and is still exiting
    assert [q for q, _d in host.exiting] == [p]
    host._reap(wait=True)                      # close(): its exit is awaited
    assert not p.alive() and p.p.returncode == 0 and host.exiting == []


def test_settle_waits_for_the_exit_of_a_process_it_cannot_see_in_the_graph(tmp_path,
                                                                           monkeypatch):
    import time as _t
    p, flag = leaver(tmp_path, '/spawner', 0.8)
    host = settled_host(tmp_path, monkeypatch, {})
    host.leave([(None, p)])                    # no node name: only its exit tells
    t0 = _t.monotonic()
    assert host.settle() == []
    assert _t.monotonic() - t0 >= 0.7 and not p.alive() and host.exiting == []


def test_an_app_that_never_leaves_is_killed_at_the_grace(tmp_path, monkeypatch):
    import signal as _s
    p, flag = leaver(tmp_path, '/stubborn', -1)
    host = settled_host(tmp_path, monkeypatch, {'/stubborn': flag})
    host.leave([('/stubborn', p)], 'first')
    # named with its scenario, for the next scenario's WARNING (Runner._run_live)
    assert host.settle(grace=0.5) == [('/stubborn', 'first')]
    assert not p.alive() and p.p.returncode == -_s.SIGKILL and host.exiting == []


def test_pick_gives_a_world_with_many_scenarios_a_second_worker():
    w1, w2 = types.SimpleNamespace(key='A'), types.SimpleNamespace(key=None)
    pending = [(0, 'b0', 'B'), (1, 'a0', 'A'), (2, 'a1', 'A'), (3, 'a2', 'A'), (4, 'a3', 'A')]
    # A: 4 pending for the 1 worker that has it (4/2) beats B: 1 for none (1/1)
    assert warm._pick(w2, pending, [w1, w2])[1] == 'a0'
    pending = [(0, 'b0', 'B'), (1, 'a0', 'A')]
    assert warm._pick(w2, pending, [w1, w2])[1] == 'b0'     # 1/1 beats 1/2


def test_a_world_a_spare_could_not_launch_is_not_tried_ahead_again(fake_python, monkeypatch,
                                                                   tmp_path):
    """The spare dies launching world x: x's scenarios still run (x1 may have been dealt
    to the spare before its death was seen: then it is the ERROR of a dying worker, as it
    would be had it started there), and no more spares are spent on x."""
    log = tmp_path / 'workers.log'
    monkeypatch.setenv('FAKE_WORKER_LOG', str(log))
    monkeypatch.setattr(warm, '_key_of', lambda argv: 'world-' + argv[0][0])
    got = []
    names = ['a1', 'a2', 'a3', 'x1', 'x2']
    warm.Pool(1, python=fake_python, spare=True).run([(n, [n]) for n in names],
                                                     lambda *r: got.append(r))
    assert sorted(t for t, _rc, _x, _w in got) == names
    rows = [ln.split() for ln in log.read_text().splitlines()]
    assert [n for _p, w, n in rows if w == 'prepare'] == ['x1']     # tried once
    by = {t: (rc, x) for t, rc, x, _w in got}
    assert by['x2'][0] == 1 and 'PASS x: x2' in by['x2'][1]
    assert by['x1'] == (2, 'ERROR the warm worker died (exit code 7)\n') or \
        (by['x1'][0] == 1 and 'PASS x: x1' in by['x1'][1])
    assert [n for _p, w, n in rows if w == 'run'][:3] == ['a1', 'a2', 'a3']


def test_a_worker_dead_before_its_job_is_written_costs_that_job_only(tmp_path,
                                                                    monkeypatch):
    """Writing a job to a worker that has just died (a broken pipe) must not stop the farm:
    the job is the ERROR of a dying worker."""
    import time as _t
    p = tmp_path / 'dead_worker'
    p.write_text('#!%s\nimport sys\nsys.stdin.close()\nsys.exit(3)\n' % sys.executable)
    p.chmod(p.stat().st_mode | stat.S_IEXEC)
    send = warm._Worker._send

    def late(self, obj):                 # the worker is gone by the time its job is written
        self.p.wait(10)
        _t.sleep(0.1)
        send(self, obj)
    monkeypatch.setattr(warm._Worker, '_send', late)
    got = []
    warm.Pool(1, python=str(p), spare=False).run([('a', ['a'])], lambda *r: got.append(r))
    assert [(t, rc) for t, rc, _x, _w in got] == [('a', 2)]
    assert 'ERROR the warm worker died (exit code 3)' in got[0][2]


# -- the launch file's arguments -----------------------------------------------------------
def test_a_world_argument_the_launch_file_does_not_declare_is_an_error(tmp_path):
    """roslaunch ignores an undeclared argument: a misspelt world.args entry would run the
    scenario on the default without a word."""
    from testing_instance.scenario.results import RunError
    from testing_instance.world.worldside import launch_args
    f = tmp_path / 'k.yaml'
    f.write_text('duration: 1\nworld: {args: {camera_rat: 30}}\n')
    with pytest.raises(RunError) as e:
        launch_args(load(str(f)), 0, 1.0)
    text = str(e.value)
    assert 'world.args: camera_rat is not an argument of' in text and 'office.launch' in text
    assert 'Did you mean camera_rate?' in text and 'display_topic' in text
    assert '\n' not in text
    f.write_text('duration: 1\nworld: {args: {camera_rate: 30, display_topic: /a/b}}\n')
    path, args = launch_args(load(str(f)), 3, 1.0)
    assert 'camera_rate:=30' in args and 'seed:=3' in args


def test_a_launch_file_without_the_runners_arguments_is_an_error(tmp_path):
    from testing_instance.scenario.results import RunError
    from testing_instance.world.worldside import declared_args, launch_args
    (tmp_path / 'w.launch').write_text(
        '<launch><arg name="paused" default="true"/><arg name="physics" default="ode"/>'
        '<arg name="real_time_factor" default="1"/><group><arg name="x" default="1"/></group>'
        '<include file="other.launch"><arg name="seed" value="1"/></include></launch>')
    assert declared_args(str(tmp_path / 'w.launch')) == {'paused', 'physics',
                                                         'real_time_factor', 'x'}
    f = tmp_path / 'k.yaml'
    f.write_text('duration: 1\nworld: {launch: w.launch, args: {x: 2}}\n')
    with pytest.raises(RunError) as e:
        launch_args(load(str(f)), 0, 1.0)
    assert 'does not declare seed, which run_scenario sets' in str(e.value)
    # a file that is not XML: roslaunch says what is wrong with it, later
    (tmp_path / 'w.launch').write_text('<launch')
    assert declared_args(str(tmp_path / 'w.launch')) is None
    assert launch_args(load(str(f)), 0, 1.0)[1][-1] == 'x:=2'


def test_a_warm_master_whose_ports_are_taken_is_one_error_saying_how(monkeypatch, tmp_path):
    """A warm worker's master that finds its port taken starts again once on a new port;
    taken again, the worker's ERROR names the port and how it was found taken."""
    from testing_instance.scenario.results import RunError
    monkeypatch.setenv('ROS_MASTER_URI', 'http://localhost:1')
    ports = iter([24001, 24002])
    monkeypatch.setattr(warm, 'master_port', lambda: next(ports))
    cores = []

    class TakenCore(warm.procs.Core):   # failure(): the real wording
        def __init__(self, port, env, run_dir):
            self.port, self.stopped, self.taken = port, False, None
            self.master = types.SimpleNamespace(p=types.SimpleNamespace(poll=lambda: None))
            cores.append(self)

        def alive(self):
            return not self.stopped

        def wait_up(self, master, deadline):
            self.taken = 'another master (pid 7) answers there'
            return False

        def stop(self, grace=2.0):
            self.stopped = True

        def log_tail(self):
            return ['rosmaster on %d' % self.port]
    monkeypatch.setattr(warm.procs, 'Core', TakenCore)
    launch = types.SimpleNamespace(stopped=False)
    launch.stop = lambda grace=2.0: setattr(launch, 'stopped', True)
    host = warm.WarmHost(str(tmp_path))
    monkeypatch.setattr(host, '_new_launch', lambda runner: launch)
    runner = types.SimpleNamespace(world_key=lambda: 'office')
    with pytest.raises(RunError) as e:
        host.ready(runner, deadline=0.0)
    assert str(e.value) == ("the warm world's ROS master could not take port 24002: another "
                            'master (pid 7) answers there')
    assert e.value.log_lines == ['rosmaster on 24002']
    assert [c.port for c in cores] == [24001, 24002] and all(c.stopped for c in cores)
    assert launch.stopped
