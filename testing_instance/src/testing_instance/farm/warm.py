"""Warm worlds for farms (issue 18): a master and a loaded world serve scenario after
scenario.

A farm (``run_scenario --jobs N``, a local sweep) starts N worker processes
(``run_scenario --warm-worker``). Each keeps one ROS master for its life and one world
launched on it; a scenario whose world is the same (the same launch file and world
arguments: :meth:`Runner.world_key`) runs in that world after a reset, any other gets the
old world stopped and its own launched. The reset between scenarios
(:meth:`WarmHost.reset`):

- ``/gazebo/reload_world``: sim_world builds a fresh World in its process (same file,
  engine and step), with the scenario's seed and real-time factor, and spawns the launch's
  models again from their requests, the phone at the scenario's start pose. Models spawned
  or deleted, environment values, faults and every plugin's state go with the old world;
- every parameter the scenario's apps and actions left on the parameter server is deleted
  (what the launch set stays);
- registrations of nodes that are gone (an app killed at the end) are removed from the
  master.

So a scenario sees what it would see in a fresh world: ``test_warm_world_gives_the_cold_
recording`` runs A then B warm and B cold and compares B's recordings message by message.
The runner itself runs in the worker process: Python, rospy and the imports are paid once
per worker, not per scenario. The last scenario's apps get SIGINT at its end; the next one
waits until they have left the ROS graph (unregistered), not for their rospy exit.

While N scenarios run, one **spare** worker more launches the world of the next scenario no
worker has (``{"id": N, "argv": [...], "prepare": true}``); a worker whose world no pending
scenario needs becomes that spare. So a farm's later worlds start while others run, on the
core the running scenario leaves idle, and one scenario at a time still runs per job.

The farm talks to a worker through its standard input and output, one JSON object per
line: ``{"id": N, "argv": [...]}`` (a run_scenario command line) in,
``{"id": N, "line": "..."}`` (its output) and ``{"id": N, "exit": code}`` out.
"""
import json
import os
import queue
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

from sim_world.netutil import master_port, wait_for_service

from ..scenario.results import EXIT_ERROR, RunError
from ..world import procs

__all__ = ['WarmHost', 'Pool', 'worker_main', 'NODE']

NODE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..',
                                    '..', 'nodes', 'run_scenario'))   # testing_instance/nodes
CORE_NODES = ('/rosout', '/sim_world', '/scenario_runner')
RSS_GROWTH = 1.5              # relaunch a world node grown by half (WarmHost._grown)
CORE_PARAMS = ('/run_id', '/rosdistro', '/rosversion', '/use_sim_time')


