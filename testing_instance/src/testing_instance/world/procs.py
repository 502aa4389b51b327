"""Child processes of a run (its ROS core, the world, the scenario's apps) and port allocation."""
import os
import platform
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import uuid
import xmlrpc.client

from sim_world.netutil import free_port  # noqa: F401 - the one copy, re-exported

__all__ = ['Core', 'Launch', 'PreApp', 'Proc', 'STOP_GRACE', 'launch_env', 'stop_run', 'age',
           'alive', 'cmdline', 'deaf_warning', 'descendants', 'first_run', 'free_port',
           'frozen_tree', 'kill_tree', 'outbound',
           'read_chars', 'ros_env', 'rss_kb', 'socket_inodes', 'state', 'tail',
           'receivers_busy', 'tcp_queues', 'TcpQueues', 'thread_runs', 'thread_states',
           'world_node']


def outbound(node, caller):
    """{(subscriber, topic)} of a node's outbound connections: its publishers' subscribers
    as the node itself counts them (``node``: an xmlrpc ServerProxy of its slave API,
    asked getBusInfo as ``caller``). Raises what the call raises (the node is gone)."""
    _c, _m, info = node.getBusInfo(caller)
    return {(c[1], c[4]) for c in info if len(c) > 4 and c[2] == 'o'}


def poll(cond, deadline, first=0.001, most=0.02):
    """Wait until ``cond()`` is true or the monotonic ``deadline`` passes, looking again
    after ``first`` s, then twice as long each time up to ``most`` s: what is ready in a
    few ms (a local connection) is seen in a few ms, what takes long costs a look every
    ``most`` s. For what only a look can tell (another node's state through its XML-RPC
    API, a TCP connection of rospy's, which has no event). Returns the last cond()."""
    wait = first
    while True:
        ok = cond()
        if ok or time.monotonic() >= deadline:
            return ok
        time.sleep(min(wait, max(0.0, deadline - time.monotonic())))
        wait = min(wait * 2, most)


