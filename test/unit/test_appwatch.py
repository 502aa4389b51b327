"""The runner's evidence that apps answered a slice (testing_instance.world.appwatch), on real
processes: idle, busy, stopped, one that does not read its connection, and one that dies
slowly after an uncaught exception."""
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

import pytest

from testing_instance.world import procs
from testing_instance.world.appwatch import AppHung, AppWatch


class P(object):
    def __init__(self, code, log_path=None):
        self.log_path = log_path
        out = open(log_path, 'w') if log_path else None
        self.p = subprocess.Popen([sys.executable, '-u', '-c', code], stdout=out,
                                  stderr=subprocess.STDOUT)

    def alive(self):
        return self.p.poll() is None


@pytest.fixture
def spawn():
    made = []

    def make(code, log_path=None):
        made.append(P(code, log_path))
        time.sleep(0.3)                  # the interpreter is up
        return made[-1]
    yield make
    for q in made:
        q.p.kill()
        q.p.wait()


def sleeper(t=0.001):
    time.sleep(t)


def waited(w):
    """Wall s one AppWatch.wait took."""
    t0 = time.monotonic()
    w.wait(sleeper)
    return time.monotonic() - t0


def test_an_idle_app_has_answered_at_once(spawn):
    w = AppWatch([('/idle', spawn('import time; time.sleep(60)'))], limit=5.0)
    t0 = time.monotonic()
    w.wait(sleeper)
    assert time.monotonic() - t0 < 2.0 and not w.misses and not w.ignored


def test_the_runner_holding_messages_counts_as_not_answered(spawn):
    pending = ['runner: /x']
    w = AppWatch([('/idle', spawn('import time; time.sleep(60)'))],
                 own_pending=lambda queues: pending[0], limit=0.3)
    w.wait(sleeper)
    assert w.waited >= 0.3
    pending[0] = None
    w.waited = 0.0
    w.wait(sleeper)
    assert w.waited < 0.3


def test_an_app_that_never_falls_idle_is_given_up_with_one_warning(spawn):
    said = []
    w = AppWatch([('/spin', spawn('while True: pass'))], limit=0.2, give_up=2,
                 warn=said.append)
    for _ in range(3):
        w.wait(sleeper)
    assert w.ignored == {'/spin'}
    assert len(said) == 1 and 'app /spin never falls idle (running' in said[0], said


def test_a_stopped_app_is_hung(spawn):
    p = spawn('import time; time.sleep(60)')
    p.p.send_signal(signal.SIGSTOP)
    w = AppWatch([('/stopped', p)], hang_after=0.4, limit=5.0)
    with pytest.raises(AppHung, match=r'app /stopped is stopped \(every thread in state T\)'):
        w.wait(sleeper)


@contextlib.contextmanager
def sent_5000_bytes(spawn, code):
    """The app ``code`` connects to a local port (``%d`` in it), which sends it 5000 bytes."""
    srv = socket.socket()
    srv.bind(('127.0.0.1', 0))
    srv.listen(1)
    p = spawn(code % srv.getsockname()[1])
    conn, _ = srv.accept()
    conn.sendall(b'x' * 5000)
    try:
        yield p
    finally:
        conn.close()
        srv.close()


def test_an_app_that_stops_reading_its_connection_is_hung(spawn):
    with sent_5000_bytes(spawn, 'import socket, time; s = socket.create_connection('
                                '("127.0.0.1", %d)); time.sleep(60)') as p:    # never read
        w = AppWatch([('/deaf', p)], hang_after=0.4, limit=5.0)
        with pytest.raises(AppHung, match=r'app /deaf hangs: it stopped reading its topics '
                                          r'\(5000 bytes wait'):
            w.wait(sleeper)


def test_an_app_that_reads_is_not_hung(spawn):
    with sent_5000_bytes(spawn, 'import socket\ns = socket.create_connection(("127.0.0.1", %d))\n'
                                'while s.recv(65536): pass') as p:
        w = AppWatch([('/reader', p)], hang_after=0.4, limit=5.0)
        w.wait(sleeper)                   # read at once: idle, no hang
        assert not w.misses


