"""sim_world.transport.gate (stepgate before issue 45) without a roscore: while the gate is
closed (the world steps a
pipelined slice) a message received from a socket and a service request wait in the thread
that got them, and go through, in order, once it is open again."""
import contextlib
import threading
import time

import pytest

pytest.importorskip('rospy')

from rospy.impl.tcpros_service import ServiceImpl  # noqa: E402
from rospy.topics import _SubscriberImpl  # noqa: E402

from sim_world.transport import gate  # noqa: E402


class FakeSub(object):
    """What _SubscriberImpl.receive_callback reads of its implementation."""
    statistics_logger = None

    def __init__(self, got):
        self.callbacks = [(lambda m, _a: got.append(m), None)]

    def _invoke_callback(self, msg, cb, cb_args):
        cb(msg, cb_args)


class FakeService(object):
    """What ServiceImpl._handle_request reads: its handler, response class, seq."""
    seq = 0
    response_class = None

    def __init__(self, got):
        self.handler = lambda req: got.append(req)


@pytest.fixture(autouse=True)
def _installed():
    """The gate wraps rospy's delivery once per process, before any subscriber exists (the
    world's API does it as it starts). Every test reads the wrapped methods, so each
    installs it first: a test that relied on an earlier one in the same process failed when
    pytest-xdist gave it a process of its own (found by bench/flaky)."""
    gate.install()


@contextlib.contextmanager
def _step_requested_over_a_socket():
    """What a world node does when its step request arrives: the request is an input this
    thread handles (past the gate), and the step closes the gate; inside, the step runs."""
    gate._enter()
    try:
        gate.close()
        yield
    finally:
        gate.reopen()
        gate._leave()


def _later(fn, *args):
    th = threading.Thread(target=fn, args=args, daemon=True)
    th.start()
    return th


def test_inputs_wait_while_the_gate_is_closed(monkeypatch):
    got = []
    gate.install()
    gate.install()                                   # once per process
    monkeypatch.setattr('rospy.impl.tcpros_service.convert_return_to_response',
                        lambda r, cls: r)

    class Transport(object):
        write_buff = type('B', (), {'write': lambda self, b: None})()

        def send_message(self, resp, seq):
            got.append('answered')
    gate.close()
    try:
        assert gate.is_closed()
        a = _later(_SubscriberImpl.receive_callback, FakeSub(got), ['m1', 'm2'], None)
        time.sleep(0.05)
        b = _later(ServiceImpl._handle_request, FakeService(got), Transport(), 'req')
        time.sleep(0.2)
        assert got == [] and a.is_alive() and b.is_alive()    # both wait
    finally:
        gate.reopen()
    a.join(5)
    b.join(5)
    assert not a.is_alive() and not b.is_alive()
    assert sorted(got) == ['answered', 'm1', 'm2', 'req']
    assert got.index('m1') < got.index('m2') and got.index('req') < got.index('answered')
    # open: at once, in the calling thread
    _SubscriberImpl.receive_callback(FakeSub(got), ['m3'], None)
    assert got[-1] == 'm3' and not gate.is_closed()


def test_close_waits_for_inputs_already_in_hand():
    """An input let through before the step (its callback running) is handled before the
    step begins: close() returns once it is done, so it never lands inside a step."""
    go, inside, got = threading.Event(), threading.Event(), []

    class Slow(FakeSub):
        def _invoke_callback(self, msg, cb, cb_args):
            inside.set()
            go.wait(10)
            got.append(msg)
    a = _later(_SubscriberImpl.receive_callback, Slow(got), ['slow'], None)
    assert inside.wait(5)
    closed = threading.Event()
    c = _later(lambda: (gate.close(), closed.set()))
    try:
        time.sleep(0.2)
        assert not closed.is_set() and got == []       # the step has not begun
        go.set()
        assert closed.wait(5) and got == ['slow']
    finally:
        go.set()
        c.join(5)
        gate.reopen()
    a.join(5)


def test_the_step_request_itself_does_not_wait_for_itself(monkeypatch):
    """The sim_world node serves StepWorld through a service request, which passes the gate
    like any other: closing the gate inside it must not wait for it."""
    monkeypatch.setattr('rospy.impl.tcpros_service.convert_return_to_response',
                        lambda r, cls: r)
    took = []

    class Transport(object):
        write_buff = type('B', (), {'write': lambda self, b: None})()

        def send_message(self, resp, seq):
            pass

    def step(req):
        t0 = time.monotonic()
        gate.close(wait=3.0)
        took.append(time.monotonic() - t0)
        gate.reopen()
    svc = FakeService([])
    svc.handler = step
    ServiceImpl._handle_request(svc, Transport(), 'step')
    assert len(took) == 1 and took[0] < 1.0