def ros_env(log_dir, port=None):
    """The environment of a run's processes: this one's, with the master on ``port`` of
    localhost (None: keep ROS_MASTER_URI, an attached run), ROS_HOSTNAME defaulting to
    localhost, the ROS logs in ``log_dir``, unbuffered Python output."""
    env = dict(os.environ)
    if port is not None:
        env['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    env.setdefault('ROS_HOSTNAME', 'localhost')
    env['ROS_LOG_DIR'] = log_dir
    env['PYTHONUNBUFFERED'] = '1'
    return env


def tail(path, n=25):
    try:
        with open(path, errors='replace') as f:
            return [ln.rstrip('\n') for ln in f.readlines()[-n:]]
    except OSError:
        return []


try:                      # resolved now: the child between fork and exec must not import
    import ctypes
    _prctl = ctypes.CDLL(None, use_errno=True).prctl
except (OSError, AttributeError):  # pragma: no cover - not Linux
    _prctl = None


def _term_with_parent():
    """In the child before exec: SIGTERM when the runner dies (even by SIGKILL), so a
    killed runner (a Ray node removed, a CI job cancelled) leaves no world behind;
    roslaunch takes SIGTERM as a shutdown and stops its nodes."""
    if _prctl is not None:
        _prctl(1, int(signal.SIGTERM))                   # PR_SET_PDEATHSIG


class Proc(object):
    """A child process in its own process group, output to a log file; it gets SIGTERM
    when the process that started it dies."""

    def __init__(self, cmd, env, log_path, cwd=None, stdin=subprocess.DEVNULL):
        self.cmd = cmd
        self.log_path = log_path
        self.log = open(log_path, 'w')
        self.p = subprocess.Popen(cmd, env=env, stdout=self.log, stderr=subprocess.STDOUT,
                                  stdin=stdin, start_new_session=True, cwd=cwd,
                                  preexec_fn=_term_with_parent)

    def alive(self):
        return self.p.poll() is None

    def stop(self, grace=10.0):
        self.interrupt()
        self.finish(time.monotonic() + grace)

    def interrupt(self):
        """SIGINT to its process group (the app's rospy shuts down in order)."""
        if self.p.poll() is None:
            try:
                os.killpg(self.p.pid, signal.SIGINT)
            except OSError:
                pass

    def finish(self, deadline):
        """Wait for it until deadline (monotonic), then SIGKILL its group; close its log.
        True when it had to be SIGKILLed."""
        killed = False
        if self.p.poll() is None:
            try:
                self.p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                killed = True
                try:
                    os.killpg(self.p.pid, signal.SIGKILL)
                except OSError:
                    pass
                self.p.wait(5)
        self.log.close()
        if self.p.stdin is not None:
            try:
                self.p.stdin.close()
            except OSError:
                pass
        return killed


class _TimedTransport(xmlrpc.client.Transport):
    def __init__(self, timeout):
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        conn = super().make_connection(host)
        conn.timeout = self.timeout
        return conn


def master_pid(master, timeout=2.0):
    """The pid the master at ``master`` (rosgraph.Master) answers with, asked with a
    socket timeout: a port taken by another node's TCPROS server accepts the call and
    never answers it (rosgraph.Master's own calls have no timeout). Anything without a
    ``master_uri`` (a test's stand-in) is asked by its ``getPid()``."""
    uri = getattr(master, 'master_uri', None)
    if uri is None:
        return master.getPid()
    proxy = xmlrpc.client.ServerProxy(uri, transport=_TimedTransport(timeout))
    code, msg, pid = proxy.getPid(master.caller_id)
    if code != 1:
        raise RuntimeError(msg)
    return pid


class Core(object):
    """A ROS master and rosout of a run's own (embedded, ``--world-node``, a replay, a warm
    worker), started directly instead of by ``roscore``. roscore is a roslaunch: it runs
    ``rosversion`` twice, starts rosmaster, looks for it every 0.1 s, then starts rosout:
    0.61 s here from the command to rosout's /rosout_agg, against 0.15 s for the two
    started directly (bench/scenario prints the start-up's master phase).

    rosout is started with /use_sim_time remapped to a name nobody sets: a roscpp node reads
    /use_sim_time once, as it starts, and subscribes to /clock when it is true, and rosout
    needs no sim time (it passes the log lines' own stamps on). Each /clock tick it took cost
    the world's thread about 80 us (a recorded 20 s sensors scenario's timeline 1.72-1.82 s
    with it, 1.50-1.54 s without); whether roscore's rosout took it was a race with whoever
    set /use_sim_time. The remap makes /use_sim_time free to set as soon as the master
    answers (``up``).

    The parameters roscore sets are set too (/run_id, /rosdistro, /rosversion)."""

    ROSOUT_NO_SIM_TIME = '/use_sim_time:=/rosout/no_sim_time'

    def __init__(self, port, env, run_dir):
        self.port = port
        self.env = env
        self.run_dir = run_dir
        self.master = Proc(['rosmaster', '--core', '-p', str(port), '-w', '3'], env,
                           os.path.join(run_dir, 'rosmaster.log'))
        self.rosout = None
        self.taken = None        # wait_up found the port taken: how (a line)

    def alive(self):
        """The master is running (rosout is not watched: nothing of a run needs it)."""
        return self.master.alive()

    #: what rosmaster prints when its port is taken (rosgraph.xmlrpc); it does not exit
    #: then: its main thread waits for the server's URI for ever, 20 % of a core busy
    PORT_TAKEN = 'Unable to start XML-RPC server'

    def wait_up(self, master, deadline):
        """Until ``master`` (rosgraph.Master on this core's port) answers with the pid of
        this core's rosmaster; False at ``deadline``, once the rosmaster has exited, or
        once its port is known to be taken (``port_taken``): another job's master answers
        there, or the rosmaster said it could not bind. A rosmaster whose port is taken
        does not exit: without these looks the run waited until its deadline (120 s)."""
        answered = []
        self.taken = None

        def done():
            if not self.alive():
                return True
            said = self.port_taken()
            if said:
                self.taken = said
                return True
            try:
                pid = master_pid(master)
            except Exception:  # noqa: BLE001 - not up yet
                pid = None
            if pid == self.master.p.pid:
                answered.append(True)
                return True
            if pid is not None:
                self.taken = 'another master (pid %s) answers there' % pid
                return True
            return False
        poll(done, deadline, first=0.005)
        return bool(answered)

    def failure(self, waited, whose='the ROS master'):
        """Why ``wait_up`` returned False, as one sentence on ``whose`` master (the run's,
        or a warm worker's): how its port was found taken, that it exited, or the ``waited``
        seconds it did not answer in. The one wording for every caller."""
        if self.taken:
            return '%s could not take port %d: %s' % (whose, self.port, self.taken)
        if not self.alive():
            return '%s exited while starting (code %s)' % (whose, self.master.p.poll())
        return '%s did not answer on port %d in %.1f s' % (whose, self.port, waited)

    def port_taken(self):
        """The line in which the rosmaster said it could not start its server (its port is
        in use, or another socket error), or None."""
        try:
            with open(self.master.log_path, errors='replace') as f:
                text = f.read(4096)
        except OSError:
            return None
        for line in text.splitlines():
            if self.PORT_TAKEN in line:
                return line.replace('ERROR: ', '', 1).strip()
        return None

    def up(self, master):
        """The master (rosgraph.Master) answers: set /use_sim_time and roscore's
        parameters, start rosout."""
        master.setParam('/use_sim_time', True)
        master.setParam('/run_id', str(uuid.uuid1()))
        try:
            import rospkg
            import rospkg.distro
            master.setParam('/rosdistro', '%s\n' % rospkg.distro.current_distro_codename())
            master.setParam('/rosversion', '%s\n' % rospkg.RosPack().get_manifest(
                'roslaunch').version)
        except Exception:  # noqa: BLE001 - informational only (rosversion's own values)
            pass
        self.rosout = Proc([rosout_path(), '__name:=rosout', self.ROSOUT_NO_SIM_TIME],
                           self.env, os.path.join(self.run_dir, 'rosout.out'))

    def pids(self):
        return {MASTER: self.master.p.pid}

    def stop(self, grace=2.0):
        """A master that did not come up (its port was taken): gone within ``grace`` s."""
        self.master.stop(grace=grace)
        if self.rosout is not None:
            self.rosout.stop(grace=grace)

    def kill(self):
        """SIGKILL rosout and the master at once, and wait for both."""
        for p in (self.rosout, self.master):
            if p is not None:
                kill_tree(p)

    def log_tail(self, n=25):
        return tail(self.master.log_path, n)


EMPTY_ROSCORE = """<launch>
  <!-- roslaunch on a run's own core (procs.Core): no rosout, no rosversion commands -->
</launch>
"""


#: the child of Launch: roslaunch's imports first, then its master's URI from stdin
#: (testing_instance.world.preapp.until_told, as a prestarted app waits)
PRELAUNCH = """\
import sys
sys.path.insert(0, %r)          # testing_instance/src: this package, nothing else
from testing_instance.world.preapp import until_told
until_told(lambda: __import__('roslaunch'))
import roslaunch
sys.argv[0] = 'roslaunch'
roslaunch.main()
""" % os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


class _Told(Proc):
    """A Python process that imports what it needs at once and then waits, talking to no
    master, until :meth:`go` gives it the URI of the run's master. Without ``go`` (the
    runner failed or died first) it exits on its own when its stdin closes, or with the
    run's other processes."""

    def __init__(self, cmd, env, log_path, cwd=None):
        Proc.__init__(self, cmd, env, log_path, cwd=cwd, stdin=subprocess.PIPE)

    KEEP_STDIN = False

    def go(self, master_uri):
        """Go on, on master_uri (the run's own master, up and checked). A PreApp's stdin
        then stays open until :meth:`finish` (preapp.watch_runner: its closing without a
        finish means the runner died)."""
        try:
            self.p.stdin.write((master_uri + '\n').encode())
            if self.KEEP_STDIN:
                self.p.stdin.flush()
            else:
                self.p.stdin.close()
        except OSError:
            pass          # it exited meanwhile: the run's check reports it with its log


class Launch(_Told):
    """``roslaunch --wait --skip-log-check ARGS`` whose Python start runs while the run's
    master starts. roslaunch's imports take 0.3-0.45 s; roslaunch was started only once the
    master answered, because a roslaunch started earlier could find another job's master on
    a port taken between free_port and the bind. This process imports roslaunch at once and
    then waits for :meth:`go`: it talks to no master until it is given the URI of the one
    this run has checked is its own (Core.wait_up)."""

    def __init__(self, args, env, log_path):
        _Told.__init__(self, [sys.executable, '-c', PRELAUNCH, '--wait', '--skip-log-check']
                       + list(args), env, log_path)


PREAPP = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'preapp.py')