class WarmHost(object):
    """One worker's master and world (see the module doc)."""

    def __init__(self, run_dir=None):
        self.dir = run_dir or tempfile.mkdtemp(prefix='warm_world_')
        self.port = None
        self.core = None          # procs.Core: master and rosout, for the worker's life
        self.launch = None        # Proc: roslaunch of the world
        self.key = None
        self.node_pid = None      # the world node below the launch
        self.base_params = set()  # ... and the launch
        self.base_nodes = set()
        self.log_offset = 0
        self.broken = False       # the master died under this process's node
        self.leaving = []         # the last scenario's apps: (name, uri, Proc, scenario)
        self.exiting = []         # (Proc, deadline): out of the graph, not yet exited
        self.rss_base = None      # kB of the world node at its first scenario

    # -- what a Runner asks --------------------------------------------------------------
    def env(self):
        return procs.ros_env(os.path.join(self.dir, 'log'), self.port)

    def ready(self, runner, deadline):
        """The master and the world ``runner``'s scenario needs, launched (or kept) and
        answering; this process's node on that master. ``prepare`` then resets the world
        for the scenario; a farm's spare worker calls only this (Pool._deal)."""
        key = runner.world_key()
        pre = None                       # a fresh master's world: procs.Launch, told later
        for attempt in (1, 2):
            fresh = self.core is None or not self.core.alive()
            if fresh and self.core is not None and _rospy_up():
                # this process's node belongs to the master that died: a new worker takes
                # the next scenario (rospy cannot start over in a process)
                self.broken = True
                raise RunError('the warm worker\'s ROS master died', self.core.log_tail())
            if fresh:
                self._stop_world()
                self.port = master_port()
                os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % self.port
                os.environ.setdefault('ROS_HOSTNAME', 'localhost')
                if pre is None:          # roslaunch's Python start while the master starts
                    pre = self._new_launch(runner)
                self.core = procs.Core(self.port, self.env(), self.dir)
                t0 = time.monotonic()
                if not self._await_core(deadline):
                    # the port was taken between the look and the master's bind (another
                    # master, or a connection's local port): once more on a new port
                    why = self.core.failure(time.monotonic() - t0,
                                            "the warm world's ROS master")
                    self.core.stop(grace=2.0)
                    if attempt == 2:
                        pre.stop(grace=2.0)
                        raise RunError(why, self.core.log_tail())
                    continue
            runner.port = self.port
            if fresh or key != self.key or self.launch is None or \
                    not self.launch.alive() or not procs.alive(self.node_pid or -1) or \
                    self._grown():
                self._stop_world()
                if not fresh:            # the killed world's registrations go too
                    self._clear(None, {'/rosout', '/scenario_runner'})
                self._start_world(runner, key, deadline, pre)
                self._await_world(deadline)
            else:
                self._clear(self.base_params, self.base_nodes | set(CORE_NODES))
            break
        runner.init_ros()                # once per worker: the node lives on the master

    def prepare(self, runner, deadline):
        """Make the world ``runner``'s scenario needs ready at sim time 0, paused."""
        self.ready(runner, deadline)
        self.reset(runner)

    def leave(self, apps, scenario=None):
        """The processes of the scenario that ended (``scenario``: its name, for the next
        one's words), as (ROS node name or None, procs.Proc): SIGINT now. ``settle`` (the
        next scenario, before it subscribes or steps) waits until each has left the ROS
        graph; ``close`` until each has exited."""
        m = self._master() if self.port else None
        for name, p in apps:
            uri = None
            if name and m is not None and p.alive():
                try:
                    uri = m.lookupNode(name)      # this process's node, not a later namesake
                except Exception:  # noqa: BLE001 - never registered, or the master is gone
                    pass
            p.interrupt()
            self.leaving.append((name, uri, p, scenario))

    def settle(self, grace=procs.STOP_GRACE):
        """Wait until every process of the last scenario has left the ROS graph: it exited,
        or its node is no longer registered under its URI. rospy unregisters within
        milliseconds of SIGINT, then takes another 0.65 s to exit (its threads poll for
        shutdown every 0.5 s): the next scenario need not wait for that. A process that
        was never registered is waited for until it exits. What is still in the graph at
        ``grace`` s is SIGKILLed and its registrations removed; processes out of the graph
        but still exiting are reaped later (``_reap``), SIGKILLed if alive at ``grace``.
        Returns [(node name, scenario name)] of the processes this SIGKILLed: they did
        not end on their SIGINT, and the next scenario's start-up waited for them (the
        runner says so)."""
        deadline = time.monotonic() + grace
        m = self._master() if self.port else None
        killed, said = False, []
        for name, uri, p, scenario in self.leaving:
            while p.alive() and time.monotonic() < deadline and _registered(m, name, uri):
                time.sleep(0.002)
            if p.alive() and not _registered(m, name, uri):
                self.exiting.append((p, deadline))
                continue
            if p.finish(deadline):                # SIGKILL at the deadline
                said.append((name, scenario))
            # (a process SIGKILLed by someone else left its registrations too)
            killed |= p.p.returncode == -signal.SIGKILL
        self.leaving = []
        self._reap()
        if killed and self.port:
            _forget_gone(self._master(), set())
        return said

    def _reap(self, wait=False):
        """Close the processes that left the graph and exited since; SIGKILL those alive
        past their deadline (``wait``: wait for each until its deadline)."""
        still = []
        for p, deadline in self.exiting:
            if p.alive() and not wait and time.monotonic() < deadline:
                still.append((p, deadline))
            else:
                p.finish(deadline)
        self.exiting = still

    def _grown(self):
        """The world node's memory grew past RSS_GROWTH times what it had at its first
        scenario: relaunch it (each reload leaves about 2 MB of heap the allocator does
        not give back; bench/soak)."""
        rss = procs.rss_kb(self.node_pid)
        if rss is None:
            return False
        if self.rss_base is None:
            self.rss_base = rss
            return False
        return rss > RSS_GROWTH * self.rss_base

    def reset(self, runner):
        from mobile_device_sim.srv import ReloadWorld
        import rospy
        pose = runner.start_pose()
        over = {}
        if pose:
            over = {k if k != 'yaw' else 'Y': float(v) for k, v in pose.items()}
            over = {'mobile_device': over}
        self.log_offset = _size(self.log_path)     # this scenario's world log from here
        try:
            r = rospy.ServiceProxy('/gazebo/reload_world', ReloadWorld)(
                seed=runner.seed, real_time_factor=runner.rtf, start_poses=json.dumps(over))
        except Exception as e:  # noqa: BLE001 - the world is gone or refused the call
            raise RunError('the warm world did not reload: %s' % e, self.log_tail())
        if not r.success:
            raise RunError('the warm world did not reload: %s' % r.status_message,
                           self.log_tail())

    @property
    def log_path(self):
        return os.path.join(self.dir, 'world.log')

    def log_tail(self, n=25):
        """The last lines the world logged since this scenario's reset."""
        try:
            with open(self.log_path, 'rb') as f:
                f.seek(self.log_offset)
                text = f.read().decode('utf-8', 'replace')
        except OSError:
            return []
        return text.splitlines()[-n:]

    def save_log(self, path):
        """This scenario's part of the world's log, as a cold run's world.log."""
        try:
            with open(self.log_path, 'rb') as f, open(path, 'wb') as out:
                f.seek(self.log_offset)
                out.write(f.read())
        except OSError:
            pass

    def watched(self):
        """{what: pid} of the master and the world node (Runner.check_world)."""
        watched = self.core.pids()
        watched.update(procs.world_node(self.launch))
        return watched

    # -- the master and the world --------------------------------------------------------
    def _master(self):
        import rosgraph
        return rosgraph.Master('/scenario_runner',
                               master_uri='http://localhost:%d' % self.port)

    def _await_core(self, deadline):
        """True once the worker's own master answers (its pid); then /use_sim_time is set
        and rosout started (procs.Core.up). False when it exited, did not answer by the
        deadline, or found its port taken (``core.taken`` says how)."""
        m = self._master()
        if not self.core.wait_up(m, deadline):
            return False
        self.core.up(m)
        return True

    def _new_launch(self, runner):
        """procs.Launch of runner's world: roslaunch imported, waiting for its master."""
        path, args = runner.launch_args()
        # the phone where the launch file puts it: each reload sets the scenario's pose
        args = [a for a in args if not a.startswith('phone_')]
        return procs.Launch([path] + args, procs.launch_env(self.env(), self.dir),
                            self.log_path)

    def _start_world(self, runner, key, deadline, launch=None):
        """roslaunch the world on the worker's master (which is up: --wait only says the
        launch starts no master of its own); ``launch``: one started with that master
        (_new_launch)."""
        self.launch = launch if launch is not None else self._new_launch(runner)
        self.launch.go('http://localhost:%d' % self.port)
        self.rss_base = None
        self.key = key
        self.log_offset = 0

    def _await_world(self, deadline):
        if not wait_for_service('/gazebo/reload_world', timeout=max(
                0.1, deadline - time.monotonic()), caller='/scenario_runner'):
            raise RunError('the warm world did not offer /gazebo/reload_world',
                           procs.tail(self.log_path))
        # the launch's own spawners (the phone, the flycam) are done: their models are the
        # ones every reload spawns again. A spawner is done when it said so in the launch's
        # output ("spawn_model: ..." at its end, before rospy's own slow exit) or is gone.
        seen = set()
        while time.monotonic() < deadline and self.launch.alive():
            live = {p for p in procs.descendants(self.launch.p.pid)[1:]
                    if 'spawn_model' in ' '.join(procs.cmdline(p))}
            seen |= live
            if not live or _said(self.log_path, b'spawn_model: ') >= len(seen):
                break
            time.sleep(0.02)
        self.node_pid = next((pid for pid in procs.descendants(self.launch.p.pid)[1:]
                              if '__name:=sim_world' in procs.cmdline(pid)), None)
        if not self.launch.alive() or self.node_pid is None:
            raise RunError('the warm world exited while starting', procs.tail(self.log_path))
        m = self._master()
        self.base_params = set(m.getParamNames())
        self.base_nodes = _nodes(m)

    def _stop_world(self):
        """The world goes at once (SIGKILL to its launch tree): nothing of it is needed
        any more, and its rospy exit took 0.7 s. The master drops the old /sim_world's
        registrations when the next world's node registers under that name; what other
        nodes of the launch left is cleared as gone (_clear)."""
        if self.launch is not None:
            procs.kill_tree(self.launch)
        self.launch, self.key, self.node_pid = None, None, None

    def _clear(self, params, nodes):
        """Delete the parameters not in ``params`` (None: all but roscore's own);
        unregister what nodes not in ``nodes`` that are gone left registered."""
        m = self._master()
        names = set(m.getParamNames())
        keep = set(params) if params is not None else {
            n for n in names if n in CORE_PARAMS or n.startswith('/roslaunch/')}
        for name in sorted(names - keep):
            try:
                m.deleteParam(name)
            except Exception:  # noqa: BLE001 - gone with a parent already
                pass
        _forget_gone(m, set(nodes))

    def close(self):
        """The worker is done: the last scenario's apps leave (returns what ``settle`` had
        to SIGKILL of them: said as the farm ends), the world and the master go."""
        said = self.settle()
        self._reap(wait=True)
        self._stop_world()
        if self.core is not None:
            self.core.kill()
            self.core = None
        if not os.environ.get('SCENARIO_KEEP_LOGS'):
            shutil.rmtree(self.dir, ignore_errors=True)
        return said


