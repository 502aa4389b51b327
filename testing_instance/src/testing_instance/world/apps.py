"""The scenario's apps: black boxes in processes of their own (``apps:`` of a scenario).

``prestart`` starts the Python ones with the run (procs.PreApp: their imports overlap the
master's start and the world's loading, they talk to no master yet), ``launch`` lets them
go on once the run's master answers and starts the others; ``await_ready`` waits until
each is registered with the master and every subscription it has to a published topic is
connected, on the app's side and, for the world's topics, on the world's (a sensor publishes
only to the connections its publisher has: so no app misses the first slice);
``check`` tells an app that finished (exit code 0, said once) from one that crashed (the
run's ERROR, with its log tail); ``wait_answered`` waits, after each slice, until every app
has answered it (appwatch: evidence from /proc, not a quiet period)."""
import json
import os
import re
import time

from ..scenario.results import RunError
from .appwatch import AppHung, AppWatch
from .procs import PreApp, Proc, env_seconds, outbound, poll, tail

#: wall s an app may leave bytes unread on its connections before the run calls it hung
#: (the environment's MDS_APP_HANG_AFTER instead: the tests that wait it out set it small)
HANG_AFTER = env_seconds('MDS_APP_HANG_AFTER', 10.0)

__all__ = ['Apps', 'python_node']


def python_node(pkg, node_type):
    """The Python script a ``node: PKG/TYPE`` app runs, or None when it is not Python (a
    compiled node, a shell wrapper) or not among the package's installed executables
    (rosrun then finds it, or says why in the app's log). Looked for where rosrun and
    roslaunch look first, the package's libexec folder of the first workspace holding it
    (catkin's find_in_workspaces: 0.1 ms, where roslib's find_node walks the package's
    source tree as well, 110 ms); a catkin relay (``catkin_install_python``'s script in
    devel space) is followed to the script it runs. A Python node runs as a ``script:`` app
    does (procs.PreApp): started with the run, its libraries imported meanwhile, and gone a
    few seconds after a killed runner even when rospy's shutdown hangs
    (preapp.watch_runner), where rosrun's exec of it would leave it running."""
    try:
        from catkin.find_in_workspaces import find_in_workspaces
        dirs = find_in_workspaces(search_dirs=['libexec'], project=pkg,
                                  first_matching_workspace_only=True)
    except Exception:  # noqa: BLE001 - no catkin: rosrun finds it
        return None
    for d in dirs:
        path = os.path.join(d, node_type)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            try:
                with open(path, 'rb') as f:
                    head = f.read(4096)
            except OSError:
                return None
            if not (head.startswith(b'#!') and b'python' in head.split(b'\n', 1)[0]):
                return None
            relay = CATKIN_RELAY.search(head)
            if relay and os.path.isfile(relay.group(1).decode()):
                return relay.group(1).decode()
            return path
    return None


# what catkin's script.py.in writes in devel space for a catkin_install_python program
CATKIN_RELAY = re.compile(rb"^# generated from catkin/cmake/template/script\.py\.in\n"
                          rb"(?:#[^\n]*\n)*python_script = '([^'\n]+)'\n", re.M)


INFRA_TOPICS = {'/rosout', '/rosout_agg', '/clock'}


def _how(code):
    """How a process ended, from its return code (not 0)."""
    return 'killed by signal %d' % -code if code < 0 else 'exit code %d' % code


