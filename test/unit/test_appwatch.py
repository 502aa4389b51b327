"""The runner's evidence that apps answered a slice (testing_instance.appwatch), on real
processes: idle, busy, stopped, and one that does not read its connection."""
import contextlib
import signal
import socket
import subprocess
import sys
import time

import pytest

from testing_instance.appwatch import AppHung, AppWatch


class P(object):
    def __init__(self, code):
        self.p = subprocess.Popen([sys.executable, '-c', code])

    def alive(self):
        return self.p.poll() is None


@pytest.fixture
def spawn():
    made = []

    def make(code):
        made.append(P(code))
        time.sleep(0.3)                  # the interpreter is up
        return made[-1]
    yield make
    for q in made:
        q.p.kill()
        q.p.wait()


def sleeper(t=0.001):
    time.sleep(t)


def test_an_idle_app_has_answered_at_once(spawn):
    w = AppWatch([('/idle', spawn('import time; time.sleep(60)'))], limit=5.0)
    t0 = time.monotonic()
    w.wait(sleeper)
    assert time.monotonic() - t0 < 2.0 and not w.misses and not w.ignored


def test_the_runner_holding_messages_counts_as_not_answered(spawn):
    pending = ['runner: /x']
    w = AppWatch([('/idle', spawn('import time; time.sleep(60)'))],
                 own_pending=lambda: pending[0], limit=0.3)
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