def test_while_an_app_runs_the_queues_are_read_only_now_and_then(spawn, monkeypatch):
    """A look begins with the app's threads; while one runs, the machine's TCP queues (the
    costly part) are read every full_every s, not every 2 ms."""
    reads = []
    real = procs.tcp_queues
    monkeypatch.setattr(procs, 'tcp_queues', lambda: reads.append(1) or real())
    w = AppWatch([('/spin', spawn('while True: pass'))], limit=0.5, full_every=0.1)
    assert waited(w) >= 0.5 and w.misses == {'/spin': 1}
    assert 3 <= len(reads) <= 10           # about 0.5 / 0.1, and one at the limit
    reads.clear()
    w2 = AppWatch([('/spin', w.apps[0][1])], limit=0.5, full_every=0.0)   # every look
    waited(w2)
    # more than the throttled watch's most (10): a look every 2 ms gives hundreds on an idle
    # machine, 17 in the light lane at nice 10 under the integration tests (2026-12-06)
    assert len(reads) > 10


def test_a_running_app_that_never_reads_its_connection_is_still_found_hung(spawn):
    with sent_5000_bytes(spawn, 'import socket, time; s = socket.create_connection('
                                '("127.0.0.1", %d))\nwhile True: pass') as p:   # spins, deaf
        w = AppWatch([('/deaf', p)], hang_after=0.4, limit=5.0, full_every=0.1)
        with pytest.raises(AppHung, match=r'app /deaf hangs'):
            w.wait(sleeper)


VFORK_WAIT = r"""
#include <unistd.h>
int main(void) { if (vfork() == 0) { sleep(2); _exit(0); } return 0; }
"""


def test_an_app_waiting_in_the_kernel_has_not_answered(spawn, tmp_path):
    """A thread in state D (uninterruptible: paging in a library on the first decode,
    reading a file) is working for the app, not idle. A real one: the parent of vfork()
    waits in state D until its child execs or exits (the child sleeps 2 s)."""
    cc = shutil.which('cc') or shutil.which('gcc')
    if cc is None:
        pytest.skip('no C compiler')
    src = tmp_path / 'vfork_wait.c'
    src.write_text(VFORK_WAIT)
    exe = str(tmp_path / 'vfork_wait')
    subprocess.check_call([cc, '-o', exe, str(src)])
    p = spawn('import subprocess, time; subprocess.call([%r]); time.sleep(60)' % exe)
    kids = procs.ProcessTree().children()
    states = [s for pid in procs.descendants(p.p.pid, kids) for s in procs.thread_states(pid)]
    assert 'D' in states and 'R' not in states, states     # what the watch is shown
    said = []
    w = AppWatch([('/disk', p)], limit=0.4, give_up=5, warn=said.append)
    assert waited(w) >= 0.4 and w.misses == {'/disk': 1}
    busy = w._busy(procs.tcp_queues())
    assert busy == [('/disk', 'waiting in the kernel (a thread in state D)')], busy
    time.sleep(2.0)                       # the child exited: the app is idle again
    assert waited(w) < 0.4 and not w.misses and not said


# a Python app whose main thread raised: the traceback is printed at once, the exit (rospy's
# shutdown: unregistering, joining threads) takes seconds; here the exit is an atexit sleep
DIES_SLOWLY = ('import atexit, time\natexit.register(time.sleep, %g)\ntime.sleep(0.5)\n'
               'raise RuntimeError("crashed on purpose")')


def test_an_app_dying_of_an_exception_is_waited_for_until_it_has_exited(spawn, tmp_path):
    p = spawn(DIES_SLOWLY % 1.5, str(tmp_path / 'app.log'))
    w = AppWatch([('/dying', p)], limit=0.2, give_up=1, exit_wait=10.0)
    w.wait(sleeper)                       # before the exception: idle
    time.sleep(0.5)                       # it raised and is busy dying (atexit)
    took = waited(w)
    assert not p.alive(), 'the runner stepped on while the app was dying'
    assert took >= 0.5
    assert not w.misses and not w.ignored  # dying is not "never falls idle"