def test_an_input_that_never_ends_delays_the_step_at_most_the_wait(caplog):
    go, inside = threading.Event(), threading.Event()

    class Stuck(FakeSub):
        def _invoke_callback(self, msg, cb, cb_args):
            inside.set()
            go.wait(10)
    a = _later(_SubscriberImpl.receive_callback, Stuck([]), ['x'], None)
    assert inside.wait(5)
    t0 = time.monotonic()
    try:
        gate.close(wait=0.3)
        assert 0.25 <= time.monotonic() - t0 < 2.0
        assert 'still in hand after 0.3 s' in caplog.text
    finally:
        gate.reopen()
        go.set()
    a.join(5)


@pytest.mark.skipif(gate.FUTEX_SYSCALL is None, reason='futex syscall number unknown here')
def busy_receiver(name):
    """A receive thread like rospy's (recv, deserialise, callback), named after its topic,
    that works 0.3 s on each message it reads off its socket before the message counts as
    handled: (the socket to write to, the handled messages, the thread). Closing the socket
    ends it."""
    import socket
    a, b = socket.socketpair()
    done = []

    def receive():
        while True:
            data = a.recv(10)
            if not data:
                a.close()
                return
            t_end = time.monotonic() + 0.3
            while time.monotonic() < t_end:     # deserialising a big message
                pass
            done.append(data)
    th = threading.Thread(target=receive, name=name, daemon=True)
    th.start()
    return b, done, th


def test_a_step_requested_over_a_socket_waits_for_a_message_between_socket_and_gate():
    """The world as a node of its own: a receive thread that has read a message off its
    socket but not yet reached the gate (here: still working on it for 0.3 s) holds the
    step back, so the message lands before the step, not a slice later. An embedded world's
    step (not a request from a socket) does not look: its runner does."""
    b, done, th = busy_receiver('/app/answer')
    try:
        time.sleep(0.05)
        assert gate.receivers_busy() == []                  # waiting for bytes: idle
        # embedded: the runner's own thread asks (not through the gate): no wait
        b.send(b'x')
        time.sleep(0.05)
        assert gate.receivers_busy() == ['/app/answer']
        t0 = time.monotonic()
        gate.close()
        gate.reopen()
        assert not done and time.monotonic() - t0 < 0.2
        while not done:
            time.sleep(0.01)
        done.clear()
        # a world node: the step request is an input this thread is handling
        b.send(b'y')
        time.sleep(0.05)
        with _step_requested_over_a_socket():
            assert done, 'the step began before the message read off its socket was handled'
            assert gate.receivers_busy() == []
    finally:
        b.close()
        th.join(5)
    assert not th.is_alive()


class _SocketTransport(object):
    """What ServiceImpl.handle reads of its transport: one request per receive_once, taken
    off a socket and then 'deserialised' for 0.3 s; closing ends the connection."""

    def __init__(self, sock):
        self.sock = sock

    def receive_once(self):
        from rospy.exceptions import TransportTerminated
        data = self.sock.recv(10)
        if not data:
            raise TransportTerminated('closed')
        t_end = time.monotonic() + 0.3
        while time.monotonic() < t_end:
            pass
        return [data]

    def write_data(self, data):
        pass

    def close(self):
        pass


def test_a_service_request_read_off_its_socket_holds_the_step_back_too():
    """A service connection's thread (rospy leaves it unnamed) is named after its service
    once the gate is installed, so a request it has read and is still deserialising holds
    a step requested over a socket back, as a subscriber's message does."""
    import socket
    gate.install()
    a, b = socket.socketpair()
    done = []
    svc = FakeService(done)
    svc.resolved_name = '/phone/inject_touch'
    svc.response_class = None
    svc.error_handler = lambda *a: None
    svc._write_service_error = lambda *a: None
    svc._handle_request = lambda transport, request: ServiceImpl._handle_request(
        svc, transport, request)
    th = threading.Thread(target=ServiceImpl.handle, daemon=True,
                          args=(svc, _SocketTransport(a), {'persistent': '1'}))
    th.start()
    try:
        time.sleep(0.05)
        assert th.name == '/phone/inject_touch'
        assert gate.receivers_busy() == []                  # waiting for a request
        b.send(b'touch')
        time.sleep(0.05)
        assert gate.receivers_busy() == ['/phone/inject_touch']
        with _step_requested_over_a_socket():
            assert done == [b'touch'], 'the step began before the request was served'
    finally:
        b.close()
        th.join(5)
        a.close()
    assert not th.is_alive()
