"""The run's side of the world: its master and world started, its services, its processes
watched, its log.

A run's world is one of four kinds, told by the runner's options:

- **embedded** (the default, ``embed.py``): a ROS core of the run's own (``procs.Core``:
  rosmaster and rosout); the launch file's parameters set and its other nodes started; the
  World built in this process, whose node this process becomes (``init_node``), and stepped
  through its services as function calls;
- **launched** (``--world-node``, or a launch file that cannot be embedded): a ROS core of
  the run's own, and ``roslaunch --wait`` of the launch file on it;
- **warm** (a farm's worker, ``warm.WarmHost``): a master and a loaded world kept from the
  last scenario, reset for this one;
- **attached** (``--attach``, rostest): a world somebody else started; its seed and
  real-time factor are read from it (``settings``).

``connect`` waits for ``/gazebo/step_world`` and keeps one persistent proxy per service;
``check`` names the first part of it that is gone (the master, the world node, the embedded
world's thread) as the run's ERROR, with the log tail (``log_tail``); ``stop`` ends what the
run started (a warm world stays)."""
import os
import subprocess
import time

from sim_world.netutil import master_port, wait_for_service

from ..scenario.results import RunError
from . import procs
from .procs import poll, tail

__all__ = ['WorldSide', 'LAUNCHES', 'launch_args', 'start_pose', 'world_key']

PKG_ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                         '..', '..', '..', '..'))
MASTER_GRACE = 15.0    # s an attached run waits for ROS_MASTER_URI's master to answer
LAUNCHES = {
    'office': os.path.join(PKG_ROOT, 'sim_world', 'launch', 'office.launch'),
}