class PreApp(_Told):
    """A scenario's Python app (``script`` with its command-line ``args``), started before
    the run's world is ready: it imports what the script imports at its top, then waits for
    :meth:`go` and runs the script (testing_instance.world.preapp). Its stdin stays open while
    it runs: it is SIGKILLed a few seconds after the runner dies (preapp.watch_runner)."""

    KEEP_STDIN = True

    def __init__(self, script, args, env, log_path, cwd=None):
        _Told.__init__(self, [sys.executable, PREAPP, script] + list(args), env, log_path,
                       cwd=cwd)


def launch_env(env, run_dir):
    """The environment of a ``roslaunch --wait`` on a run's Core. roslaunch reads
    roscore.xml (ROS_ETC_DIR's first) even when it starts no master, and runs its two
    ``rosversion`` commands for /rosversion and /rosdistro (0.21 s), which Core.up sets: its
    ROS_ETC_DIR here holds an empty roscore.xml. The logging configuration stays the one
    rospy would find (ROS_HOME's config, then the ROS_ETC_DIR it had), named by
    ROS_PYTHON_LOG_CONFIG_FILE unless that is set already."""
    import rospkg
    env = dict(env)
    etc = os.path.join(run_dir, 'etc_ros')
    path = os.path.join(etc, 'roscore.xml')
    if not os.path.exists(path):
        os.makedirs(etc, exist_ok=True)
        with open(path, 'w') as f:
            f.write(EMPTY_ROSCORE)
    if not env.get('ROS_PYTHON_LOG_CONFIG_FILE'):
        for d in (os.path.join(rospkg.get_ros_home(env), 'config'),
                  rospkg.get_etc_ros_dir(env)):
            found = [os.path.join(d, 'python_logging.' + ext) for ext in ('conf', 'yaml')
                     if os.path.isfile(os.path.join(d, 'python_logging.' + ext))]
            if found:
                env['ROS_PYTHON_LOG_CONFIG_FILE'] = found[0]
                break
    env['ROS_ETC_DIR'] = etc
    return env


