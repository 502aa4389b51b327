"""Has every app answered the slice? Evidence from /proc, not a wall-clock quiet period.

Apps are black boxes in processes of their own. After a slice the world is paused, so an app
that is done with the slice's messages is idle: none of its threads is running (state R) or
in an uninterruptible wait in the kernel (state D: paging in code or data from disk, as an
app's first decode does when it touches a library for the first time, or reading a file),
no byte waits on its TCP connections (nothing queued to send, nothing received and not yet
read, nothing its peer has queued to send it: a receive thread that has just read its queue
empty waits in recv() while the rest of a big message is still on the sender's side), and
nothing it sent waits in the runner (the runner's sockets are empty and every message its
subscriptions deserialised has reached the inbox: ``own_pending``). The runner
checks that after each slice (``wait``), woken by every message that arrives. The world
answers a step only once every message of the slice is written to its subscribers'
sockets (sim_world.transport.wait_sent): a message still in the world's queue for an app
would look like an idle app with nothing to read. And the runner's own receive threads
(an embedded world's too) must all be waiting for bytes (procs.receivers_busy): one that
has taken an app's message off its socket but waits for the GIL before handing it on
leaves no trace in any queue. The queues are read through netlink (procs.tcp_queues),
fast enough that without that check the runner did look first: auto_rotate's landscape
answer was recorded a slice late in 1 run of 8, and in none of 25 with it.

A look is not one instant: the queues are read first, then each thread's state. An app can
run in between (take the last bytes off its socket, write its answer, and be back asleep
before its threads are read), and the look would then show an idle app with nothing queued
while its answer is on its way, stamped a slice late (the QR app's answer in a warm farm, once
in a fresh-clone CI run). So each look also reads every thread's schedstat (how often it got
a CPU): an app is idle only when none of its threads has run since the look before, which
was after that look's queues were read (a wait's first look: a reading just before its
queues). One that ran is looked at again at once; idle then if it did nothing meanwhile
(procs.thread_runs).

The same readings tell a hung app: a connection of it has had unread bytes at every look
for ``hang_after`` s of wall time, or every one of its threads is stopped (SIGSTOP). That is an error naming the app (``AppHung``). An app that never falls idle (it
works by the wall clock, or floods) is waited for at most ``limit`` s per slice; after
``give_up`` such slices in a row it is no longer waited for, with one warning.

An app that printed an uncaught exception's traceback (a Python app whose main thread
raised) is exiting: rospy's exit unregisters from the master and joins its threads, which
takes seconds under load. It is waited for until it has exited (at most ``exit_wait`` s of
wall time, outside the per-slice limit), so that the runner notices the crash in the slice
in which it happened instead of stepping on while the app dies. A traceback that rospy
logs for a callback (``bad callback``) or one of a dying thread (``Exception in thread``)
does not end the process and is not waited for; an app that outlives ``exit_wait`` after a
traceback is not waited for on tracebacks again.
"""
import os
import time

from . import procs

RAN = 'ran since the last look'
HANDLING = 'handling an input'     # another process (a world node) at work
TRACEBACK = b'Traceback (most recent call last):'
NOT_FATAL = (b'bad callback', b'Exception in thread')

__all__ = ['AppWatch', 'AppHung']


class AppHung(Exception):
    """An app stopped reading its topics (or was stopped): ``name``, ``text``."""

    def __init__(self, name, text):
        Exception.__init__(self, text)
        self.name = name