def _rospy_up():
    import rospy.core
    return rospy.core.is_initialized()


def _registered(m, name, uri):
    """Is the node ``name`` still registered with master ``m`` under ``uri``? (True when
    that cannot be known: no name or URI.)"""
    if m is None or not name or not uri:
        return True
    try:
        return m.lookupNode(name) == uri
    except Exception:  # noqa: BLE001 - unknown to the master (or the master is gone)
        return False


def _said(path, what):
    """How many times ``what`` (bytes) is in the file at ``path``."""
    try:
        with open(path, 'rb') as f:
            return f.read().count(what)
    except OSError:
        return 0


def _size(path):
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _nodes(m):
    pubs, subs, srvs = m.getSystemState()
    return {n for _t, ns in pubs + subs + srvs for n in ns}


def _forget_gone(m, keep):
    """Unregister every topic and service of nodes (not in ``keep``) that no longer answer."""
    from xmlrpc.client import ServerProxy
    pubs, subs, srvs = m.getSystemState()
    for node in {n for _t, ns in pubs + subs + srvs for n in ns} - keep:
        try:
            uri = m.lookupNode(node)
        except Exception:  # noqa: BLE001
            continue
        try:
            _Quick(uri).getPid('/scenario_runner')
            continue                                       # alive: it stays
        except Exception:  # noqa: BLE001 - gone
            pass
        master = ServerProxy(m.master_uri)
        for topic, ns in pubs:
            if node in ns:
                master.unregisterPublisher(node, topic, uri)
        for topic, ns in subs:
            if node in ns:
                master.unregisterSubscriber(node, topic, uri)
        for srv, ns in srvs:
            if node in ns:
                try:
                    master.unregisterService(node, srv, m.lookupService(srv))
                except Exception:  # noqa: BLE001
                    pass


