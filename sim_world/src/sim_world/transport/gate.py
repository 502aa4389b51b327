"""The gate (stepgate before issue 45): inputs from other nodes wait while the world steps a
slice of the testing instance's lockstep.

In the lockstep an app answers what a slice brought it; what it sends (a topic the world
subscribes to, a service call to the world) must not reach the world in the middle of a
step, or where it lands would depend on how fast the app is: a quick app's
``display/enable`` took effect at the same tick as the proximity reading it answered on a
quiet machine, a tick later under load (bench/load, the battery's power_state). While the
gate is closed (:func:`close`, from the start of a step to its end) every subscriber
callback this process gets from a socket and every service request it serves waits in the
thread that received it; :func:`reopen` lets them through, in the order of their threads,
at the slice's end, where the testing instance then waits for the apps to answer. The
pipelined lockstep (StepWorld's ``pipeline``) relies on it as well: there the app works on
the last slice's messages while the world steps the next one.

:func:`close` also waits until every input already let through has been handled (a
callback that began before the step ends before the step begins), so an input lands at a
slice boundary, never inside a step.

A world that is a node of its own (the step request came over a socket) first waits,
before it closes the gate, until none of its receive threads (a subscriber's, or one
serving a service connection) holds a message or request it has taken off its socket and
not yet brought to the gate (:func:`receivers_busy`): the testing
instance's evidence that an app has answered ends at the world's socket queues, and a
message read from its socket, still being deserialised or waiting for the GIL, is in no
queue (bench/load found the NFC example's OK recorded a slice late in 1 attached run of 6).
An embedded world's runner checks the same threads itself, as its own: after a slice (the
apps' answers) and, with :func:`settle`, before a step that follows its own actions'
messages to the world (a radio switched off at sim time 0 landed a slice late under load).

Messages this node publishes to itself (sim_world.transport.connections' local deliveries: a world's
/clock, the camera preview of the display, an embedded world's messages to the runner) do
not pass a socket and are not held.
"""
import logging
import platform
import threading
import time

__all__ = ['FUTEX_SYSCALL', 'close', 'install', 'is_closed', 'receivers_busy', 'reopen',
           'settle']

log = logging.getLogger('sim_world.transport.gate')

_cond = threading.Condition(threading.Lock())
_closed = [False]
_installed = [False]
_active = {}             # thread ident -> inputs it is handling, past the gate
CLOSE_WAIT = 5.0         # s of wall time close() waits for inputs in hand


def close(wait=CLOSE_WAIT):
    """From now on, inputs from sockets wait (install() first); returns once the inputs
    already let through are handled (other threads' only: the caller may be serving one,
    the step request itself), at most ``wait`` s of wall time. Called while serving a
    request from a socket (the world is a node of its own), it first waits until no
    receive thread holds a message between its socket and the gate."""
    install()
    me = threading.get_ident()
    deadline = time.monotonic() + wait
    if me in _active:
        _settle(me, deadline, wait)
    with _cond:
        _closed[0] = True
        while any(t != me for t in _active):
            left = deadline - time.monotonic()
            if left <= 0:
                log.warning('stepgate: %d input(s) still in hand after %.1f s: the step '
                            'begins anyway', sum(n for t, n in _active.items() if t != me),
                            wait)
                break
            _cond.wait(left)


def settle(wait=CLOSE_WAIT):
    """Until no receive thread of this process but the caller's is busy (receivers_busy):
    a message written to one of its sockets has been taken off and handled. At most
    ``wait`` s of wall time (a WARNING then). For a caller that is not itself an input,
    such as an embedded world's runner before it steps past its own actions' messages
    (close() does it for a step requested over a socket). True when settled."""
    return _settle(threading.get_ident(), time.monotonic() + wait, wait)


def _settle(me, deadline, wait):
    """Until no receive thread but ``me`` is busy (receivers_busy), at most to
    ``deadline`` (``wait`` s after close() began); the wait hands the GIL to them."""
    busy = receivers_busy(exclude=me)
    while busy:
        if time.monotonic() >= deadline:
            log.warning('stepgate: the receive thread of %s still busy after %.1f s: the '
                        'step begins anyway', busy[0], wait)
            return False
        with _cond:
            _cond.wait(0.0005)
        busy = receivers_busy(exclude=me)
    return True


# the futex syscall's number (a thread waiting for a lock: the GIL), per architecture
FUTEX_SYSCALL = {'x86_64': '202', 'aarch64': '98', 'riscv64': '98'}.get(platform.machine())


def receivers_busy(exclude=None):
    """Names of this process's rospy subscriber connection threads (rospy names each after
    its topic) and service connection threads (named after their service by install();
    but thread ``exclude``) that are running, waiting for a lock or blocked
    outside a system call (/proc/self/task/TID/syscall: ``running``, the futex call,
    ``-1``: a page fault reading code or data from disk). An idle one waits in the kernel
    for bytes; one that has taken a message's bytes off its socket (the socket's queue is
    empty again) and has not yet handed the message to its callbacks is running or, behind
    the GIL, waiting on a futex. [] where the futex syscall's number is not known (another
    architecture)."""
    if FUTEX_SYSCALL is None:
        return []
    out = []
    for th in threading.enumerate():
        if not th.name.startswith('/') or not getattr(th, 'native_id', None) \
                or th.ident == exclude:
            continue
        try:
            with open('/proc/self/task/%d/syscall' % th.native_id) as f:
                call = f.read().split(None, 1)[0]
        except (OSError, IndexError):
            continue                                  # it ended just now
        if call in ('running', FUTEX_SYSCALL, '-1'):
            out.append(th.name)
    return out


def reopen():
    """Let every waiting input through, and the ones that come from now on."""
    with _cond:
        _closed[0] = False
        _cond.notify_all()


def is_closed():
    return _closed[0]


def _enter():
    """An input passes the gate (waits while it is closed) and counts as in hand."""
    me = threading.get_ident()
    with _cond:
        while _closed[0]:
            _cond.wait()
        _active[me] = _active.get(me, 0) + 1


def _leave():
    me = threading.get_ident()
    with _cond:
        n = _active.get(me, 1) - 1
        if n > 0:
            _active[me] = n
        else:
            _active.pop(me, None)
            _cond.notify_all()


def install():
    """Wrap rospy's delivery of received messages to a subscriber's callbacks and its
    handling of a service request so that both pass the gate first and are counted while
    they run, and name each thread serving a service connection after the service
    (receivers_busy), once per process. Before any subscriber connects (sim_world.gazebo_api does
    it as it starts): each connection's receive thread keeps the receive_callback it was
    given, so connections made before the wrapping would bypass the gate."""
    if _installed[0]:
        return
    from rospy.impl.tcpros_service import ServiceImpl
    from rospy.topics import _SubscriberImpl
    receive, handle = _SubscriberImpl.receive_callback, ServiceImpl._handle_request

    def receive_callback(self, msgs, connection):
        _enter()
        try:
            return receive(self, msgs, connection)
        finally:
            _leave()

    def _handle_request(self, transport, request):
        _enter()
        try:
            return handle(self, transport, request)
        finally:
            _leave()
    handle_connection = ServiceImpl.handle

    def serve_connection(self, transport, header):
        # rospy leaves the thread serving a service connection unnamed; named after the
        # service, like a subscriber's receive thread after its topic, receivers_busy sees
        # a request read off its socket and not yet at the gate
        threading.current_thread().name = self.resolved_name
        return handle_connection(self, transport, header)
    _SubscriberImpl.receive_callback = receive_callback
    ServiceImpl._handle_request = _handle_request
    ServiceImpl.handle = serve_connection
    _installed[0] = True