class Apps(object):
    def __init__(self, sc, env, run_dir, say, world=lambda: None, master_pid=lambda: None):
        """sc: the scenario; env(): the processes' environment (the run's master);
        run_dir: where each app's log goes (<name>.log); say(line): the run's output;
        world(): the world node's caller id (None: no world node, a replay);
        master_pid(): the pid of the run's own master (None: not this run's, --attach)."""
        self.sc = sc
        self.world = world
        self.master_pid = master_pid
        self.env = env
        self.run_dir = run_dir
        self.say = say
        self.procs = []            # [(node name, Proc)], the prestarted ones from prestart
        self._plan = None          # [(node name, script or None, args or command)]
        self.finished = set()
        self.watch = None          # AppWatch, once launched
        self.ready = False         # await_ready done: time may start

    def names(self):
        return {n for n, _p in self.procs}

    def prestart(self):
        """Start the Python apps' processes now (once), before the world is ready: they
        import what their scripts import and wait for ``launch`` (procs.PreApp). Every
        entry is checked first: a bad one starts no app at all (RunError)."""
        if self._plan is not None:
            return
        plan = []
        for i, app in enumerate(self.sc.apps):
            name = app.get('name', 'app%d' % i)
            params = ['_%s:=%s' % (k, json.dumps(v) if not isinstance(v, str) else v)
                      for k, v in (app.get('params') or {}).items()]
            args = [str(a) for a in app.get('args') or []] + params + ['__name:=%s' % name]
            if 'script' in app:
                script = self.sc.resolve(app['script'])
                if not os.path.isfile(script):
                    raise RunError('apps[%d].script: no file %s' % (i, script))
                plan.append(('/' + name, script, args))
            else:
                pkg, _, typ = app['node'].partition('/')
                script = python_node(pkg, typ)
                plan.append(('/' + name, script, args) if script else
                            ('/' + name, None, ['rosrun', pkg, typ] + args))
        self._plan = plan
        for name, script, args in plan:
            if script is not None:
                self.procs.append((name, PreApp(script, args, self.env(),
                                                self._log(name), cwd=self.sc.dir)))

    def _log(self, name):
        return os.path.join(self.run_dir, '%s.log' % name.lstrip('/'))

    def launch(self, own_pending, others=lambda: ()):
        """Start every app (once), on the run's master, which answers now: the prestarted
        ones go on, the others (``node:``) start. own_pending(queues): why this process
        still holds app messages not yet delivered; others(): [(name, pid)] of processes
        whose threads must be idle too (AppWatch). Returns the Procs."""
        if self.watch is not None or not self.sc.apps:
            return []
        self.prestart()
        uri = self.env()['ROS_MASTER_URI']
        early = iter([p for _n, p in self.procs])      # in the plan's order
        procs = []
        for name, script, cmd in self._plan:
            if script is not None:
                p = next(early)
                p.go(uri)
            else:
                p = Proc(cmd, self.env(), self._log(name), cwd=self.sc.dir)
            procs.append((name, p))
        self.procs = procs
        self.watch = AppWatch(self.procs, own_pending, warn=self.say, others=others,
                              hang_after=HANG_AFTER)
        return [p for _n, p in self.procs]

    def await_ready(self):
        """Wait until every app is registered with the master and connected."""
        if not self.procs:
            self.ready = True
            return
        import rosgraph
        names = list(self.procs)
        m = rosgraph.Master('/scenario_runner')
        deadline = time.monotonic() + min(self.sc.timeout, 60.0)

        def registered():
            pubs, subs, _srv = m.getSystemState()
            nodes = {n for _t, ns in pubs + subs for n in ns}
            for n, p in list(names):
                if not p.alive():
                    raise RunError('app %s exited at start (%s)' % (n, _how(p.p.returncode)),
                                   tail(p.log_path))
                if n in nodes:
                    names.remove((n, p))
            return not names
        poll(registered, deadline, first=0.005)
        if names:
            raise RunError('app(s) %s did not register with the master within 60 s'
                           % ', '.join(n for n, _p in names),
                           sum((tail(p.log_path) for _n, p in names), []))
        self._wait_connections(m, deadline)
        self.ready = True

    def _wait_connections(self, master, deadline):
        """Wait until every app is set up: each subscription of its to a published topic
        connected (asked through each node's slave API, getBusInfo), so no app misses the
        first slice, and then, by evidence, nothing more coming: the apps' topics unchanged
        from one look to the next while the apps and the run's master did nothing in
        between (AppWatch.ran_since: no thread of theirs ran, nothing queued on their
        connections). A fixed quiet period (20 ms of unchanged topics, until 2026-11-29)
        took an app starved of the CPU between its publisher and its subscribers, or waiting
        for the master's answer to its registration, for one that was set up. Connected
        means on the app's side and, for a topic the world publishes, on the world's side
        too: the app's side is done once the world's answer to its connection header has
        arrived, the world adds the connection to its publisher only after writing that
        answer, and a sensor publishes to the connections its publisher has."""
        t_start = time.monotonic()
        last_topics, missing, before, settled = None, [], None, None
        master_pid = self.master_pid()
        extra = [('the ROS master (pid %d)' % master_pid, master_pid)] if master_pid else []
        while time.monotonic() < deadline:
            # what the apps and the master did since the last look (before this look's
            # calls, which make the master run)
            busy = self.watch.ran_since(before, extra) if before is not None else True
            pubs, subs, _srv = master.getSystemState()
            topics = {(node, t) for node in self._nodes() for t, ns in pubs + subs
                      if node in ns and t not in INFRA_TOPICS}
            if missing or topics != last_topics:
                missing = self._missing(master, pubs, subs, topics, t_start)
                settled = None
            elif not busy:
                return
            elif settled is None:
                settled = time.monotonic()
            elif time.monotonic() - settled >= self.watch.limit:
                # connected, its topics unchanged, yet at work (a loop by the wall clock,
                # a spin): the slices' app watch takes it from here, as it does any app
                # that never falls idle
                self.say('WARNING %s at work after %.1f s with its topics unchanged; time '
                         'starts' % (', '.join('app %s' % n if n.startswith('/') else n
                                               for n, _w in busy),
                                     time.monotonic() - settled))
                return
            last_topics = topics
            before = self.watch.reading(extra)       # after this look's calls
            # a fixed 20 ms between looks, not procs.poll's backoff: an app that sleeps a
            # few ms between its registrations is not taken for set up either
            time.sleep(0.02)
        # said, not silent: such an app may miss the first messages
        self.say('WARNING %s not set up within %.0f s of wall time (%s); time starts anyway'
                 % (', '.join('app %s' % n for n in sorted(missing)) or 'the apps',
                    time.monotonic() - t_start,
                    'subscriptions not connected' if missing else
                    'still registering or at work'))

    def _nodes(self):
        return {'/' + app.get('name', 'app%d' % i) for i, app in enumerate(self.sc.apps)}

    def _missing(self, master, pubs, subs, topics, t_start):
        """The apps whose subscriptions to published topics are not connected yet (both
        sides, see _wait_connections), or that have no topics of their own yet (rospy
        registers /rosout and /clock at init_node, before the app's code runs; 5 s grace
        for apps without topics)."""
        from xmlrpc.client import ServerProxy
        world = self.world()
        published = {t for t, _n in pubs}
        of_world = {t for t, ns in pubs if world in ns}
        served = []                # [the world's outbound connections], once asked
        missing = []
        for node in self._nodes():
            if not any(n == node for n, _t in topics) and time.monotonic() - t_start < 5.0:
                missing.append(node)
                continue
            want = {t for t, ns in subs if node in ns and t in published}
            if not want:
                continue
            try:
                code, _msg, info = ServerProxy(master.lookupNode(node)).getBusInfo(
                    '/scenario_runner')
            except Exception:  # noqa: BLE001 - node not answering yet
                missing.append(node)
                continue
            have = {c[4] for c in info if len(c) > 4 and c[2] in ('i', 'in')}
            if want - have:
                missing.append(node)
                continue
            if want & of_world:
                if not served:
                    served.append(self._served(master, world))
                if served[0] is not None and {(node, t) for t in want & of_world} - served[0]:
                    missing.append(node)
        return missing

    @staticmethod
    def _served(master, world):
        """{(subscriber, topic)} of the world node's outbound connections (getBusInfo), or
        None when the world node does not answer (it is gone: the run's checks say so)."""
        from xmlrpc.client import ServerProxy
        try:
            return outbound(ServerProxy(master.lookupNode(world)), '/scenario_runner')
        except Exception:  # noqa: BLE001 - the world node is gone
            return None

    def check(self, t, fault_t):
        """An app that exited: code 0 has finished (said once, at sim time ``t``); any other
        code or a signal is the run's ERROR at ``fault_t()``, with its log tail: one that
        exited before time started (the run's checks while the world loads) "exited at
        start", as await_ready says it (a node rosrun could not find: its words)."""
        for name, p in self.procs:
            code = p.p.poll()
            if code is None or name in self.finished:
                continue
            if code == 0:
                self.finished.add(name)
                self.say('app %s finished at sim time %.3f s (exit code 0)' % (name, t))
                continue
            if not self.ready:
                raise RunError('app %s exited at start (%s)' % (name, _how(code)),
                               tail(p.log_path))
            raise RunError('app %s crashed at sim time %.3f s (%s)'
                           % (name, fault_t(), _how(code)), tail(p.log_path))

    def wait_answered(self, wake):
        """After a slice: until every app has answered it (AppWatch.wait; ``wake(s)``: wait
        up to s for the next message to arrive). A hung app: the run's ERROR."""
        if self.watch is None:
            return
        try:
            self.watch.wait(wake)
        except AppHung as e:
            p = dict(self.procs).get(e.name)
            raise RunError(str(e), tail(p.log_path) if p else [])

    @property
    def waited(self):
        """Wall s spent waiting for the apps to answer, or None without apps."""
        return None if self.watch is None else self.watch.waited