class _Quick(object):
    """An XML-RPC proxy with a 1 s socket timeout (a dead node's port refuses at once; a
    stopped one must not hang the reset)."""

    def __init__(self, uri):
        import xmlrpc.client
        import http.client

        class T(xmlrpc.client.Transport):
            def make_connection(self, host):
                return http.client.HTTPConnection(host, timeout=1.0)
        self._p = xmlrpc.client.ServerProxy(uri, transport=T())

    def __getattr__(self, name):
        return getattr(self._p, name)


# -- the worker: run_scenario --warm-worker ------------------------------------------------
def worker_main(stdin=None, stdout=None):
    """Read jobs (run_scenario command lines) and run each in this process's warm world."""
    from .command import prepare_argv, run_argv
    stdin = stdin or sys.stdin
    proto = stdout or os.fdopen(os.dup(sys.stdout.fileno()), 'w', buffering=1)
    # everything else this process prints (rospy's console lines) is not the protocol
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    host = WarmHost()
    lock = threading.Lock()

    def send(obj):
        with lock:
            proto.write(json.dumps(obj) + '\n')
            proto.flush()
    try:
        for line in stdin:
            if not line.strip():
                continue
            job = json.loads(line)
            jid = job['id']
            if job.get('prepare'):
                # a spare worker: launch this command line's world and wait (Pool._deal)
                try:
                    prepare_argv(job['argv'], host)
                    code = 0
                except Exception as e:  # noqa: BLE001 - said when its scenario runs here
                    send({'id': jid, 'line': 'the warm world did not start: %s: %s'
                          % (type(e).__name__, e)})
                    code = EXIT_ERROR
                send({'id': jid, 'exit': code})
                if host.broken:
                    break
                continue
            try:
                code = run_argv(job['argv'], warm=host,
                                out=lambda s, i=jid: send({'id': i, 'line': s}),
                                on_start=lambda i=jid: send({'id': i, 'started': True}))
            except Exception as e:  # noqa: BLE001 - the job is an ERROR, the worker lives on
                send({'id': jid, 'line': 'ERROR the warm worker failed: %s: %s'
                      % (type(e).__name__, e)})
                code = EXIT_ERROR
            send({'id': jid, 'exit': code})
            if host.broken:
                break                    # the pool starts a new worker for the rest
    finally:
        # the last scenario's apps: one deaf to its SIGINT held the farm's end for the
        # grace (the pool prints the line after its scenarios' results)
        for name, scenario in host.close():
            send({'note': procs.deaf_warning('app %s of scenario %s' % (name, scenario),
                                             ' (at the farm\'s end)')})
    return 0