class WorldSide(object):
    def __init__(self, sc, run_dir, port=None, attach=False, embedded=False,
                 embed_required=False, warm=None, launch_args=None):
        """launch_args(): (launch file, [arguments]) of the scenario's world (the runner's,
        with the seed and real-time factor of the run)."""
        self.sc = sc
        self.run_dir = run_dir
        self.port = port
        self.attach = attach
        self.embedded = embedded
        self.embed_required = embed_required
        self.warm = warm
        self.launch_args = launch_args
        self.core = None           # procs.Core: the run's own master and rosout (not
                                   # attached, not warm)
        self.proc = None           # the world's process: roslaunch, the warm world's launch
        self.launch_procs = []     # embedded: the launch file's other nodes
        self.launch_plan = None    # embedded: embed.LaunchPlan
        self.host = None           # embedded: the sim_world WorldHost
        self.failed = []           # embedded: the world thread's exception, once it died
        self.logfile = None        # embedded: the world's log lines (embed.LogFile)
        self.watch = {}            # what (e.g. 'the world node /sim_world') -> pid
        self.rospy = None
        self.node = None           # the caller id serving /gazebo/step_world
        self.srv_types = {}
        self._proxies = {}

    # -- processes -------------------------------------------------------------------------
    def env(self):
        """The environment of the run's processes (its master, its log folder)."""
        return procs.ros_env(os.path.join(self.run_dir, 'log'),
                             None if self.attach else self.port)

    def master_uri(self):
        """The run's master; attached without ROS_MASTER_URI, rosgraph's default (as rospy
        would use)."""
        uri = self.env().get('ROS_MASTER_URI')
        if not uri:
            import rosgraph
            uri = rosgraph.get_master_uri()
        return uri

    def start(self, deadline):
        """Start (or reuse, or find) the master and the world; returns once the master
        answers. The world itself may still be loading (``connect`` waits for it)."""
        if self.warm is not None:
            return     # WarmHost.prepare, called by the runner once its node can be made
        if self.attach:
            self._find_attached(deadline)
            return
        if self.embedded and self._start_embedded(deadline):
            return
        path, args = self.launch_args()
        # roslaunch's Python start runs while the master starts (procs.Launch)
        self.proc = procs.Launch([path] + args, procs.launch_env(self.env(), self.run_dir),
                                 os.path.join(self.run_dir, 'world.log'))
        self.start_master(deadline)
        self._launch(deadline)

    def _find_attached(self, deadline, master_grace=MASTER_GRACE):
        """Attached: wait until ROS_MASTER_URI's master answers (at most ``master_grace``
        s) and lists /gazebo/step_world, before this process makes its node: roslaunch sets
        every parameter of its launch file (/use_sim_time among them) before it starts the
        world node, so the node then runs on sim time. (Made earlier, as when roslaunch and
        the run start together, rospy read no /use_sim_time and recorded the latched
        /gazebo/environment at its wall-clock time; with no master at all it retried for
        ever.)"""
        import rosgraph
        uri = self.master_uri()
        m = rosgraph.Master('/scenario_runner', master_uri=uri)
        seen, t0 = {}, time.monotonic()

        def world_up():
            try:
                m.getPid()
                seen['master'] = True
                return bool(m.lookupService('/gazebo/step_world'))
            except Exception:  # noqa: BLE001 - no master yet (OSError), no world (Failure)
                return False
        if poll(world_up, min(deadline, time.monotonic() + master_grace), first=0.005,
                most=0.1):
            return
        if not seen.get('master'):
            raise RunError('--attach: no ROS master answers at %s (ROS_MASTER_URI) within '
                           '%g s; start the world first (a .test file, or roslaunch of its '
                           'launch file with paused:=true), or run without --attach'
                           % (uri, master_grace))
        if not poll(world_up, deadline, first=0.005, most=0.1):
            raise RunError('--attach: the ROS master at %s lists no /gazebo/step_world '
                           'within %.0f s: no world to attach to'
                           % (uri, time.monotonic() - t0))

    def _launch(self, deadline):
        """``roslaunch --wait`` of the launch file on the run's master, once that master
        answers (on a port taken by another job's master it would set its parameters and
        start its nodes there). Returns once roslaunch has set the launch file's
        parameters (it sets them all before it starts its first node): the apps can start
        and read them while the world loads."""
        self.proc.go(self.master_uri())

        def first_node():
            return not self.proc.alive() or any(
                any(a.startswith('__name:=') for a in procs.cmdline(pid))
                for pid in procs.descendants(self.proc.p.pid)[1:])
        poll(first_node, deadline, first=0.005)

    def start_core(self):
        """The run's own master and rosout (procs.Core) on ``self.port``."""
        self.core = procs.Core(self.port, self.env(), self.run_dir)

    def wait_master(self, deadline):
        """Until the run's own master answers: it is the rosmaster this run started (its
        pid). A port taken meanwhile (another job's master answers there, or the rosmaster
        said it cannot bind) is an error at once: start_master tries a new port."""
        import rosgraph
        m = rosgraph.Master('/scenario_runner', master_uri=self.master_uri())
        t0 = time.monotonic()
        if self.core.wait_up(m, deadline):
            return m
        raise RunError(self.core.failure(time.monotonic() - t0), self.log_tail())

    def start_master(self, deadline, meanwhile=None):
        """The run's own master and rosout (procs.Core) on a free port (netutil.master_port:
        below the ephemeral range, where no outgoing connection takes it), once the master
        answers, with /use_sim_time set (``Core.up``): rospy reads it at init_node, else
        this node would time messages by the wall clock. ``meanwhile()`` runs once while
        the first master starts. Returns the master (rosgraph.Master)."""
        for attempt in (1, 2):
            if self.port is None or attempt == 2:
                self.port = master_port()
            self.start_core()
            if attempt == 1 and meanwhile is not None:
                meanwhile()
            try:
                m = self.wait_master(deadline)
                break
            except RunError:
                # the free port was taken by another process between the check and the
                # master's bind (parallel jobs): once more on a new port
                if attempt == 2 or time.monotonic() >= deadline:
                    raise
                self.core.stop(grace=2.0)
        self.core.up(m)
        self.watch.update(self.core.pids())
        return m

    def _start_embedded(self, deadline):
        """A master of its own, the launch file's parameters and other nodes; the world
        itself is built by init_node in this process (embed.py). False: the launch file
        cannot be embedded and --embedded was not asked for (the master is gone again)."""
        from .embed import plan_launch
        path, args = self.launch_args()

        def plan():
            # roslaunch's loader (xacro) runs while the master starts. The renderer's
            # imports (OpenCV, PyOpenGL: 0.2-0.6 s) start in the background once the phone
            # is spawned (sim_world.node._preload_renderer) and the first step that draws
            # waits for the rest: started here, beside the master, they lengthened the
            # master phase by as much as they saved (on 2 cores both are CPU-bound).
            self.launch_plan = plan_launch(path, args, self.port)
        m = self.start_master(deadline, meanwhile=plan)
        if self.launch_plan.world is None:
            if self.embed_required:
                raise RunError('--embedded: %s' % self.launch_plan.why)
            self.core.kill()
            self.core, self.embedded, self.port = None, False, None
            self.watch.clear()
            return False
        self.launch_plan.set_params(m)
        self.launch_procs = self.launch_plan.start_nodes(self.env(), self.run_dir)
        return True

    # -- this process's node ---------------------------------------------------------------
    def init_node(self, rospy, on_message):
        """This process's ROS node: embedded, the world node with the World in it (its
        messages handed to ``on_message`` in the world's thread); else /scenario_runner."""
        import rospy.core
        self.rospy = rospy
        if self.embedded:
            # one rospy process is one node: the runner is the world node (embed.py)
            argv = self.launch_plan.world_argv()
            # rospy takes a node's namespace from ROS_NAMESPACE or this process's own argv
            # when it is imported, never from init_node's argv (__ns:=): set it as
            # roslaunch's ROS_NAMESPACE would (not in the environment: the apps inherit it)
            from sim_world import transport
            transport.set_namespace(self.launch_plan.world_namespace())
            rospy.init_node(self.launch_plan.world.name, argv=argv, disable_signals=True)
            self._embed(argv, on_message)
        elif not rospy.core.is_initialized():    # a warm worker's runners share the node
            rospy.init_node('scenario_runner', disable_signals=True)

    def _embed(self, argv, on_message):
        """Build the launch file's world in this process and start its loop thread, as the
        sim_world executable does (sim_world.node)."""
        from sim_world.node import SetupError, host_from_params
        from .embed import LogFile
        self.logfile = LogFile(os.path.join(self.run_dir, 'world.log'))
        try:
            # the node's own argv: without its remappings, as rospy.myargv gives it
            self.host = host_from_params(self.rospy.myargv(argv))
        except SetupError as e:
            raise RunError('the embedded world %s: %s' % (self.launch_plan.world_name, e),
                           self.log_tail())
        except Exception as e:  # noqa: BLE001 - a plugin's failure while loading: the run's
            import traceback    # ERROR (the sim_world node would have died with it)
            raise RunError('the embedded world %s could not be built: %s: %s'
                           % (self.launch_plan.world_name, type(e).__name__, e),
                           self.log_tail() + traceback.format_exc().splitlines()[-12:])
        # the world's messages reach the intake in the world's own thread (no delivery thread
        # woken per message, no GIL hand-off): the runner waits for the step anyway
        from sim_world import transport
        transport.deliver_inline(on_message)
        _thread, self.failed = self.host.start()

    def settings(self):
        """Attached: (seed or None, real-time factor or None) of the running world."""
        try:
            seed = self.rospy.get_param('/sim_world/seed', '')
            rtf = self.rospy.get_param('/sim_world/real_time_factor', None)
            return (int(seed) if str(seed).strip() else None,
                    float(rtf) if rtf is not None else None)
        except (ValueError, TypeError, OSError):
            return None, None

    # -- the world's services --------------------------------------------------------------
    def connect(self, check):
        """Wait for /gazebo/step_world (``check()`` raises when a process is gone); the
        step and get-state proxies; the node serving them (``node``)."""
        from mobile_device_sim.srv import (DeleteModel, GetModelState, InjectTouch,
                                           PressButton, SetEnvironment, SetModelState,
                                           SetSensorFault, SpawnModel, StepWorld)
        self.srv_types = dict(step=StepWorld, get=GetModelState, set=SetModelState,
                              env=SetEnvironment, fault=SetSensorFault, spawn_urdf=SpawnModel,
                              spawn_sdf=SpawnModel, delete=DeleteModel, touch=InjectTouch,
                              button=PressButton)
        self.step_srv = self.proxy('/gazebo/step_world', StepWorld)
        self.get_state = self.proxy('/gazebo/get_model_state', GetModelState)
        if not wait_for_service('/gazebo/step_world', timeout=self.sc.timeout,
                                caller=self.rospy.get_name(), give_up=self.gone):
            check()
            raise RunError('the world did not offer /gazebo/step_world within %g s'
                           % self.sc.timeout, self.log_tail())
        import rosgraph
        try:
            _p, _s, services = rosgraph.Master('/scenario_runner').getSystemState()
            self.node = next((ns[0] for name, ns in services
                              if name == '/gazebo/step_world' and ns), None)
        except Exception:  # noqa: BLE001 - counted topics then fall back to a quiet period
            self.node = None
        return self.node

    def gone(self):
        """The world's process (roslaunch of a cold run, a warm world's) has exited."""
        return self.proc is not None and not self.proc.alive()

    def proxy(self, name, typ):
        """A persistent proxy of the world's service ``name``: one connection for the run
        (a new one per call cost a master lookup, a TCP handshake and a handler thread in
        the world: 30 % of a walking scenario's timeline), and no TIME_WAIT sockets for
        the app watch's /proc/net/tcp walks to step over."""
        if name not in self._proxies:
            local = None
            if self.embedded:       # the world's services are this process's: a call
                from sim_world.transport import local_service
                local = local_service(name)
            self._proxies[name] = local or self.rospy.ServiceProxy(name, typ,
                                                                   persistent=True)
        return self._proxies[name]

    def wait_phones(self, deadline, check):
        """Until the scenario's first phone model is in the world (the launch file's;
        ``check()`` raises when a process is gone). The others are spawned by the runner
        (``has_model`` tells it which an attached world has already)."""
        for ph in self.sc.phones[:1]:
            def there(ns=ph['ns']):
                check()
                return self.has_model(ns)
            if not poll(there, deadline, first=0.005, most=0.05):
                raise RunError('phone model %r did not appear' % ph['ns'], self.log_tail())

    def has_model(self, name):
        """Is model ``name`` in the world now?"""
        try:
            return bool(self.get_state(name, '').success)
        except Exception:  # noqa: BLE001 - a refused call, or the service not yet there
            return False

    def stopped(self):
        """After a failed step: give roslaunch the time to tear down after its node died."""
        if self.proc is not None:
            try:
                self.proc.p.wait(15.0)
            except subprocess.TimeoutExpired:
                pass

    # -- watching --------------------------------------------------------------------------
    def find_watched(self):
        """The master (procs.Core, or the warm worker's) and the world node below roslaunch:
        watched by pid (roslaunch keeps running when either dies)."""
        self.watch.update(self.warm.watched() if self.warm is not None
                          else procs.world_node(self.proc))
        if self.attach and self.node:
            pid = procs.local_node_pid(self.node)
            if pid is not None:        # a world on this machine: watched as a launched one
                self.watch['the world node %s' % self.node] = pid

    def world_pids(self):
        """The pids of the world's node (this process, embedded)."""
        return [os.getpid()] + [p for w, p in self.watch.items() if 'world' in w]

    def check(self, fault_t):
        """Every part of the world still there? An error naming the first one that is not,
        at sim time ``fault_t()``, with its log tail."""
        for what, pid in self.watch.items():
            if not procs.alive(pid):
                raise RunError('%s died at sim time %.3f s (%s, pid %d, is gone)' % (
                    'the ROS master' if 'master' in what else 'the world', fault_t(),
                    what, pid),
                    self.log_tail() + self._ros_log(what))
        if self.host is not None and self.failed:
            e = self.failed[0]
            raise RunError('the embedded world stopped at sim time %.3f s: %s: %s'
                           % (fault_t(), type(e).__name__, e), self.log_tail())
        if self.host is not None and self.rospy.is_shutdown():
            raise RunError('the world node %s (embedded in this run) was shut down at sim '
                           'time %.3f s (rosnode kill?)' % (self.launch_plan.world_name,
                                                            fault_t()), self.log_tail())
        if self.core is not None and not self.core.alive():
            raise RunError('the ROS master died at sim time %.3f s (exit code %s)'
                           % (fault_t(), self.core.master.p.returncode),
                           self.log_tail() + self._ros_log(procs.MASTER))
        if self.proc is not None and not self.proc.alive():
            raise RunError('the world died at sim time %.3f s (exit code %s)'
                           % (fault_t(), self.proc.p.returncode), self.log_tail())

    def any_gone(self):
        """Is the master or the world gone (roslaunch takes the master down with its
        required world)?"""
        return any(not procs.alive(pid) for pid in self.watch.values()) or self.gone()

    def interrupt(self, why):
        """The watchdog fired: unblock a step the world will never answer."""
        if self.host is not None:          # the embedded world's step
            self.rospy.signal_shutdown(why)
        if self.proc is not None:          # a step_world call
            self.proc.stop(grace=5.0)

    def log_tail(self):
        """The last lines of the world's log (the run's ERRORs show them)."""
        if self.logfile is not None:
            # the embedded world's lines, then the last ones of the launch file's other nodes
            # (what roslaunch's output would have shown after them)
            lines = self.logfile.tail()
            for p in self.launch_procs:
                lines += ['%s:' % os.path.basename(p.log_path)] + tail(p.log_path, 8)
            return lines
        if self.warm is not None:
            return self.warm.log_tail()
        if self.proc is not None:
            return tail(self.proc.log_path)
        if self.core is not None:            # a replay's: its master's output
            return self.core.log_tail()
        return []

    def _ros_log(self, what):
        """The log tail of the ROS log of a watched process (rosmaster: master.log)."""
        d = os.path.join(self.run_dir, 'log')
        key = 'master' if 'master' in what else what.rsplit('/', 1)[-1]
        lines = []
        for root, _dirs, files in os.walk(d):
            for f in sorted(files):
                if f.startswith(key) and f.endswith('.log'):
                    lines += ['%s:' % f] + tail(os.path.join(root, f), 10)
        return lines

    # -- the end ---------------------------------------------------------------------------
    def close_proxies(self):
        for px in self._proxies.values():
            px.close()                   # the persistent connections to the world

    def stop(self, apps):
        """End the run's processes: ``apps`` [(node name, Proc)] and what this side started.
        A warm world stays for the next scenario. Returns the names of the processes that
        did not end on their SIGINT and were SIGKILLed (procs.stop_run; a warm farm's
        leaving apps are waited for by the next scenario, WarmHost.settle, which says
        the ones it had to SIGKILL)."""
        killed = []
        if self.warm is not None:
            # the apps get SIGINT and leave the graph while the next scenario's reload and
            # apps start; their rospy exit (0.65 s) is not waited for (WarmHost.leave)
            self.warm.leave(apps, self.sc.name)
            self.warm.save_log(os.path.join(self.run_dir, 'world.log'))
        elif self.embedded:
            # the world is this process (it ends with it); its launch nodes and apps stop
            # as a run's apps do, the master goes at once
            killed = procs.stop_run(self.launch_procs + [p for _n, p in apps])
            if self.logfile is not None:
                self.logfile.close()     # its file stays for the log tails
        else:
            killed = procs.stop_run([p for _n, p in apps], self.proc,
                                    self.watch.get(procs.WORLD_NODE))
        if self.core is not None:        # the master and rosout go at once (nothing
            self.core.kill()             # of theirs is needed any more)
        names = {id(p): 'app %s' % n for n, p in apps}
        return [names.get(id(p)) or 'the launch node %s' % (
            getattr(p, 'node_name', None) or os.path.basename(p.cmd[0])) for p in killed or ()]