def rosout_path():
    """The rosout executable (Debian: /usr/lib/rosout/rosout), found as roslaunch finds it."""
    global _ROSOUT
    if _ROSOUT is None:
        import roslib.packages
        found = roslib.packages.find_node('rosout', 'rosout')
        if not found:
            raise RuntimeError('rosout is not installed (no rosout executable of package '
                               'rosout)')
        _ROSOUT = found[0]
    return _ROSOUT


_ROSOUT = None


def env_seconds(name, default):
    """A duration in s from the environment variable ``name``: ``default`` when it is unset,
    and also when it is not a finite number > 0, then with one line on stderr naming the
    variable and its value (a bad knob must not stop the run with a traceback at import)."""
    text = os.environ.get(name)
    if text is None:
        return default
    try:
        v = float(text)
    except ValueError:
        v = float('nan')
    if not (v > 0 and v != float('inf')):
        sys.stderr.write('%s=%r is not a number of seconds > 0; using %g\n'
                         % (name, text, default))
        return default
    return v


#: s a run's processes have to end on their SIGINT, then SIGKILL (the environment's
#: MDS_STOP_GRACE instead: the tests that wait it out on purpose set it small)
STOP_GRACE = env_seconds('MDS_STOP_GRACE', 10.0)


def deaf_warning(who, after=''):
    """The run's line for a process that outlived its SIGINT by STOP_GRACE and was SIGKILLed
    (``who``: 'app /x', 'app /x of scenario s', 'the launch node /y'; ``after``: what
    follows, e.g. ' (this start-up waited for it)')."""
    return ('WARNING %s did not end within %g s of its SIGINT: SIGKILLed with its process '
            'group%s' % (who, STOP_GRACE, after))