# -- the farm's side ------------------------------------------------------------------------
class Pool(object):
    """Runs run_scenario command lines ``jobs`` at a time: in warm workers (default), or
    each in its own process (``warm=False``: a cold world per scenario, as before).
    ``run(items, done)``: items are (tag, argv); done(tag, code, text, wall) is called as
    each finishes. Warm: scenarios of the same world are dealt out one after another so a
    worker's world is reused; a worker that dies costs its scenario (an ERROR with its log
    tail) and is replaced."""

    def __init__(self, jobs, warm=True, env=None, python=None, spare=None):
        self.jobs = max(1, int(jobs))
        self.notes = []           # the workers' lines of no scenario (worker_main's end)
        self.warm = warm
        # a worker beyond ``jobs`` launching the next world (_deal). None: when the jobs
        # leave a CPU idle (--jobs 2 on 2 cores measured 13.8 s without it, 14.6 s with)
        if spare is None:
            spare = self.jobs < len(os.sched_getaffinity(0))
        self.spare = 1 if spare else 0
        self.env = dict(env or os.environ)
        self.env.pop('ROS_MASTER_URI', None)      # each worker/run starts its own master
        self.env.setdefault('ROS_HOSTNAME', 'localhost')
        self.python = python or sys.executable
        self.dir = tempfile.mkdtemp(prefix='warm_pool_')
        self.started = 0          # workers started (a dead one is replaced)
        self.unready = set()      # worlds a spare failed to launch (not tried ahead again)

    def run(self, items, done):
        try:
            if self.warm:
                return self._run_warm(sort_by_world(items), done)
            return self._run_cold(list(items), done)
        finally:
            if not os.environ.get('SCENARIO_KEEP_LOGS'):
                shutil.rmtree(self.dir, ignore_errors=True)

    def _run_cold(self, items, done):
        pending, running = list(items), []
        while pending or running:
            while pending and len(running) < self.jobs:
                tag, argv = pending.pop(0)
                p = subprocess.Popen([self.python, NODE] + list(argv), stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, env=self.env, text=True)
                running.append((tag, p, time.monotonic()))
            for item in list(running):
                tag, p, t0 = item
                if p.poll() is not None:
                    running.remove(item)
                    done(tag, p.returncode, p.stdout.read(), time.monotonic() - t0)
            time.sleep(0.02)

    def _run_warm(self, items, done):
        events = queue.Queue()
        pending = [(i, (tag, argv), key) for i, (key, tag, argv) in enumerate(items)]
        workers = []
        try:
            while pending or any(w.job is not None for w in workers):
                for w in [w for w in workers if not w.alive() and w.job is None]:
                    w.close()                    # died: its scenario is said; replaced
                    workers.remove(w)
                self._deal(pending, workers, events)
                try:
                    w, msg = events.get(timeout=1.0)
                except queue.Empty:
                    continue
                if msg is None:                           # the worker's output ended
                    if w.prep is not None:
                        self.unready.add(w.key)  # not launched ahead again (_deal)
                    w.prep = None
                    if w.job is not None:
                        (_i, (tag, _argv)), t0, lines = w.job, w.t0, w.lines
                        w.job = None
                        lines.append('ERROR the warm worker died (exit code %s)'
                                     % w.p.wait())
                        lines += ['  | ' + ln for ln in procs.tail(w.log_path, 15)]
                        done(tag, EXIT_ERROR, '\n'.join(lines) + '\n',
                             time.monotonic() - t0)
                    continue
                if w.prep is not None and msg.get('id') == w.prep and 'exit' in msg:
                    if msg['exit']:              # it will say why when a scenario of that
                        self.unready.add(w.key)  # world runs there; not launched ahead again
                    w.prep = None
                    continue
                if 'note' in msg:
                    self.notes.append(msg['note'])
                    continue
                if w.job is None or msg.get('id') != w.job[0]:
                    continue
                if 'line' in msg:
                    w.lines.append(msg['line'])
                elif 'started' in msg:
                    w.running = True
                elif 'exit' in msg:
                    (_i, (tag, _argv)), t0 = w.job, w.t0
                    text = '\n'.join(w.lines) + ('\n' if w.lines else '')
                    w.job = None
                    done(tag, int(msg['exit']), text, time.monotonic() - t0)
        finally:
            for w in workers:
                w.close()
            # what the workers said as they ended (their output is read to its end first)
            for w in workers:
                w.reader.join(5.0)
            while True:
                try:
                    _w, msg = events.get_nowait()
                except queue.Empty:
                    break
                if msg and 'note' in msg:
                    self.notes.append(msg['note'])

    def _deal(self, pending, workers, events):
        """Give idle workers scenarios, at most ``jobs`` running: first to a worker that has
        (or is launching) the scenario's world, then to any (it launches the world), then
        to new workers. Then the spare: one worker more than ``jobs`` launches the world
        of the next scenario no worker has, while the others run (a scenario then starts in
        a world that is ready); a worker whose world no pending scenario needs any more
        becomes that spare instead of a new one."""
        def idle():
            return [w for w in workers if w.job is None and w.alive()]

        def busy():
            return sum(w.job is not None for w in workers)
        for _i, _it, k in list(pending):                  # in the farm's order
            w = next((w for w in idle() if k is not None and w.key == k), None)
            if w is not None and busy() < self.jobs:
                w.give(*_pick(w, pending, workers))
        for w in idle():
            if busy() < self.jobs and pending:
                w.give(*_pick(w, pending, workers))
        while pending and busy() < self.jobs and len(workers) < self.jobs + self.spare and \
                all(w.job is not None for w in workers if w.alive()):
            w = self._new_worker(events, workers)
            w.give(*_pick(w, pending, workers))
        if not self.spare or not all(w.running for w in workers if w.job is not None):
            return                       # the spare starts while the others run, not start
        held = {w.key for w in workers if w.alive()} | self.unready
        nxt = next(((i, item, k) for i, item, k in pending if k is not None and k not in held),
                   None)
        if nxt is None:
            return
        needed = {k for _i, _it, k in pending}
        free = [w for w in idle() if w.prep is None and w.key not in needed]
        if free:
            free[0].prepare('p%d' % nxt[0], nxt[1][1], nxt[2])
        elif len([w for w in workers if w.alive()]) < self.jobs + self.spare:
            self._new_worker(events, workers).prepare('p%d' % nxt[0], nxt[1][1], nxt[2])

    def _new_worker(self, events, workers):
        w = _Worker(self, self.started, events)
        self.started += 1
        workers.append(w)
        return w


