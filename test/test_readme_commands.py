"""Every shell block of the documentation works as typed (issue 46).

The blocks of README.md, docs/*.md and every stack's README*.md (found anew on each run:
test/fixtures/readme_blocks.py) run page by page, in the page's order, in bash after
``source build/env.sh``, from the tree's root, with ROS_HOSTNAME=localhost and ROS_HOME in
build/, against one office world started the way the README says (``roslaunch
mobile_device_sim office.launch`` with its own master on a free port; module-scoped, shared
by every page). A command that starts a world of its own (roslaunch of a world, roscore,
tools/demo) gets a master of its own. Each command must exit as the page says (0 unless
``# -> exit N``), print what the page shows (``# -> TEXT``), write the files it names, and
print no Python traceback. A command that runs until Ctrl-C is started, checked, then
stopped with SIGINT: once it printed what the page shows, or, when the page shows nothing,
GRACE seconds after a node of its own registered with the master (at most SETTLE seconds).
Between pages the world is reset (``/gazebo/reset_world``) and the models a page spawned
are deleted; the shared world is paused while a command of a master of its own runs. Both
by one long-lived node (_WorldControl), not a rosservice per step. The test's output lists
each command's wall seconds.

A block marked ``<!-- not-run: REASON -->`` is not run; test_blocks_not_run_here_are_listed
prints every such block with its reason in the test output (never a silent skip).
The conventions are in docs/tests.md, "Documentation that is tested"."""
import os
import queue
import signal
import subprocess
import threading
import time
import xmlrpc.client

import pytest
import yaml

from fixtures.readme_blocks import (Command, doc_pages, leaves_the_shared_world_alone,
                                    shell_blocks, runs_until_interrupted, starts_a_world)
from fixtures.rosworld import office_world
from sim_world.netutil import master_port

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FINITE_TIMEOUT = float(os.environ.get('MDS_README_TIMEOUT', '600'))   # s, a command run to its end
EXPECT_TIMEOUT = 150.0    # s a command that runs until Ctrl-C has to print what the page shows
SETTLE = {'roslaunch': 15.0, 'roscore': 3.0}    # s such a command runs when nothing is expected
SETTLE_DEFAULT = 8.0
GRACE = 3.0               # s such a command still runs once it has registered a new node
STOP_TIMEOUT = 60.0       # s after SIGINT (at nice 10 in the light lane under a load of 22, a
                          # rospy node took more than 30 s to stop: fresh clone of 2026-12-06)

PAGES = [p for p in doc_pages(ROOT) if shell_blocks(ROOT, p)]


def _not_run_blocks():
    return [b for p in PAGES for b in shell_blocks(ROOT, p) if b.not_run is not None]


def test_blocks_not_run_here_are_listed(request):
    """Every block the suite does not run, with its reason, in the test's output."""
    blocks = _not_run_blocks()
    lines = ['documentation blocks not run here (%d):' % len(blocks)]
    lines += ['  %s  not-run: %s  (%s)' % (b.where, b.not_run,
                                           '; '.join(c.text[:60] for c in b.commands[:2]))
              for b in blocks]
    reporter = request.config.pluginmanager.getplugin('terminalreporter')
    if reporter is not None:
        reporter.write_line('')
        for line in lines:
            reporter.write_line(line)
    print('\n'.join(lines))
    for b in blocks:
        assert b.not_run.strip(), '%s: <!-- not-run: --> needs a reason' % b.where


@pytest.fixture(scope='module')
def world(tmp_path_factory):
    tmp = tmp_path_factory.mktemp('readme_world')
    with office_world(tmp, defaults=False) as env:
        env = dict(env, ROS_HOME=os.path.join(ROOT, 'build', 'ros_home'))
        os.makedirs(env['ROS_HOME'], exist_ok=True)
        env['MDS_README_TMP'] = str(tmp)
        env['MDS_README_MODELS'] = ' '.join(_launched_models(env))
        control = _WorldControl(env)
        try:
            yield env, control
        finally:
            control.close()