def stop_run(apps, launch=None, node=None, grace=STOP_GRACE):
    """Stop a run's processes together: every app (its group gets SIGINT) and the world
    node (pid ``node``, below the roslaunch Proc ``launch``) at once, each shutting down in
    order; then the rest of the launch tree (roslaunch, rosmaster, rosout: they hold
    nothing a run needs) is SIGKILLed instead of shut down one node after the other, as
    roslaunch does (1.5 s of every run's 2.2 s teardown). Without a node, the launch gets
    SIGINT like an app. Anything alive at ``grace`` s is SIGKILLed. Returns the apps that
    were (said by the run: they did not end on their SIGINT)."""
    deadline = time.monotonic() + grace
    tree = []
    for p in apps:
        p.interrupt()
    if launch is not None:
        if node is not None and alive(node) and launch.alive():
            tree = descendants(launch.p.pid)
            try:
                os.kill(node, signal.SIGINT)
            except OSError:
                pass
        else:
            launch.interrupt()
    killed = [p for p in apps if p.finish(deadline)]
    if launch is None:
        return killed
    if tree:
        while alive(node) and time.monotonic() < deadline:
            time.sleep(0.01)
        # roslaunch first (stopped, then killed): it would restart a respawn="true" node
        # killed before it; the tree is listed again (what it started meanwhile)
        _kill_all([node] + [q for q in frozen_tree(launch.p.pid, tree) if q != node
                            and alive(q)])
    launch.finish(deadline if not tree else time.monotonic() + 5.0)
    return killed


def frozen_tree(pid, also=()):
    """Stop ``pid`` (SIGSTOP) and wait, up to 1 s, until it is stopped: then it cannot
    start anything new (roscore and roslaunch respawn a respawn="true" node, such as
    roscore's rosout, as soon as it dies). Returns pid, then every process below it, then
    those of ``also`` not among them (listed earlier: they may have been reparented)."""
    try:
        os.kill(pid, signal.SIGSTOP)
    except OSError:
        pass
    deadline = time.monotonic() + 1.0
    while state(pid) not in (None, 'T', 't', 'Z', 'X') and time.monotonic() < deadline:
        time.sleep(0.001)
    tree = descendants(pid)
    return tree + [p for p in also if p not in tree]


def _kill_all(pids):
    """SIGKILL each pid in order (the root first: it cannot restart the others)."""
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


def kill_tree(proc):
    """SIGKILL ``proc`` and every process below it; wait for it. ``proc`` is stopped and
    killed first: killing roscore's rosout before roscore let roscore start a new one,
    left behind once roscore was killed (seen once, an orphaned rosout)."""
    tree = frozen_tree(proc.p.pid)
    _kill_all(tree)
    proc.finish(time.monotonic() + 5.0)
    deadline = time.monotonic() + 5.0     # its sockets are closed once each one is gone
    while any(alive(pid) for pid in tree) and time.monotonic() < deadline:
        time.sleep(0.005)