class _Worker(object):
    def __init__(self, pool, n, events):
        self.log_path = os.path.join(pool.dir, 'worker%d.log' % n)
        self.log = open(self.log_path, 'w')
        self.p = subprocess.Popen([pool.python, NODE, '--warm-worker'], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, stderr=self.log, env=pool.env,
                                  text=True, bufsize=1)
        self.job, self.t0, self.lines = None, 0.0, []
        self.key = None           # the world it has (or will have after its job)
        self.prep = None          # the id of the world it is launching (Pool._deal's spare)
        self.running = False      # its scenario reached sim time 0 (Pool._deal's spare)
        self.reader = threading.Thread(target=self._read, args=(events,), daemon=True)
        self.reader.start()

    def _read(self, events):
        for line in self.p.stdout:
            try:
                events.put((self, json.loads(line)))
            except ValueError:
                continue
        events.put((self, None))

    def alive(self):
        return self.p.poll() is None

    def give(self, i, item, key=None):
        self.job, self.t0, self.lines = (i, item), time.monotonic(), []
        self.running = False
        if key is not None:
            self.key = key
        self._send({'id': i, 'argv': list(item[1])})

    def prepare(self, i, argv, key):
        """Launch the world of command line ``argv`` now, to run its scenarios later."""
        self.prep, self.key = i, key
        self._send({'id': i, 'argv': list(argv), 'prepare': True})

    def _send(self, obj):
        try:
            self.p.stdin.write(json.dumps(obj) + '\n')
            self.p.stdin.flush()
        except OSError:
            pass        # it died just now: its output ends, and the pool says so (_run_warm)

    def close(self):
        try:
            self.p.stdin.close()
        except OSError:
            pass
        try:
            self.p.wait(30)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait(5)
        self.log.close()