def launch_args(sc, seed, rtf, report=None):
    """(launch file, [its arguments]) of scenario ``sc``'s world: what makes the world
    (``world_key``) and what only sets its start (the seed, the real-time factor and the
    office phone's pose, which a warm world takes from /gazebo/reload_world)."""
    w = sc.world
    launch = w.get('launch', 'office')
    path = LAUNCHES.get(launch) or sc.resolve(launch)
    if not os.path.isfile(path):
        raise RunError('world.launch: no launch file %s (expected office or a path to a '
                       '.launch file)' % path)
    args = ['paused:=true', 'seed:=%d' % seed, 'real_time_factor:=%g' % rtf,
            'physics:=%s' % w.get('physics', 'ode')]
    if launch == 'office':
        # the report shows the spectator view: the flycam at 1 frame per sim second
        args += ['flycam:=true', 'flycam_rate:=1'] if report else ['flycam:=false']
        args += ['phone_%s:=%r' % kv for kv in sorted(start_pose(sc).items())]
    if 'max_step_size' in w:
        args.append('max_step_size:=%r' % w['max_step_size'])
    own = [a.split(':=', 1)[0] for a in args]
    for k, v in (w.get('args') or {}).items():
        args.append('%s:=%s' % (k, str(v).lower() if isinstance(v, bool) else v))
    _check_args(path, own, list(w.get('args') or {}))
    return path, args


