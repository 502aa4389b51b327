"""sim_world.transport: the one place that knows rospy's internals (issue 45).

The testing instance's lockstep needs three things rospy's public API does not give: how
many messages a given subscriber was handed in a slice (and how many a full queue dropped),
inputs from other nodes held at a slice boundary, and the sim time each unstamped message
went out at. rospy also yields the GIL after every queued message and wakes a thread per
message. So this package replaces or wraps a few of rospy's classes and reads some of its
private fields; nothing outside it may (test/unit/test_transport_fence.py), and importing it
checks that rospy is the version it was written for, with every attribute it uses
(:mod:`.version`; a mismatch stops the process with one line). sim_world/README.md draws it.

Every publisher the world makes itself goes through this facade (/clock, /tf, the Gazebo
API's topics, every plugin output through the sensor base: the camera, the display, the
sensors). A library that makes its own publishers is the named exception: actionlib's
action server (sim_world.control's trajectory actions) publishes status, feedback and result
through plain rospy publishers, which the slice handshake does not count (the testing
instance waits for them by a quiet period, as for any publisher it does not count).

The facade's public names (the only ones other modules use):

Publishing (the world's side)
  ``publisher(topic, msg_type, queue_size=10, inline_local=False, latch=False, ...)``
      a rospy.Publisher whose connections are counted and timed for the slice report,
      sent without rospy's per-message GIL yield, and handed to this node's own subscribers
      as objects; ``inline_local``: those subscribers' callbacks run in the publishing thread.
  ``no_yield(pub)``         the same for a rospy.Publisher made elsewhere.
  ``subscribed_here(topic)``  True when this node itself subscribes ``topic`` (the camera asks).
  ``set_sim_clock(fn)``     fn() -> sim time: unstamped messages are timed by it.
  ``zero_stamped(msg)``     a header stamp of zero, timed as an unstamped message.

Subscribing and serving (inputs, which the gate holds)
  ``subscriber(topic, msg_type, callback, ..., inline=False)``  a rospy.Subscriber; with
      ``inline`` messages from this node's own publishers reach ``callback`` in the
      publishing thread (``deliver_inline(callback, on=True)`` does it for one made before).
  ``service(name, srv_type, handler)``  a rospy.Service.
  ``local_service(name)``   a service of this very process, called as a function
      (``LocalService``: a ServiceProxy's interface); None when it does not serve ``name``.
  ``connection_header(msg)``  rospy's header of a received message ({'callerid': ...}), None
      for one handed over in this process.
  ``received_count(sub)``   messages rospy has deserialised for a subscriber so far.
  ``on_new_publisher(callback)`` / ``remove_listener(listener)``  callback(topic) for each
      publisher this process declares from now on.
  ``set_namespace(ns)``     this process's node namespace, before rospy.init_node.

The gate (inputs from sockets wait while the world steps a slice)
  ``install()``             once, after rospy.init_node and before any subscriber connects:
      the gate and the TCPROS handshake guard (``install_gate()``, ``guard_handshakes()``:
      each alone).
  ``close_gate(wait=5.0)``  inputs wait from now on; returns once those let through are handled.
  ``reopen_gate()``         lets them through.
  ``settle(wait=5.0)``      until no receive thread holds a message between socket and gate.
  ``gate_closed()``, ``receivers_busy(exclude=None)``, ``FUTEX_SYSCALL`` (the futex syscall's
      number here, None where unknown: receivers_busy then sees nothing).

The per-slice report (what the world handed one subscriber)
  ``slice_report(subscriber)``  after a step: waits until the messages are in the sockets
      (``wait_sent``), then ``SliceReport(handed={topic: (handed, dropped)},
      times={topic: [sim time of each unstamped message]})``; ``handed_to(subscriber)`` and
      ``take_times(subscriber)`` each alone.
  ``hold(keep=())``, ``release(drop=False, stop=False)``, ``holding()``  the pipelined
      lockstep: messages to other nodes wait for the next step's beginning.
  ``wait_sent(stall=0.2)``, ``unsent()``  messages handed over and not yet in the sockets.

The check at import (:mod:`.version`)
  ``WRITTEN_FOR``           the rospy version this layer was written for (Debian 12's).
  ``RospyMismatch``         a SystemExit raised at import when rospy is another version or
      lacks an attribute the layer uses: one line, naming both, and no traceback.

Modules: :mod:`.connections` (the connections, counts, times, local delivery; fastpub
before issue 45), :mod:`.gate` (stepgate), :mod:`.tcpros_guard`, :mod:`.local` (this
process's node: from the testing instance's embed and intake), :mod:`.version`.
"""
import collections