def _pick(w, pending, workers):
    """The pending (i, item, key) worker ``w`` takes next: one on the world it has; else
    the first one on the world with the most pending scenarios per other worker that has
    it (a world no other worker has counts them all: each small world is launched once,
    a world with many scenarios gets more workers)."""
    for n, p in enumerate(pending):
        if p[2] is not None and p[2] == w.key:
            return pending.pop(n)
    holders, count = {}, {}
    for x in workers:
        if x is not w:
            holders[x.key] = holders.get(x.key, 0) + 1
    for p in pending:
        count[p[2]] = count.get(p[2], 0) + 1
    best = max(range(len(pending)), key=lambda n: (
        count[pending[n][2]] / (1.0 + holders.get(pending[n][2], 0)), -n))
    return pending.pop(best)


def sort_by_world(items):
    """(key, tag, argv) of the (tag, argv) items, those of one world next to each other
    (first-seen order of the worlds, the given order within each); key: the world's."""
    order, groups = [], {}
    for tag, argv in items:
        k = _key_of(argv)
        if k not in groups:
            order.append(k)
            groups[k] = []
        groups[k].append((k, tag, argv))
    return [it for k in order for it in groups[k]]


def _key_of(argv):
    """The world key of a run_scenario command line (None: not known, e.g. a bad file)."""
    from .command import world_key_of
    try:
        return repr(world_key_of(argv))
    except Exception:  # noqa: BLE001 - the run will say what is wrong
        return None