def declared_args(path):
    """The names of the arguments launch file ``path`` declares (its ``<arg>``s, but for
    those given to an ``<include>``), or None when it cannot be read as XML (roslaunch
    then says what is wrong with it)."""
    import xml.etree.ElementTree as ET
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return None
    out = set()

    def walk(el):
        for c in el:
            if c.tag == 'include':
                continue
            if c.tag == 'arg' and c.get('name'):
                out.add(c.get('name'))
            walk(c)
    walk(root)
    return out


def _check_args(path, own, given):
    """RunError when launch file ``path`` does not declare an argument the run gives it:
    roslaunch ignores an undeclared command-line argument without a word, so a misspelt
    ``world.args`` entry (``given``) would leave the default, and a launch file without
    ``seed`` or ``paused`` (``own``: what run_scenario sets) an unseeded or running world."""
    import difflib
    declared = declared_args(path)
    if declared is None:
        return
    for name in given:
        if name not in declared:
            close = difflib.get_close_matches(name, sorted(declared), 1)
            raise RunError('world.args: %s is not an argument of %s, so roslaunch would '
                           'ignore it.%s Its arguments: %s.'
                           % (name, path, ' Did you mean %s?' % close[0] if close else '',
                              ', '.join(sorted(declared)) or 'none'))
    missing = [n for n in own if n not in declared]
    if missing:
        raise RunError('world.launch %s does not declare %s, which run_scenario sets (a '
                       "scenario's launch file declares paused, seed, real_time_factor and "
                       'physics%s)' % (path, ', '.join(missing),
                                       ', and max_step_size when the scenario sets it'
                                       if 'max_step_size' in missing else ''))


def start_pose(sc):
    """The office launch's phone_x, phone_y, phone_z, phone_yaw scenario ``sc`` sets."""
    if sc.world.get('launch', 'office') != 'office':
        return {}
    ph, pose = sc.phones[0], {}
    if 'position' in ph:
        pose.update(zip('xyz', ph['position']))
    if 'rpy' in ph:
        pose['yaw'] = ph['rpy'][2]
    return pose


def world_key(sc, report=None):
    """What a warm world must have been launched with to serve scenario ``sc``: its launch
    file and arguments, but for the seed, the real-time factor and the phone's pose."""
    path, args = launch_args(sc, 0, 1.0, report)
    return (os.path.abspath(path),) + tuple(
        a for a in args if not a.startswith(('seed:=', 'real_time_factor:=', 'phone_')))
