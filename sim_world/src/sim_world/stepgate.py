"""Inputs from other nodes wait while the world steps (the pipelined lockstep).

In the testing instance's pipelined lockstep (StepWorld's ``pipeline``) an app works on the
last slice's messages while the world steps the next one. Whatever the app sends meanwhile
(a topic the world subscribes to, a service call to the world) must not reach the world in
the middle of a step, or where it lands would depend on how fast the app is. While the gate
is closed (:func:`close`, from the start of a step to its end) every subscriber callback
this process gets from a socket and every service request it serves waits in the thread
that received it; :func:`reopen` lets them through, in the order of their threads, at the
slice's end, where the testing instance then waits for the apps to answer.

Messages this node publishes to itself (sim_world.fastpub's local deliveries: a world's
/clock, the camera preview of the display, an embedded world's messages to the runner) do
not pass a socket and are not held.
"""
import threading

__all__ = ['close', 'install', 'is_closed', 'reopen', 'wait_open']

_cond = threading.Condition(threading.Lock())
_closed = [False]
_installed = [False]


def close():
    """From now on, inputs from sockets wait (install() first)."""
    install()
    with _cond:
        _closed[0] = True


def reopen():
    """Let every waiting input through, and the ones that come from now on."""
    with _cond:
        _closed[0] = False
        _cond.notify_all()


def is_closed():
    return _closed[0]


def wait_open():
    """Return once the gate is open (at once when it is)."""
    if not _closed[0]:
        return
    with _cond:
        while _closed[0]:
            _cond.wait()


def install():
    """Wrap rospy's delivery of received messages to a subscriber's callbacks and its
    handling of a service request so that both pass :func:`wait_open` first (once per
    process)."""
    if _installed[0]:
        return
    from rospy.impl.tcpros_service import ServiceImpl
    from rospy.topics import _SubscriberImpl
    receive, handle = _SubscriberImpl.receive_callback, ServiceImpl._handle_request

    def receive_callback(self, msgs, connection):
        wait_open()
        return receive(self, msgs, connection)

    def _handle_request(self, transport, request):
        wait_open()
        return handle(self, transport, request)
    _SubscriberImpl.receive_callback = receive_callback
    ServiceImpl._handle_request = _handle_request
    _installed[0] = True