def test_a_traceback_the_app_lives_through_is_waited_for_once(spawn, tmp_path):
    code = ('import time, traceback\ntime.sleep(0.5)\n'
            'try:\n    1 / 0\nexcept ZeroDivisionError:\n    traceback.print_exc()\n'
            'time.sleep(0.5)\ntry:\n    1 / 0\nexcept ZeroDivisionError:\n'
            '    traceback.print_exc()\ntime.sleep(60)')
    p = spawn(code, str(tmp_path / 'app.log'))
    w = AppWatch([('/logs', p)], limit=0.2, exit_wait=0.6)
    time.sleep(0.5)
    assert 0.5 <= waited(w) < 3.0 and p.alive()   # the first traceback: up to exit_wait
    time.sleep(1.0)                       # the second traceback: not waited for
    assert waited(w) < 0.5 and w.survived == {'/logs'}


def test_a_callback_exception_rospy_logs_is_not_waited_for(spawn, tmp_path):
    code = ('import sys, time\ntime.sleep(0.3)\n'
            'print("[ERROR] [12.5]: bad callback: <function on_imu>")\n'
            'print("Traceback (most recent call last):")\nprint("ValueError: x")\n'
            'time.sleep(60)')
    p = spawn(code, str(tmp_path / 'app.log'))
    time.sleep(0.5)
    w = AppWatch([('/cb', p)], limit=0.2, exit_wait=5.0)
    assert waited(w) < 1.0 and not w.exiting


def loopback_connection():
    """(listening socket, client end, accepted end) of a new loopback TCP connection."""
    lst = socket.socket()
    lst.bind(('127.0.0.1', 0))
    lst.listen(1)
    c = socket.create_connection(lst.getsockname())
    a, _ = lst.accept()
    return lst, c, a


def test_tcp_queues_reads_what_proc_net_tcp_says():
    """The sock_diag netlink dump gives the same queues as /proc/net/tcp: unread bytes on
    the receiving socket, nothing for empty ones (ESTABLISHED only)."""
    import socket
    import time as _t
    lst, c, a = loopback_connection()
    try:
        c.sendall(b'x' * 1234)
        inode = os.fstat(a.fileno()).st_ino
        for _ in range(100):
            q = procs.tcp_queues()
            if q.get(inode) == (0, 1234):
                break
            _t.sleep(0.01)
        assert q.get(inode) == (0, 1234)
        assert procs._tcp_queues_proc().get(inode) == (0, 1234)
        assert os.fstat(c.fileno()).st_ino not in q          # its queues are empty
        a.recv(2000)
        assert inode not in procs.tcp_queues()
    finally:
        for s in (c, a, lst):
            s.close()


def test_tcp_queues_pair_the_two_ends_of_a_connection():
    """TcpQueues.peer: the socket at the other end of a loopback connection, from both the
    netlink dump and /proc/net/tcp; inbound: what that end has queued to send this one."""
    lst, c, a = loopback_connection()
    try:
        ia, ic = os.fstat(a.fileno()).st_ino, os.fstat(c.fileno()).st_ino
        for q in (procs.tcp_queues(), procs._tcp_queues_proc()):
            assert q.peer(ia) == ic and q.peer(ic) == ia
            assert q.peer(os.fstat(lst.fileno()).st_ino) is None      # not a connection
            assert q.inbound(ia) == 0
        # c sends more than a's receive queue and c's send queue can take at once: the rest
        # waits at c while a's queue is full; c's send queue is what is on its way to a
        a.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        c.setblocking(False)
        sent = 0
        try:
            while sent < 1 << 24:
                sent += c.send(b'x' * 65536)
        except BlockingIOError:
            pass
        q = procs.tcp_queues()
        assert q.inbound(ia) == q[ic][0] > 0 and q[ia][1] > 0
        assert q.inbound(ia) + q[ia][1] == sent
    finally:
        for s in (c, a, lst):
            s.close()


