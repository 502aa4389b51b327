"""Inputs from other nodes wait while the world steps a slice of the testing instance's
lockstep.

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

Messages this node publishes to itself (sim_world.fastpub's local deliveries: a world's
/clock, the camera preview of the display, an embedded world's messages to the runner) do
not pass a socket and are not held.
"""
import logging
import threading
import time

__all__ = ['close', 'install', 'is_closed', 'reopen']

log = logging.getLogger('sim_world.stepgate')

_cond = threading.Condition(threading.Lock())
_closed = [False]
_installed = [False]
_active = {}             # thread ident -> inputs it is handling, past the gate
CLOSE_WAIT = 5.0         # s of wall time close() waits for inputs in hand


def close(wait=CLOSE_WAIT):
    """From now on, inputs from sockets wait (install() first); returns once the inputs
    already let through are handled (other threads' only: the caller may be serving one,
    the step request itself), at most ``wait`` s of wall time."""
    install()
    me = threading.get_ident()
    with _cond:
        _closed[0] = True
        deadline = time.monotonic() + wait
        while any(t != me for t in _active):
            left = deadline - time.monotonic()
            if left <= 0:
                log.warning('stepgate: %d input(s) still in hand after %.1f s: the step '
                            'begins anyway', sum(n for t, n in _active.items() if t != me),
                            wait)
                break
            _cond.wait(left)


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
    they run (once per process). Before any subscriber connects (sim_world.gazebo_api does
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
    _SubscriberImpl.receive_callback = receive_callback
    ServiceImpl._handle_request = _handle_request
    _installed[0] = True