from . import version as _version

_version.check()

from . import connections as _connections  # noqa: E402 - after the check
from . import gate as _gate  # noqa: E402
from . import local as _local  # noqa: E402
from . import tcpros_guard as _tcpros_guard  # noqa: E402
from .connections import (deliver_inline, handed_to, hold, holding, no_yield,  # noqa: E402
                          publisher, release, set_sim_clock, subscribed_here, take_times,
                          unsent, wait_sent, zero_stamped)
from .gate import FUTEX_SYSCALL, receivers_busy, settle  # noqa: E402
from .local import (LocalService, connection_header, local_service,  # noqa: E402
                    on_new_publisher, received_count, remove_listener, set_namespace)
from .version import WRITTEN_FOR, RospyMismatch  # noqa: E402

__all__ = ['FUTEX_SYSCALL', 'LocalService', 'RospyMismatch', 'SliceReport', 'WRITTEN_FOR',
           'close_gate', 'connection_header', 'deliver_inline', 'gate_closed',
           'guard_handshakes', 'handed_to', 'hold', 'holding', 'install', 'install_gate',
           'local_service', 'no_yield', 'on_new_publisher', 'publisher', 'received_count',
           'release', 'remove_listener', 'reopen_gate', 'receivers_busy', 'service',
           'set_namespace', 'set_sim_clock', 'settle', 'slice_report', 'subscribed_here',
           'subscriber', 'take_times', 'unsent', 'wait_sent', 'zero_stamped']

#: what the world handed one subscriber since the last report: {topic: (handed, dropped)}
#: and {topic: [sim time, ...]} of its unstamped messages, in the order sent
SliceReport = collections.namedtuple('SliceReport', 'handed times')


def install():
    """The gate and the handshake guard, once per process (idempotent)."""
    _tcpros_guard.install()
    _gate.install()


def guard_handshakes():
    """Only the TCPROS handshake guard (tcpros_guard)."""
    _tcpros_guard.install()


def install_gate():
    """Only the gate (stepgate)."""
    _gate.install()


def close_gate(wait=_gate.CLOSE_WAIT):
    _gate.close(wait)


def reopen_gate():
    _gate.reopen()


def gate_closed():
    return _gate.is_closed()


def slice_report(subscriber):
    """After a step: wait until its messages to remote subscribers are in their sockets,
    then what it handed ``subscriber`` (a caller id; '' or None: nothing)."""
    wait_sent()
    if not subscriber:
        return SliceReport({}, {})
    return SliceReport(handed_to(subscriber), take_times(subscriber))


def subscriber(topic, msg_type, callback, callback_args=None, queue_size=None,
               buff_size=65536, tcp_nodelay=False, inline=False):
    """rospy.Subscriber (its inputs pass the gate once :func:`install` ran); ``inline``:
    this node's own publishers call ``callback`` in their thread (deliver_inline)."""
    import rospy
    sub = rospy.Subscriber(topic, msg_type, callback, callback_args=callback_args,
                           queue_size=queue_size, buff_size=buff_size,
                           tcp_nodelay=tcp_nodelay)
    if inline:
        deliver_inline(callback)
    return sub


def service(name, srv_type, handler):
    """rospy.Service (its requests pass the gate once :func:`install` ran)."""
    import rospy
    return rospy.Service(name, srv_type, handler)