def _launched_models(env, timeout=180.0):
    """The models once office.launch's spawners are done (the phone and the flycam are
    there), the ones the reset between pages keeps."""
    deadline = time.monotonic() + timeout
    names = None
    while time.monotonic() < deadline:
        names = _models(env) or []
        if 'mobile_device' in names and 'flycam' in names:
            return names
        time.sleep(1.0)
    raise AssertionError('office.launch did not spawn the phone and the flycam within %.0f s '
                         '(models: %s)' % (timeout, names))


def _bash(cmd):
    return ['bash', '-c', 'set +u; source build/env.sh >/dev/null; set -u; ' + cmd]


def _run_quiet(env, cmd, timeout=60):
    return subprocess.run(_bash(cmd), cwd=ROOT, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True, timeout=timeout)


def _models(env):
    out = _run_quiet(env, 'rostopic echo -n1 /gazebo/model_states/name').stdout
    try:
        names = yaml.safe_load(out.split('---')[0])
    except yaml.YAMLError:
        return None
    return [str(n) for n in names] if isinstance(names, list) else None


_CONTROL = r"""
import sys
import rospy
from std_srvs.srv import Empty
from mobile_device_sim.msg import ModelStates
from mobile_device_sim.srv import DeleteModel
rospy.init_node('readme_world_control', anonymous=True, disable_signals=True)
SERVICES = {'pause': ('/gazebo/pause_physics', Empty),
            'unpause': ('/gazebo/unpause_physics', Empty),
            'delete': ('/gazebo/delete_model', DeleteModel),
            'reset': ('/gazebo/reset_world', Empty)}
def call(what, **kw):
    name, kind = SERVICES[what]
    rospy.wait_for_service(name, 60)
    return rospy.ServiceProxy(name, kind)(**kw)
print('ready', flush=True)
for line in sys.stdin:
    words = line.split()
    try:
        if words[0] == 'reset':
            keep = set(words[1:])
            names = rospy.wait_for_message('/gazebo/model_states', ModelStates, timeout=60).name
            for name in names:
                if name not in keep:
                    call('delete', model_name=name)
        call(words[0])
        print('ok', flush=True)
    except Exception as e:
        print(('%s %s: %s' % (words[0], type(e).__name__, e)).replace('\n', ' '), flush=True)
"""


class _WorldControl(object):
    """Pauses, runs and resets the shared world from one long-lived node (each rosservice or
    rostopic command would cost a Python start-up: pages flip the world a few times each)."""

    def __init__(self, env):
        self.p = subprocess.Popen(_bash('exec python3 -c "$MDS_CONTROL"'), cwd=ROOT,
                                  env=dict(env, MDS_CONTROL=_CONTROL), stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  universal_newlines=True, bufsize=1, start_new_session=True)
        self.paused = False
        self.lines = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self._answer('starting the world control node', 120)

    def _answer(self, what, timeout):
        deadline = time.monotonic() + timeout
        lines = []
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                break
            if line is None:
                break
            lines.append(line.rstrip())
            if line.strip() in ('ok', 'ready'):
                return
            if line.startswith(what.split()[0] + ' '):
                break
        raise AssertionError('%s failed:\n%s' % (what, '\n'.join(lines)))

    def _read(self):
        for line in self.p.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def request(self, line, timeout=120):
        self.p.stdin.write(line + '\n')
        self.p.stdin.flush()
        self._answer(line.split()[0], timeout)

    def running(self, running):
        """Pause the shared world while a command that cannot reach it runs (its own
        master: leaves_the_shared_world_alone), run it again before one that may; only on
        a change."""
        if running == self.paused:
            self.request('unpause' if running else 'pause')
            self.paused = not running

    def reset(self, keep):
        """The world as the launch made it: spawned models deleted, then reset_world."""
        self.running(True)
        self.request('reset ' + ' '.join(keep))

    def close(self):
        if self.p.poll() is None:
            os.killpg(self.p.pid, signal.SIGINT)
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, signal.SIGKILL)
                self.p.wait()
        self.p.stdin.close()