def test_bytes_on_their_way_to_an_app_count_as_not_answered(spawn):
    """An app whose receive queue is empty while its peer still has bytes queued for it (it
    has just read what had arrived; the rest of a big message follows) has not answered:
    the queues the watch is shown say so for the runner's end of the app's connection."""
    with sent_5000_bytes(spawn, 'import socket\ns = socket.create_connection(("127.0.0.1", %d))\n'
                                'while s.recv(65536): pass') as p:
        w = AppWatch([('/reader', p)], limit=5.0)
        w.wait(sleeper)                        # it read the 5000 bytes: idle
        real = procs.tcp_queues()
        app = [i for i in procs.socket_inodes(p.p.pid) if real.peer(i) is not None]
        assert len(app) == 1, app
        other = real.peer(app[0])
        in_flight = procs.TcpQueues({other: (3000, 0)}, real.ends)
        assert w._busy(in_flight) == [('/reader', '3000 bytes queued')]
        assert w._busy(procs.TcpQueues({}, real.ends)) == []


TCP_QUEUES = procs.tcp_queues      # (a test below puts a wrapper in its place)
ECHO = ('import socket\ns = socket.create_connection(("127.0.0.1", %d))\n'
        'while True:\n    b = s.recv(1)\n    if not b: break\n    s.sendall(b)')


@contextlib.contextmanager
def echo_app(spawn):
    """(app, its connection's other end): the app sends back every byte it reads."""
    srv = socket.socket()
    srv.bind(('127.0.0.1', 0))
    srv.listen(1)
    p = spawn(ECHO % srv.getsockname()[1])
    conn, _ = srv.accept()
    try:
        yield p, conn
    finally:
        conn.close()
        srv.close()


def asleep(p):
    """Wait until no thread of the app runs (at most 2 s)."""
    for _ in range(400):
        if not any(s in ('R', 'D') for s in procs.thread_states(p.p.pid)):
            return
        time.sleep(0.005)
    raise AssertionError('the app did not fall asleep')


def poke(p, conn):
    """The app answers one byte and is asleep again, its connection's queues empty (the
    acknowledgement of its answer, which TCP may delay, is in)."""
    conn.sendall(b'x')
    assert conn.recv(1) == b'x'
    mine = os.fstat(conn.fileno()).st_ino
    for _ in range(400):
        q = TCP_QUEUES()
        if mine not in q and q.peer(mine) not in q:
            break
        time.sleep(0.005)
    asleep(p)


def test_thread_runs_change_only_when_a_thread_ran(spawn):
    with echo_app(spawn) as (p, conn):
        asleep(p)
        a = procs.thread_runs(p.p.pid)
        assert list(a) == [p.p.pid] and a[p.p.pid][0] == 'S', a
        if a[p.p.pid][1] is None:
            pytest.skip('no /proc/PID/task/TID/schedstat in this kernel')
        time.sleep(0.05)
        assert procs.thread_runs(p.p.pid) == a           # asleep: nothing changed
        poke(p, conn)
        b = procs.thread_runs(p.p.pid)
        assert b[p.p.pid][0] == 'S' and b != a            # it ran, and sleeps again
    assert procs.thread_runs(10 ** 7) == {}               # no such process


def test_an_app_that_ran_after_the_queues_were_read_has_not_answered(spawn):
    """A look reads the queues, then the threads. An app that took its input, wrote its
    answer and went back to sleep in between looks idle with nothing queued; the threads'
    schedstat says it ran since the look before, and it is looked at again."""
    with echo_app(spawn) as (p, conn):
        if procs.thread_runs(p.p.pid)[p.p.pid][1] is None:
            pytest.skip('no /proc/PID/task/TID/schedstat in this kernel')
        w = AppWatch([('/echo', p)], limit=5.0)
        asleep(p)
        w.wait(sleeper)                          # idle
        assert w._busy(procs.tcp_queues()) == []
        queues = procs.tcp_queues()              # the look's queues: nothing queued
        poke(p, conn)                            # the app runs before its threads are read
        assert w._busy(queues) == [('/echo', 'ran since the last look')]
        assert w._busy(procs.tcp_queues()) == []
        # wait(): the look that meets it is followed by another at once, without a wake
        looks, wakes, real = [], [], procs.tcp_queues

        def reading_then_poke():
            q = real()
            if not looks:
                poke(p, conn)
            looks.append(q)
            return q
        procs.tcp_queues = reading_then_poke
        try:
            w.wait(wakes.append)
        finally:
            procs.tcp_queues = real
        assert len(looks) == 2 and wakes == [], (len(looks), wakes)