# -- what /proc says about a process tree (the runner's evidence about apps) ----------------
def children_map():
    """{pid: [child pids]} of every process (read from /proc)."""
    kids = {}
    for d in os.listdir('/proc'):
        if not d.isdigit():
            continue
        try:
            with open('/proc/%s/stat' % d, 'rb') as f:
                ppid = int(f.read().rsplit(b')', 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        kids.setdefault(ppid, []).append(int(d))
    return kids


def last_pid():
    """The last process or thread id the kernel handed out (the last field of
    /proc/loadavg), or None: while it stays the same, no process was created."""
    try:
        with open('/proc/loadavg', 'rb') as f:
            return int(f.read().split()[-1])
    except (OSError, ValueError, IndexError):
        return None


class ProcessTree(object):
    """children_map(), scanned again only once a process (or thread) was created since
    the last scan (last_pid). A scan reads every /proc/PID/stat of the machine: 1.1 ms
    with 65 processes, and the app watch looks every 2 ms while an app works. A process
    that exited stays in the map: its /proc files are gone, and its pid is not reused
    without a new id being handed out."""

    def __init__(self):
        self.mark = None
        self.kids = None

    def children(self):
        mark = last_pid()             # before the scan: one made meanwhile rescans next time
        if self.kids is None or mark is None or mark != self.mark:
            self.kids, self.mark = children_map(), mark
        return self.kids


def descendants(pid, kids=None):
    """pid and every process below it."""
    kids = children_map() if kids is None else kids
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(kids.get(p, ()))
    return out


def carrying(marker):
    """[(pid, command line)] of the processes (this one excepted) whose environment holds
    ``marker`` (a string set in the environment of a run: what it left behind)."""
    out = []
    for d in os.listdir('/proc'):
        if d.isdigit() and int(d) != os.getpid():
            try:
                with open('/proc/%s/environ' % d, 'rb') as f:
                    if marker.encode() not in f.read():
                        continue
            except OSError:
                continue
            out.append((int(d), ' '.join(cmdline(int(d)))[:120]))
    return out


MASTER = 'the ROS master (rosmaster)'
WORLD_NODE = 'the world node /sim_world'


def world_node(proc):
    """{WORLD_NODE: pid} of the sim_world node below ``proc`` (a roslaunch Proc, or None),
    to be watched by pid (roslaunch keeps running when its node dies)."""
    if proc is None:
        return {}
    for pid in descendants(proc.p.pid)[1:]:
        if '__name:=sim_world' in cmdline(pid):
            return {WORLD_NODE: pid}
    return {}


def local_node_pid(name, master=None):
    """The pid of ROS node ``name`` when it runs on this machine (its XML-RPC URI is on a
    local address and its getPid names a process here), else None: how an attached run
    finds the world node somebody else launched."""
    import rosgraph
    import xmlrpc.client
    from urllib.parse import urlparse
    try:
        uri = (master or rosgraph.Master('/scenario_runner')).lookupNode(name)
        host = urlparse(uri).hostname or ''
        if host not in ('localhost', socket.gethostname(), socket.getfqdn()) and \
                not host.startswith('127.'):
            return None
        code, _msg, pid = xmlrpc.client.ServerProxy(uri).getPid('/scenario_runner')
    except Exception:  # noqa: BLE001 - gone, or not a node: not watched
        return None
    return pid if code == 1 and isinstance(pid, int) and state(pid) is not None else None


def cmdline(pid):
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as f:
            return [a.decode('utf-8', 'replace') for a in f.read().split(b'\0') if a]
    except OSError:
        return []


def state(pid):
    """The process's state letter (R, S, D, T, t, Z...), or None when it is gone."""
    try:
        with open('/proc/%d/stat' % pid, 'rb') as f:
            return f.read().rsplit(b')', 1)[1].split()[0].decode()
    except (OSError, IndexError):
        return None


def alive(pid):
    return state(pid) not in (None, 'Z', 'X')


def thread_states(pid):
    """The state letters of every thread of pid ([] when it is gone)."""
    return [st for st, _ran in thread_runs(pid).values()]


def thread_runs(pid):
    """{thread id: (state letter, schedstat)} of every thread of pid ({} when it is gone).
    schedstat is /proc/PID/task/TID/schedstat: the thread's time on a CPU, its time waiting
    for one, and how many times it got one (None where the kernel keeps no such figures). It
    changes whenever the thread has run: two looks with the same schedstat for every thread,
    all of them sleeping, mean the process did nothing in between."""
    out = {}
    try:
        tids = os.listdir('/proc/%d/task' % pid)
    except OSError:
        return out
    for tid in tids:
        base = '/proc/%d/task/%s/' % (pid, tid)
        try:
            with open(base + 'stat', 'rb') as f:
                state = f.read().rsplit(b')', 1)[1].split()[0].decode()
        except (OSError, IndexError):
            continue                                  # it ended just now
        try:
            with open(base + 'schedstat', 'rb') as f:
                ran = f.read()
        except OSError:
            ran = None
        out[int(tid)] = (state, ran)
    return out


def _proc_number(pid, name, key):
    """The number after ``key`` in /proc/PID/``name``, or None."""
    try:
        with open('/proc/%d/%s' % (pid, name)) as f:
            for ln in f:
                if ln.startswith(key):
                    return int(ln.split()[1])
    except (OSError, ValueError, TypeError):
        return None
    return None


def read_chars(pid):
    """Bytes the process has read so far (/proc/PID/io rchar), or None."""
    return _proc_number(pid, 'io', 'rchar:')


def rss_kb(pid):
    """Resident memory of the process in kB (/proc/PID/status VmRSS), or None."""
    return _proc_number(pid, 'status', 'VmRSS:')


def socket_inodes(pid):
    out = set()
    try:
        fds = os.listdir('/proc/%d/fd' % pid)
    except OSError:
        return out
    for fd in fds:
        try:
            link = os.readlink('/proc/%d/fd/%s' % (pid, fd))
        except OSError:
            continue
        if link.startswith('socket:['):
            out.add(int(link[8:-1]))
    return out


# the one copy, in the world's step gate (a world node checks its own receive threads)
from sim_world.transport import FUTEX_SYSCALL, receivers_busy  # noqa: E402,F401 - re-exported


class TcpQueues(dict):
    """tcp_queues' answer: {socket inode: (bytes queued to send, bytes received and not yet
    read)} for the sockets with bytes in a queue, and :meth:`peer`: the other end of a
    connection inside this network namespace (loopback: ROS nodes on one machine), from the
    addresses and ports of every established socket."""

    def __init__(self, queues=(), ends=None):
        dict.__init__(self, queues)
        self.ends = ends or {}        # (local address, port, remote address, port) -> inode
        self._by_inode = None

    def peer(self, inode):
        """The inode of the socket at the other end of ``inode``'s connection, or None."""
        if self._by_inode is None:
            self._by_inode = {v: k for k, v in self.ends.items()}
        key = self._by_inode.get(inode)
        if key is None:
            return None
        return self.ends.get((key[2], key[3], key[0], key[1]))

    def inbound(self, inode):
        """Bytes on their way to socket ``inode``: queued to send at its peer (written by
        the sender, not yet in this socket's receive queue: a receiver that has just read
        its queue empty waits in recv() while the rest is still at the sender's side)."""
        other = self.peer(inode)
        return self.get(other, (0, 0))[0] if other is not None else 0


def tcp_queues():
    """{socket inode: (bytes queued to send, bytes received and not yet read)} for every
    established TCP socket of this network namespace with bytes in a queue (absent: none),
    as a :class:`TcpQueues` (which also knows each connection's other end).
    Asked through the kernel's sock_diag netlink interface (what ``ss`` uses), with only
    ESTABLISHED sockets dumped: 0.17 ms on one machine, 1.07 ms on another (kernel 6.18)
    even with no socket at all, as the dump walks every bucket of the established hash
    (262,144 there; ``dmesg``: "TCP established hash table entries"). So the app watch
    reads it once a look only when no app is running (appwatch.AppWatch.full_every).
    /proc/net/tcp (the fallback where netlink is refused) formats every socket, the
    hundreds in TIME_WAIT that XML-RPC calls leave too: 1.4 ms. IPv6 sockets are asked
    only when ROS uses IPv6 (ROS_IPV6=on; otherwise rospy and roscpp connect over IPv4)."""
    families = (socket.AF_INET, socket.AF_INET6) if os.environ.get('ROS_IPV6') == 'on' \
        else (socket.AF_INET,)
    try:
        out = TcpQueues()
        for family in families:
            _DIAG.established(family, out)
        return out
    except OSError:
        return _tcp_queues_proc()


class _SockDiag(object):
    """One NETLINK_SOCK_DIAG socket per process (a lock for its dump)."""
    REQ = 20                      # SOCK_DIAG_BY_FAMILY
    DUMP = 0x301                  # NLM_F_REQUEST | NLM_F_DUMP
    ESTABLISHED = 1 << 1          # TCP_ESTABLISHED

    def __init__(self):
        self.sock = None
        self.pid = None
        self.seq = 0
        self.lock = threading.Lock()

    def established(self, family, out):
        """Add the ESTABLISHED sockets of ``family`` to ``out`` (a TcpQueues)."""
        with self.lock:
            if self.sock is None or self.pid != os.getpid():     # a forked child: its own
                self.sock = socket.socket(socket.AF_NETLINK, socket.SOCK_RAW, 4)
                self.sock.connect((0, 0))
                self.pid = os.getpid()
            self.seq += 1
            # inet_diag_req_v2: family, protocol, ext, pad, states; a zero inet_diag_sockid
            req = struct.pack('=BBBBI', family, socket.IPPROTO_TCP, 0, 0,
                              self.ESTABLISHED) + bytes(48)
            self.sock.send(struct.pack('=IHHII', 16 + len(req), self.REQ, self.DUMP,
                                       self.seq, 0) + req)
            ends = out.ends
            while True:
                data = self.sock.recv(65536)
                off = 0
                while off + 16 <= len(data):
                    length, typ, _flags, seq, _pid = struct.unpack_from('=IHHII', data, off)
                    if length < 16:
                        raise OSError('sock_diag: a malformed netlink message')
                    if seq == self.seq:
                        if typ == 3:                             # NLMSG_DONE
                            return out
                        if typ == 2:                             # NLMSG_ERROR
                            raise OSError('sock_diag refused the dump')
                        # inet_diag_msg: 4 bytes, the 48-byte id (source and destination
                        # port, big-endian; source and destination address, 16 bytes each;
                        # interface, cookie), expires, rqueue, wqueue, uid, inode
                        rq, wq, _uid, inode = struct.unpack_from('=IIII', data, off + 72)
                        if rq or wq:
                            out[inode] = (wq, rq)
                        sport, dport = struct.unpack_from('>HH', data, off + 20)
                        ends[(data[off + 24:off + 40], sport, data[off + 40:off + 56],
                              dport)] = inode
                    off += (length + 3) & ~3


_DIAG = _SockDiag()


def _tcp_queues_proc():
    """tcp_queues from /proc/net/tcp (and tcp6 with ROS_IPV6=on)."""
    out = TcpQueues()
    names = ('/proc/net/tcp', '/proc/net/tcp6') if os.environ.get('ROS_IPV6') == 'on' \
        else ('/proc/net/tcp',)
    for name in names:
        try:
            with open(name) as f:
                next(f, None)
                for ln in f:
                    p = ln.split()
                    if len(p) < 10 or p[3] != '01':           # ESTABLISHED only
                        continue
                    local, remote = p[1].rsplit(':', 1), p[2].rsplit(':', 1)
                    out.ends[(local[0], int(local[1], 16), remote[0], int(remote[1], 16))] = \
                        int(p[9])
                    tx, rx = p[4].split(':')
                    if tx != '00000000' or rx != '00000000':
                        out[int(p[9])] = (int(tx, 16), int(rx, 16))
        except OSError:
            pass
    return out


_FIRST = [True]


def first_run():
    """True the first time it is asked in this process (a farm's later runs: False)."""
    first, _FIRST[0] = _FIRST[0], False
    return first


def age(pid=None):
    """Seconds since the process (default: this one) started (/proc/PID/stat starttime)."""
    pid = os.getpid() if pid is None else pid
    with open('/proc/%d/stat' % pid, 'rb') as f:
        start = int(f.read().rsplit(b')', 1)[1].split()[19]) / os.sysconf('SC_CLK_TCK')
    with open('/proc/uptime') as f:
        return float(f.read().split()[0]) - start