class Failure(Exception):
    pass


def _nodes(env):
    """The nodes registered with env's master (publishing, subscribing or serving), or None
    when no master answers there."""
    try:
        code, _m, state = xmlrpc.client.ServerProxy(env['ROS_MASTER_URI']).getSystemState(
            '/readme_test')
    except (OSError, xmlrpc.client.Error):
        return None
    if code != 1:
        return None
    return {n for kind in state for _name, nodes in kind for n in nodes}


def _tail(path, n=2500):
    with open(path, errors='replace') as f:
        text = f.read()
    return text[-n:]


def _stop(p):
    """SIGINT to the command's process group, as Ctrl-C; True if it stopped in time."""
    if p.poll() is not None:
        return True
    try:
        os.killpg(p.pid, signal.SIGINT)
    except ProcessLookupError:
        return True
    try:
        p.wait(STOP_TIMEOUT)
        return True
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        return False


def _command_env(world, block_env, cmd):
    if block_env is not None:
        return block_env
    if starts_a_world(cmd.text, ROOT):
        return dict(world, ROS_MASTER_URI='http://localhost:%d' % master_port())
    return world


def _check_output(cmd, log, started, upto=None):
    """upto: how much of the output came before the SIGINT (a KeyboardInterrupt's traceback
    after it is how Python stops, not a fault)."""
    with open(log, errors='replace') as f:
        out = f.read()
    before = out if upto is None else out[:upto]
    missing = [e for e in cmd.expects if e not in out]
    if missing:
        raise Failure('output lacks %s' % ', '.join(repr(m) for m in missing))
    if 'Traceback (most recent call last)' in before and not any('Traceback' in e
                                                               for e in cmd.expects):
        raise Failure('printed a Python traceback')
    for path in cmd.writes:
        full = os.path.join(ROOT, path)
        if not os.path.exists(full):
            raise Failure('did not write %s' % path)
        if os.path.getmtime(full) < started - 1:
            raise Failure('%s is older than the command' % path)


def _printed(log, expects):
    with open(log, errors='replace') as f:
        text = f.read()
    return all(e in text for e in expects)


def _run_command(cmd, env, log, background):
    """Runs one command; returns the process if it is left running (background). Whatever
    happens meanwhile (a failure, Ctrl-C of the suite), nothing of it is left running."""
    started = time.time()
    nodes = (_nodes(env) if runs_until_interrupted(cmd.text) and not cmd.expects
             and not background else None)
    with open(log, 'w') as out:
        p = subprocess.Popen(_bash(cmd.text), cwd=ROOT, env=env, stdout=out,
                             stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                             start_new_session=True)
    try:
        return _follow(cmd, p, log, background, started, env, nodes)
    except BaseException:
        _stop(p)
        raise