def test_a_world_node_that_ran_after_the_queues_were_read_holds_the_apps(spawn):
    """``others``: a world node of its own (here the echo process) is held to the apps'
    rule once the apps are idle: running, or run since the look before, it is waited for."""
    idle = spawn('import time; time.sleep(60)')
    with echo_app(spawn) as (node, conn):
        if procs.thread_runs(node.p.pid)[node.p.pid][1] is None:
            pytest.skip('no /proc/PID/task/TID/schedstat in this kernel')
        w = AppWatch([('/idle', idle)], limit=5.0,
                     others=lambda: [('the world node', node.p.pid)])
        asleep(node)
        w.wait(sleeper)
        assert w._others_busy() == []
        poke(node, conn)
        assert w._others_busy() == [('the world node', 'ran since the last look')]
        assert w._others_busy() == []
        spin = spawn('while True: pass')
        w2 = AppWatch([('/idle', idle)], limit=0.2, give_up=5,
                      others=lambda: [('the world node', spin.p.pid)])
        assert waited(w2) >= 0.2 and w2.misses == {'the world node': 1}
        assert w2._others_busy() == [('the world node', 'handling an input')]


@pytest.mark.skipif(procs.FUTEX_SYSCALL is None, reason='futex syscall number unknown here')
def test_receivers_busy_names_a_receive_thread_not_waiting_for_bytes():
    """A rospy receive thread (named after its topic) that has taken bytes off its socket
    and waits for the GIL or a lock, or runs, holds a message: the runner has not got it
    yet. One waiting in recv holds nothing."""
    import threading
    a, b = socket.socketpair()
    lock = threading.Lock()
    lock.acquire()
    stop = threading.Event()
    idle = threading.Thread(target=lambda: a.recv(1), name='/idle_topic', daemon=True)
    locked = threading.Thread(target=lambda: (lock.acquire(), lock.release()),
                              name='/locked_topic', daemon=True)

    def spin():
        while not stop.is_set():
            pass
    spinning = threading.Thread(target=spin, name='/spinning_topic', daemon=True)
    other = threading.Thread(target=lambda: (lock.acquire(), lock.release()),
                             name='not a topic', daemon=True)
    for t in (idle, locked, spinning, other):
        t.start()
    try:
        time.sleep(0.2)
        busy = procs.receivers_busy()
        assert '/locked_topic' in busy and '/spinning_topic' in busy
        assert '/idle_topic' not in busy and 'not a topic' not in busy
    finally:
        stop.set()
        lock.release()
        b.send(b'x')
        for t in (idle, locked, spinning, other):
            t.join(5)
        a.close()
        b.close()
    assert procs.receivers_busy() == []


def test_the_process_tree_is_scanned_again_only_after_a_process_was_made(monkeypatch, spawn):
    scans = []
    real = procs.children_map
    monkeypatch.setattr(procs, 'children_map', lambda: scans.append(1) or real())
    tree = procs.ProcessTree()
    marks = iter([100, 100, 100, 101])
    monkeypatch.setattr(procs, 'last_pid', lambda: next(marks))
    kids = tree.children()
    assert tree.children() is kids and tree.children() is kids and len(scans) == 1
    tree.children()                                  # an id was handed out: scanned again
    assert len(scans) == 2
    monkeypatch.undo()
    # the real mark moves when a process is made, and the new one is in the next map
    tree = procs.ProcessTree()
    tree.children()
    before = procs.last_pid()
    p = spawn('import time; time.sleep(60)')
    assert procs.last_pid() != before
    assert p.p.pid in tree.children().get(os.getpid(), [])