class AppWatch(object):
    def __init__(self, apps, own_pending=lambda queues: None, hang_after=10.0, limit=2.0, give_up=3,
                 warn=print, clock=time.monotonic, exit_wait=10.0, others=lambda: (),
                 full_every=0.05):
        """apps: [(name, Proc)]; own_pending(queues): a reason string while the runner
        itself still holds undelivered app messages, else None (queues: the same
        procs.tcp_queues() snapshot the apps were judged by); others(): [(name, pid)] of
        other processes held to the same rule about their threads (a world node of its
        own, which hands an app's message on to another app)."""
        self.apps = list(apps)
        self.others = others
        self.own_pending = own_pending
        self.hang_after = float(hang_after)
        self.limit = float(limit)
        self.give_up = int(give_up)
        self.warn = warn
        self.clock = clock
        self.stuck = {}        # name -> {socket inode or 'stopped': wall time first seen}
        self.misses = {}       # name -> slices in a row it did not fall idle
        self.ignored = set()
        self.waited = 0.0      # wall s spent waiting, for the timeline's figures
        self.exit_wait = float(exit_wait)
        self.exiting = {}      # name -> wall time a fatal-looking traceback was first seen
        self.survived = set()  # apps that outlived a traceback: not waited for on them again
        self.log_pos = {}      # name -> bytes of its log already read
        self.log_tail = {}     # name -> its last lines read
        self.tree = procs.ProcessTree()
        self.ran = {}          # name -> {(pid, tid): schedstat} at the last look
        # A look begins with the threads (_mark); while one of an app is running, the rest
        # (the machine's TCP queues through netlink, the app's sockets, its log, the
        # runner's own sockets: 2-4 ms of the runner's CPU on the cores the app and the
        # world need, most of the app watch's cost in the pipelined QR scenario) is read
        # only every ``full_every`` s of wall time: for a hang or a traceback.
        self.full_every = float(full_every)

    def _traceback_seen(self, name, p):
        """Did the app's log (its stdout and stderr) get an uncaught exception's traceback
        since the last look?"""
        path = getattr(p, 'log_path', None)
        if not path or name in self.survived:
            return False
        pos = self.log_pos.get(name, 0)
        try:
            size = os.path.getsize(path)
            if size <= pos:
                return False
            with open(path, 'rb') as f:
                f.seek(pos)
                new = f.read(size - pos)
        except OSError:
            return False
        self.log_pos[name] = pos + len(new)
        tail = self.log_tail.get(name, b'')
        lines = (tail + new).split(b'\n')
        self.log_tail[name] = b'\n'.join(lines[-3:])  # the lines before the next look's
        for i in range(tail.count(b'\n'), len(lines)):  # lines already looked at: context
            if lines[i].startswith(TRACEBACK) and not any(
                    k in line for line in lines[max(0, i - 2):i] for k in NOT_FATAL):
                return True
        return False

    @staticmethod
    def _read(pids, main=True):
        """(state letters, {(pid, tid): schedstat}) of every thread of ``pids`` (without
        each process's main thread unless ``main``)."""
        runs = {(pid, tid): r for pid in pids for tid, r in procs.thread_runs(pid).items()
                if main or tid != pid}
        return [st for st, _ran in runs.values()], {k: ran for k, (_st, ran) in runs.items()}

    @staticmethod
    def _queued(pids, queues):
        """(socket inodes, bytes queued to send, bytes to read: received or on their way
        from the other end) of the processes ``pids`` (queues: procs.tcp_queues())."""
        inodes = set()
        for pid in pids:
            inodes |= procs.socket_inodes(pid)
        tx = sum(queues.get(i, (0, 0))[0] for i in inodes)
        rx = sum(queues.get(i, (0, 0))[1] + queues.inbound(i) for i in inodes)
        return inodes, tx, rx

    @staticmethod
    def _working(states):
        """Why threads in these states are at work now (a thread running, or waiting in
        the kernel), or None."""
        if 'R' in states:
            return 'running'
        if 'D' in states:
            return 'waiting in the kernel (a thread in state D)'
        return None

    def _mark(self):
        """Read every app's threads (and the others') before a look reads the queues: that
        look compares its own reading with this one. Returns [(name, why)] of those with a
        thread running or waiting in the kernel right now: busy, whatever the queues say."""
        out = []
        kids = self.tree.children()
        for name, p in self.apps:
            if p.alive() and name not in self.ignored:
                states, self.ran[name] = self._read(procs.descendants(p.p.pid, kids))
                why = self._working(states)
                if why:
                    out.append((name, why))
        for name, pid in self.others():
            states, self.ran[name] = self._read([pid])
            if name not in self.ignored and self._working(states):
                out.append((name, HANDLING))
        return out

    def _others_busy(self):
        """[(name, why)] of the other processes running, waiting in the kernel, or that
        ran since the last reading."""
        out = []
        for name, pid in self.others():
            if name in self.ignored:
                continue
            states, ran = self._read([pid])
            ran_before, self.ran[name] = self.ran.get(name), ran
            if self._working(states):
                out.append((name, HANDLING))
            elif ran != ran_before:
                out.append((name, RAN))
        return out

    def _busy(self, queues):
        """[(name, why)] of the apps still working (not those given up on); raises
        AppHung for any app, given up on or not."""
        out = []
        kids = self.tree.children()
        now = self.clock()
        for name, p in self.apps:
            if not p.alive():
                continue
            if name not in self.exiting and self._traceback_seen(name, p):
                self.exiting[name] = now
            if name in self.exiting:
                if now - self.exiting[name] < self.exit_wait:
                    out.append((name, 'exiting'))
                    continue
                del self.exiting[name]        # it lives on: the traceback was not fatal
                self.survived.add(name)
            pids = procs.descendants(p.p.pid, kids)
            states, ran = self._read(pids)
            ran_before, self.ran[name] = self.ran.get(name), ran
            inodes, tx, rx = self._queued(pids, queues)
            stopped = bool(states) and all(s in ('T', 't') for s in states)
            # a connection it does not read: bytes wait on it at every look
            seen = self.stuck.setdefault(name, {})
            for i in [k for k in seen if k != 'stopped']:
                if i not in inodes or not queues.get(i, (0, 0))[1]:
                    del seen[i]
            for i in inodes:
                if queues.get(i, (0, 0))[1]:
                    seen.setdefault(i, now)
            if stopped:
                seen.setdefault('stopped', now)
            else:
                seen.pop('stopped', None)
            if seen:
                key = min(seen, key=seen.get)
                if now - seen[key] >= self.hang_after:
                    raise AppHung(name, (
                        'app %s is stopped (every thread in state T) for %.0f s of wall time'
                        % (name, now - seen[key])) if key == 'stopped' else (
                        'app %s hangs: it stopped reading its topics (%d bytes wait on its '
                        'connections, unread for %.0f s of wall time)'
                        % (name, queues.get(key, (0, rx))[1], now - seen[key])))
            if name in self.ignored:
                continue
            why = self._working(states)
            if why:
                out.append((name, why))
            elif tx or rx:
                out.append((name, '%d bytes queued' % (tx + rx)))
            elif stopped:
                out.append((name, 'stopped'))
            elif ran != ran_before:
                # it ran since the last look, which may have been after ``queues`` was read:
                # what it did then (an answer written, a thread woken and back to sleep
                # before its state was read) is not in this look
                out.append((name, RAN))
        return out

    # -- the apps' set-up (Apps.await_ready): one look, no waiting ------------------------
    def reading(self, serving=()):
        """{name: schedstat of its threads} of every live app (its processes) and of the
        request threads of ``serving`` ([(name, pid)]: the run's master): what
        ``ran_since`` compares with. Not ``others()``: a paused world node runs now and then
        (its paused publishing), and whether it took an app's connection is asked of it
        (Apps._missing)."""
        return {name: ran for name, _pids, _app, _states, ran in self._setup_threads(serving)}

    def ran_since(self, before, serving=()):
        """[(name, why)] of what was not idle since ``before`` (a ``reading``): a thread
        running or waiting in the kernel now, or one that ran since; for an app also bytes
        queued on its connections (its registration's answer not yet read). Empty: the
        apps and ``serving`` did nothing in between."""
        out = []
        queues = None
        for name, pids, is_app, states, ran in self._setup_threads(serving):
            why = self._working(states)
            if why is None and ran != before.get(name):
                why = RAN
            if why is None and is_app:
                queues = queues if queues is not None else procs.tcp_queues()
                _inodes, tx, rx = self._queued(pids, queues)
                why = '%d bytes queued' % (tx + rx) if tx or rx else None
            if why is not None:
                out.append((name, why))
        return out

    def _setup_threads(self, serving):
        """[(name, pids, is an app, thread states, {(pid, tid): schedstat})] of the live
        apps and of ``serving`` without its main thread: rosmaster's wakes every 0.1 s to
        see whether it should stop; its requests are served by the other threads. Its
        sockets are not looked at: counted with their other ends, they showed 400-1212
        bytes at look after look of a run's set-up while the master did nothing."""
        kids = self.tree.children()
        out = []
        for name, p in self.apps:
            if p.alive():
                pids = procs.descendants(p.p.pid, kids)
                out.append((name, pids, True) + self._read(pids))
        for name, pid in serving:
            out.append((name, [pid], False) + self._read([pid], main=False))
        return out

    def wait(self, wake):
        """Block until every app is idle and the runner holds nothing of theirs (wake(s):
        wait up to s for the next message to arrive). Raises AppHung."""
        if not self.apps:
            return
        t0 = last_full = self.clock()
        relooked = False
        while True:
            busy = self._mark()
            now = self.clock()
            if busy and now - last_full < self.full_every and now - t0 < self.limit:
                own = None                    # working: the queues can wait (see __init__)
            else:
                last_full = now
                queues = procs.tcp_queues()
                busy = self._busy(queues)
                if not busy:
                    busy = self._others_busy()
                own = self.own_pending(queues) if not busy else None
            if not busy and own is None:
                for name, _p in self.apps:
                    self.misses.pop(name, None)
                break
            if busy and all(w == RAN for _n, w in busy) and not relooked:
                relooked = True               # look again at once: idle if it did nothing
                continue
            relooked = False
            dying_only = busy and all(w == 'exiting' for _n, w in busy)
            if now - t0 >= self.limit and not dying_only and now == last_full:
                for name, why in busy:
                    if why == 'exiting':
                        continue
                    n = self.misses[name] = self.misses.get(name, 0) + 1
                    if n >= self.give_up and name not in self.ignored:
                        self.ignored.add(name)
                        self.warn('WARNING app %s never falls idle (%s, %d slices in a row): '
                                  'it is no longer waited for; its outputs are timed by their '
                                  'arrival' % (name, why, n))
                break
            wake(0.002)
        self.waited += self.clock() - t0