def _follow(cmd, p, log, background, started, env, nodes):
    """nodes: the master's nodes before a command that runs until Ctrl-C and shows no output
    started (None: no master yet). Such a command runs SETTLE seconds, or GRACE seconds
    once a node of its own is registered with the master (it got through its start-up:
    imports, arguments, init_node, its topics)."""
    if background:
        # a background command's '# -> TEXT' says when it is ready for the next line
        deadline = time.monotonic() + (EXPECT_TIMEOUT if cmd.expects else 2.0)
        while time.monotonic() < deadline and p.poll() is None:
            if cmd.expects and _printed(log, cmd.expects):
                break
            time.sleep(0.3)
        if p.poll() not in (None, 0):
            raise Failure('background command exited %s' % p.returncode)
        if cmd.expects and not _printed(log, cmd.expects):
            raise Failure('output lacks %s' % ', '.join(
                repr(e) for e in cmd.expects if not _printed(log, [e])))
        return p
    if runs_until_interrupted(cmd.text):
        prog = cmd.text.split()[0]
        deadline = time.monotonic() + (EXPECT_TIMEOUT if cmd.expects
                                       else SETTLE.get(prog, SETTLE_DEFAULT))
        registered = False
        while time.monotonic() < deadline and p.poll() is None:
            if cmd.expects and _printed(log, cmd.expects):
                break
            if nodes is not None and not registered:
                now = _nodes(env)
                if now is not None and now - nodes:
                    registered = True
                    deadline = min(deadline, time.monotonic() + GRACE)
            time.sleep(0.3)
        code = p.poll()
        with open(log, errors='replace') as f:
            upto = len(f.read())
        stopped = _stop(p)
        if code not in (None, 0):
            raise Failure('exited %s before Ctrl-C (it should run until then)' % code)
        if not stopped:
            raise Failure('did not stop within %.0f s of SIGINT' % STOP_TIMEOUT)
        _check_output(cmd, log, started, upto)
        return None
    else:
        try:
            p.wait(FINITE_TIMEOUT)
        except subprocess.TimeoutExpired:
            _stop(p)
            raise Failure('still running after %.0f s' % FINITE_TIMEOUT)
        if p.returncode != cmd.exit:
            raise Failure('exit status %s, the page says %s' % (p.returncode, cmd.exit))
    _check_output(cmd, log, started)
    return None


@pytest.mark.slow
@pytest.mark.parametrize('page', PAGES)
def test_readme_page_commands_work_as_typed(page, world):
    world, control = world
    blocks = [b for b in shell_blocks(ROOT, page) if b.not_run is None]
    if not blocks:
        return
    r0 = time.monotonic()
    control.reset(world['MDS_README_MODELS'].split())
    tmp = world['MDS_README_TMP']
    failures, ran, times = [], 0, [(time.monotonic() - r0, 'the reset before the page')]
    t0 = r0
    for block in blocks:
        block_env = None
        if any(c.text.split()[0] == 'roscore' for c in block.commands if c.text.split()):
            block_env = dict(world, ROS_MASTER_URI='http://localhost:%d' % master_port())
        background = []
        try:
            for cmd in block.commands:
                log = os.path.join(tmp, '%s_%d.log' % (page.replace('/', '_'), cmd.line))
                ran += 1
                env = _command_env(world, block_env, cmd)
                control.running(not leaves_the_shared_world_alone(cmd.text, ROOT))
                if cmd.text.split()[:1] == ['roscore'] and '-p' not in cmd.text.split():
                    # roscore takes 11311 whatever ROS_MASTER_URI says: the block's port
                    cmd.text += ' -p %s' % env['ROS_MASTER_URI'].rsplit(':', 1)[1]
                c0 = time.monotonic()
                try:
                    p = _run_command(cmd, env, log, cmd.background)
                    if p is not None:
                        background.append(p)
                except Failure as e:
                    failures.append('%s:%d  %s\n    %s\n%s' % (page, cmd.line, cmd.text, e,
                                                              _indent(_tail(log))))
                finally:
                    times.append((time.monotonic() - c0, cmd))
        finally:
            s0 = time.monotonic()
            for p in reversed(background):
                _stop(p)
            if background:
                times.append((time.monotonic() - s0, 'stop of the block at line %d' % block.line))
    control.running(True)
    # each command's wall seconds (a background command's: until it was ready), then the sum
    print('\n'.join('  %6.1f s  %s' % (t, '%d: %s' % (c.line, c.text.split('\n')[0][:100])
                                        if isinstance(c, Command) else c)
                     for t, c in times))
    print('%s: %d commands in %d blocks, %.0f s' % (page, ran, len(blocks),
                                                    time.monotonic() - t0))
    assert not failures, '%d of %d commands of %s failed:\n\n%s' % (
        len(failures), ran, page, '\n\n'.join(failures))


def _indent(text):
    return '\n'.join('      | ' + l for l in text.rstrip().split('\n'))
