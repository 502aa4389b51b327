"""The publishers' connections (fastpub before issue 45): counted, timed, held, and sent
without handing the GIL away on every message.

rospy's queued publisher (``queue_size`` set) appends each serialized message to a
per-subscriber queue and then calls ``time.sleep(0)`` "to yield the rest of the thread
quantum" (rospy.impl.tcpros_pubsub.QueuedConnection.write_data). In a process whose main
work is one Python thread stepping the world, that yield hands the GIL to whichever thread
wants it (socket readers, callbacks, the writer threads) and the world thread waits up to
the interpreter's switch interval (5 ms) to get it back -- on every /clock tick and every
image. Profiling sim_world with one 480x800 camera showed this as the largest single cost
on the ROS side (bench/camera).

:func:`no_yield` makes a publisher's future connections use :class:`NoYieldConnection`:
the same queue, writer thread and drop-oldest behaviour, without the ``sleep(0)``. A
message for a connection whose writer thread is idle, with nothing queued, is written to
the socket by the publishing thread itself, without blocking (``MSG_DONTWAIT``), as roscpp
does: no thread wakes for it. Waking the writer thread for every message cost the world
thread a GIL hand-off each time; rosout alone, which subscribes to /clock, made an embedded
scenario 20 % slower (bench/scenario). Only what the socket does not take at once (a big
image, a subscriber that reads slowly) goes through the queue, and the writer thread sends
it in the background (socket writes release the GIL), so a slow or stalled subscriber never
blocks the world: at worst it loses the oldest queued messages, as with rospy's own queue;
a message already begun on the socket is never dropped.

A topic that only subscribers in this node read is not serialized at all: they get the
message objects (:class:`_LocalDelivery`).
"""
import logging
import threading
import time
import weakref

__all__ = ['NoYieldConnection', 'deliver_inline', 'handed_to', 'hold', 'holding', 'no_yield',
           'publisher', 'release', 'set_sim_clock', 'subscribed_here', 'take_times', 'unsent',
           'wait_sent']

log = logging.getLogger('sim_world.transport.connections')

_sim_clock = [None]
_locals = []                   # the live _LocalDelivery objects
_inline_callbacks = set()      # in-process subscriber callbacks run in the publishing thread
_timed_subscribers = set()     # caller ids that asked for times (take_times)
MAX_TIMES = 100000             # per connection, should a subscriber stop asking
_sent = threading.Condition(threading.Lock())   # notified when a connection wrote a message
_connections = weakref.WeakSet()                # the live NoYieldConnections
_zero = threading.local()      # .on: the message this thread is publishing has a zero stamp


def zero_stamped(msg):
    """A message with a header whose stamp is zero: the testing instance times it as one
    without a header (testing_instance.run.intake.stamp_of), so the world notes when it went
    out (take_times) as for a headerless one. Sensors stamp the world's time, which is zero
    at the first tick; the environment and other latched topics may leave it unset."""
    st = getattr(getattr(msg, 'header', None), 'stamp', None)
    return st is not None and not (st.secs or st.nsecs)


def _unstamped_now(unstamped_type):
    return unstamped_type or getattr(_zero, 'on', False)


def set_sim_clock(fn):
    """fn() -> the world's sim time (s): from now on, connections of topics whose messages
    carry no header stamp note the sim time each message was handed over at (take_times)."""
    _sim_clock[0] = fn


try:  # pragma: no branch - rospy is there in the project environment
    from rospy.impl.tcpros_pubsub import QueuedConnection as _Queued
except ImportError:  # pragma: no cover
    _Queued = object


class NoYieldConnection(_Queued):
    """rospy's QueuedConnection without the ``time.sleep(0)`` after each message while the
    writer thread keeps up; once half the queue is waiting (the writer is starved of the
    GIL) it yields like rospy, so messages are not dropped just because the publishing
    thread never lets go. ``handed`` counts the messages handed to this connection (latched
    replays included), ``dropped`` those the full queue lost: the testing instance's slice
    handshake waits for exactly ``handed - dropped`` (see :func:`handed_to`). ``times``
    (a list, for a subscriber that asked, else None) holds, for each message handed over
    since the last :func:`take_times` less those dropped, the sim time it was handed over
    at if it has no header stamp (a headerless type, or a zero stamp: zero_stamped), else
    None."""
    dropped = 0
    handed = 0
    sent = 0
    times = None
    unstamped = False
    busy_since = 0.0      # monotonic time it last got a message with nothing unsent
    last_write = 0.0      # ... and of its last write to the socket
    _writing = False      # the writer thread is writing what it took from the queue
    _partial = False      # the queue's head is the rest of a message begun directly
    _held = None          # [(data, sim time)] held back while the world steps (hold)

    def __init__(self, connection, queue_size):
        super(NoYieldConnection, self).__init__(connection, queue_size)
        write = connection.write_data

        def counted(data):
            # the writer thread's write to the socket: ``sent`` counts it (wait_sent)
            try:
                return write(data)
            finally:
                with _sent:
                    self.sent += 1
                    self.last_write = time.monotonic()
                    _sent.notify_all()
        connection.write_data = counted
        _connections.add(self)

    def unsent(self):
        """Messages handed to this connection, not dropped, not yet written to its socket
        (0 once the connection is closed or failed)."""
        with self._lock:
            if self._error or getattr(self._connection, 'done', False):
                return 0
            return max(0, self.handed - self.dropped - self.sent)

    def write_data(self, data):
        held = _hold[0]
        if held is not None and getattr(self._connection, 'endpoint_id', None) not in held:
            # the pipelined lockstep: sent when the next step begins (release)
            t = _sim_clock[0]() if _sim_clock[0] is not None else None
            with self._lock:
                if self._held is None:
                    self._held = []
                self._held.append((data, t, _unstamped_now(self.unstamped)))
            return True
        return self._hand(data, None, _unstamped_now(self.unstamped))

    def release(self, drop=False):
        """Hand over (or with ``drop`` forget) the messages held back (:func:`hold`), in
        the order they were published, timed at the sim time they were published at."""
        with self._lock:
            held, self._held = self._held, None
        if held and not drop:
            for data, t, unstamped in held:
                self._hand(data, t, unstamped)

    def _hand(self, data, t, unstamped):
        """Hand ``data`` (one serialized message, published at sim time ``t``, None: now;
        ``unstamped``: without a header stamp) to the socket or the queue."""
        with self._lock:
            if self._error:
                error, self._error = self._error, None
                raise error
            if self.handed - self.dropped - self.sent <= 0:
                self.busy_since = time.monotonic()
            self.handed += 1
            times = self.times
            if times is not None and _sim_clock[0] is not None:
                times.append(None if not unstamped else _sim_clock[0]() if t is None else t)
                if len(times) > MAX_TIMES:
                    del times[:len(times) - MAX_TIMES]
            sent_now = False
            if not self._queue and not self._writing:
                n = self._send_now(data)
                sent_now = n == len(data)
                if n and not sent_now:   # the kernel took a part: the writer sends the rest
                    data = data[n:]
                    self._partial = True
            else:
                head = 1 if self._partial else 0      # a message begun is never dropped
                if self._queue_size > 0 and len(self._queue) - head >= self._queue_size:
                    if times is not None:   # the oldest queued one, if handed since the take
                        i = len(times) - 1 - len(self._queue) + head
                        if i >= 0:
                            del times[i]
                    del self._queue[head]
                    self.dropped += 1
            if not sent_now:
                self._queue.append(data)
                self._cond_data_available.notify()
            behind = len(self._queue) > max(1, self._queue_size // 2)
        if sent_now:                # (``sent`` is _sent's, as the writer thread counts)
            with _sent:
                self.sent += 1
                self.last_write = time.monotonic()
                _sent.notify_all()
        if behind:
            time.sleep(0)
        return True

    def _send_now(self, data):
        """Write ``data`` to the socket from the publishing thread, without blocking (under
        self._lock, the writer thread idle and nothing queued): the bytes the kernel took.
        All of them: the message is sent and no thread was woken for it (write_data counts
        it, outside self._lock: wait_sent holds _sent while it asks for self._lock). Fewer:
        the rest goes through the queue as before."""
        conn = self._connection
        sock = getattr(conn, 'socket', None)
        if sock is None or getattr(conn, 'done', False) or not _DIRECT[0]:
            return 0
        try:
            n = sock.send(data, _MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            return 0            # the writer thread meets it again, and rospy closes it
        if n == len(data):
            conn.stat_bytes += n
            conn.stat_num_msg += 1
        return n

    def _run(self):
        """rospy's writer thread (QueuedConnection._run), which also says when it is
        writing: the publishing thread sends directly only while it is not."""
        while not self._connection.done:
            with self._lock:
                while not self._queue and not self._connection.done:
                    self._cond_data_available.wait()
                queue, self._queue = self._queue, []
                self._partial = False
                self._writing = bool(queue)
            try:
                for data in queue:
                    try:
                        self._connection.write_data(data)
                    except Exception as e:  # noqa: BLE001 - as rospy: raised at the next write
                        with self._lock:
                            self._error = e
            finally:
                with self._lock:
                    self._writing = False


_DIRECT = [True]                 # tests turn the direct send off to compare
_hold = [None]                   # hold: the caller ids whose connections are not held
_MSG_DONTWAIT = getattr(__import__('socket'), 'MSG_DONTWAIT', 0)


class _LocalConnection(object):
    """A subscriber in this very node: rospy would send it the serialized bytes over TCP
    loopback and deserialize them in its receive thread. Here the bytes are dropped and the
    publisher hands the message object over (:class:`_LocalDelivery`)."""

    def __init__(self, connection, topic):
        self._connection = connection
        self._topic = topic

    def __getattr__(self, name):
        if name.startswith('__'):
            raise AttributeError(name)
        return getattr(self._connection, name)

    def write_data(self, data):
        if _subscriber_impl(self._topic) is None:        # the local subscriber is gone
            from rospy.exceptions import TransportTerminated
            raise TransportTerminated('local subscriber of %s closed' % self._topic)
        return True


def _subscriber_impl(topic):
    from rospy.impl.registration import get_topic_manager
    tm = get_topic_manager()
    sub = tm.get_subscriber_impl(topic) if tm is not None else None
    if sub is None or getattr(sub, 'closed', False):
        return None
    return sub


def subscribed_here(topic):
    """True when this node has a live subscriber of ``topic`` (resolved name), connected
    or not yet: rospy connects a node's subscriber to the node's own publisher through the
    master, asynchronously, a few hundred ms after both were made."""
    try:
        return _subscriber_impl(topic) is not None
    except ImportError:  # pragma: no cover - rospy is there in the project environment
        return False


class _LocalDelivery(object):
    """Messages for the in-process subscribers of one topic, handed over as objects (no
    serialization, no socket) and run through their callbacks in a thread of their own,
    as rospy runs callbacks in a receive thread. The subscriber's queue_size holds: the
    oldest messages are dropped when it is full."""

    def __init__(self, topic, inline=False, unstamped=False):
        self.topic = topic
        self.inline = inline
        self.unstamped = unstamped
        self.cond = threading.Condition(threading.Lock())
        self.queue = []
        self.thread = None
        self.delivered = 0
        self.closed = False
        # as NoYieldConnection's, for this node's own subscribers (an embedded world's
        # runner is one): messages handed over, of those dropped by a full queue, and the
        # sim times of the unstamped ones since the last take_times (None for the others)
        self.handed = 0
        self.dropped = 0
        self.times = None
        self._sub = None            # the subscriber implementation last looked up
        _locals.append(self)

    def subscriber(self):
        """The live subscriber implementation of the topic in this node, or None. One look-up
        in rospy's topic manager (under its lock) per subscription, not per message: rospy
        closes an implementation when its last Subscriber unregisters and makes a new one
        for a later subscription, so a closed one is looked up again."""
        sub = self._sub
        if sub is None or sub.closed:
            sub = self._sub = _subscriber_impl(self.topic)
        return sub

    def close(self):
        """The publisher is gone (unregistered): the delivery thread ends."""
        with self.cond:
            self.closed = True
            self.queue = []
            self.cond.notify()
        try:
            _locals.remove(self)
        except ValueError:
            pass

    def _note(self, msg):
        """Count a message handed over (under self.cond)."""
        self.handed += 1
        if self.times is None and _own_id() in _timed_subscribers:
            self.times = []
        if self.times is not None and _sim_clock[0] is not None:
            self.times.append(_sim_clock[0]() if self.unstamped or zero_stamped(msg) else None)
            if len(self.times) > MAX_TIMES:
                del self.times[:len(self.times) - MAX_TIMES]

    def put(self, msg):
        sub = self.subscriber()
        if sub is None or self.closed:
            return
        if self.inline:
            with self.cond:
                self._note(msg)
            self._deliver(sub, (msg,))
            return
        if _inline_callbacks:
            now = [cc for cc in sub.callbacks if cc[0] in _inline_callbacks]
            if now:
                with self.cond:
                    self._note(msg)
                for cb, cb_args in now:
                    sub._invoke_callback(msg, cb, cb_args)
                if len(now) == len(sub.callbacks):
                    return
                with self.cond:
                    self._queue(sub, msg, account=False)
                return
        with self.cond:
            self._note(msg)
            self._queue(sub, msg)

    def _queue(self, sub, msg, account=True):
        """For the delivery thread (under self.cond). A full queue drops its oldest; with
        ``account`` those count as dropped (their times go too): not when an inline
        callback had the message already."""
        qs = sub.queue_size or 0
        self.queue.append(msg)
        if qs > 0 and len(self.queue) > qs:
            n = len(self.queue) - qs
            if account and self.times is not None:      # the oldest queued ones' times
                i = len(self.times) - len(self.queue)
                if i >= 0:
                    del self.times[i:i + n]
            del self.queue[:n]
            if account:
                self.dropped += n
        self.cond.notify()
        if self.thread is None:
            self.thread = threading.Thread(target=self._run, daemon=True,
                                           name='local delivery %s' % self.topic)
            self.thread.start()

    def _run(self):
        import rospy
        while not rospy.is_shutdown():
            with self.cond:
                while not self.queue:
                    if self.closed:
                        return
                    self.cond.wait(1.0)
                    if rospy.is_shutdown():
                        return
                msgs, self.queue = self.queue, []
            sub = self.subscriber()
            if sub is not None:
                self._deliver(sub, msgs)

    def _deliver(self, sub, msgs):
        inline = _inline_callbacks if not self.inline else ()
        for msg in msgs:
            for cb, cb_args in sub.callbacks:
                if cb not in inline:            # (those had it in the publishing thread)
                    sub._invoke_callback(msg, cb, cb_args)
            self.delivered += 1


def unsent():
    """Messages this process's publishers handed to remote subscribers' connections and
    have not written to their sockets yet."""
    return sum(c.unsent() for c in list(_connections))


def hold(keep=()):
    """The pipelined lockstep (StepWorld's ``pipeline``): from now on every message for a
    remote subscriber is held back until :func:`release`, except for the nodes named in
    ``keep`` (caller ids: the testing instance that steps the world) and this node itself.
    So an app, which works on what it got while the world steps the next slice, gets
    nothing in the middle of a step: what it sees (the sensors' messages, /clock) is the
    world at the end of a slice, whatever its speed."""
    _hold[0] = frozenset(keep) | {_own_id()}


def release(drop=False, stop=False):
    """Hand every held message to its connection (with ``drop``: forget them, for a world
    started over); with ``stop`` hold nothing from now on. A message published while this
    runs waits for the next release if the hold goes on."""
    if stop:
        _hold[0] = None
    for c in list(_connections):
        c.release(drop)


def holding():
    return _hold[0] is not None


def wait_sent(stall=0.2):
    """Block until every message handed to a remote subscriber's connection is written to
    its socket (so it is in the subscriber's receive queue, where the testing instance's
    evidence that an app has answered looks). A connection that has had messages to write
    and written none for ``stall`` s of wall time (a subscriber that stopped reading: its
    socket is full, its writer blocked) is not waited for, now or at later calls until it
    writes again: a stalled rviz or rostopic costs one ``stall``, not one per step; the
    appwatch names a stalled app. True: every message is written."""
    with _sent:
        while True:
            conns = [c for c in list(_connections) if c.unsent()]
            now = time.monotonic()
            moving = [max(c.last_write, c.busy_since) + stall for c in conns]
            moving = [t for t in moving if t > now]
            if not moving:
                return not conns
            _sent.wait(min(moving) - now)


def deliver_inline(callback, on=True):
    """Run ``callback`` (a rospy.Subscriber callback of this node) in the publishing thread
    for messages of this node's own publishers, instead of waking a delivery thread per
    message: for a cheap callback whose caller waits for the publisher anyway (the runner
    of an embedded world, whose step is a function call: one thread and no GIL hand-offs).
    The callback must not wait for the publishing thread."""
    if on:
        _inline_callbacks.add(callback)
    else:
        _inline_callbacks.discard(callback)


def _only_local(impl, local):
    """True when every connection of the publisher ``impl`` is to a live subscriber in this
    node (an embedded world's runner, rospy's own /clock subscriber; ``local``: the topic's
    :class:`_LocalDelivery`): then rospy would serialize each message only for
    :class:`_LocalConnection` to drop the bytes."""
    conns = impl.connections
    if not conns or impl.closed:
        return False
    for c in conns:
        if type(c) is not _LocalConnection:
            return False
    return local.subscriber() is not None


def _number(impl, msg):
    """What rospy's publish does to a message besides sending its bytes, for a message
    only this node's subscribers get: the topic's sequence number in its header (and a
    frame_id of None made '0'), under the publisher's lock, so that a recording holds the
    same header as when the message went through rospy (rospy.msg.serialize_message).
    False: the topic closed meanwhile (rospy's own publish says how)."""
    impl.acquire()
    try:
        if impl.closed:
            return False
        impl.seq += 1
        if getattr(msg.__class__, '_has_header', False):
            h = msg.header
            h.seq = impl.seq
            if h.frame_id is None:
                h.frame_id = '0'
        return True
    finally:
        impl.release()


def no_yield(pub, inline_local=False):
    """Make ``pub`` (a rospy.Publisher created with a queue_size) queue its messages
    through NoYieldConnection for every remote subscriber that connects from now on, and
    hand messages to subscribers in this same node as objects (no serialization, no
    socket; a latched topic keeps rospy's path). With ``inline_local`` those subscribers'
    callbacks run in the publishing thread itself (for trivial callbacks on frequent
    messages, such as rospy's own /clock subscriber in sim_world: waking a delivery thread
    per message would cost more than the callback). Returns pub. A topic whose publisher
    implementation already has connections, or was created without a queue, is left as
    it is."""
    import rospy
    impl = getattr(pub, 'impl', None)
    qs = getattr(impl, 'queue_size', None)
    if impl is None or qs is None or getattr(impl, '_no_yield', False) or impl.connections:
        return pub
    orig_add = impl.add_connection
    topic = impl.resolved_name
    headered = getattr(pub.data_class, '_has_header', True)
    local = _LocalDelivery(topic, inline_local, not headered) if not impl.is_latch else None

    def add_connection(c):
        if local is not None and getattr(c, 'endpoint_id', None) == rospy.get_caller_id():
            return orig_add(_LocalConnection(c, topic))
        nc = NoYieldConnection(c, qs)
        nc.unstamped = not headered
        if getattr(c, 'endpoint_id', None) in _timed_subscribers:
            nc.times = []           # from its first message (a latched one) on
        if not (headered and impl.is_latch):
            return orig_add(nc)
        with impl.publock:          # (an RLock) the latched message it is sent at once
            _zero.on = impl.latch is not None and zero_stamped(impl.latch)
            try:
                return orig_add(nc)
            finally:
                _zero.on = False
    impl.queue_size = None          # the original add_connection must not wrap it again
    impl.add_connection = add_connection
    impl._no_yield = True

    def message(args, kwds):
        if len(args) == 1 and not kwds and isinstance(args[0], pub.data_class):
            return args[0]
        from rospy.msg import args_kwds_to_message
        return args_kwds_to_message(pub.data_class, args, kwds)
    if local is not None:
        orig_publish = pub.publish

        def publish(*args, **kwds):
            if _only_local(impl, local):
                msg = message(args, kwds)
                if _number(impl, msg):
                    local.put(msg)
                    return
            orig_publish(*args, **kwds)
            if any(isinstance(c, _LocalConnection) for c in impl.connections):
                local.put(message(args, kwds))
        pub.publish = publish
        pub.local_delivery = local
        orig_unregister = pub.unregister

        def unregister():
            local.close()           # its thread would wait for messages forever
            orig_unregister()
        pub.unregister = unregister
    if headered:
        inner = pub.publish

        def publish_noting_zero_stamps(*args, **kwds):
            # the connections time a message with a zero stamp (zero_stamped) as one
            # without a header: the flag is this thread's, for this publish
            msg = message(args, kwds)
            _zero.on = zero_stamped(msg)
            try:
                return inner(msg)
            finally:
                _zero.on = False
        pub.publish = publish_noting_zero_stamps
    return pub


def publisher(topic, msg_type, queue_size=10, inline_local=False, **kw):
    """rospy.Publisher(topic, msg_type, queue_size=queue_size, **kw) passed through
    :func:`no_yield`."""
    import rospy
    return no_yield(rospy.Publisher(topic, msg_type, queue_size=queue_size, **kw),
                    inline_local=inline_local)


def _connections_to(subscriber, topic_manager=None):
    """(topic, NoYieldConnection) of this node's publishers to the node ``subscriber``."""
    if topic_manager is None:
        from rospy.impl.registration import get_topic_manager
        topic_manager = get_topic_manager()
    if topic_manager is None or not subscriber:
        return
    for topic, _typ in topic_manager.get_publications():
        impl = topic_manager.get_publisher_impl(topic)
        if impl is None:
            continue
        for c in list(impl.connections):
            if isinstance(c, NoYieldConnection) and \
                    getattr(c, 'endpoint_id', None) == subscriber:
                yield topic, c


def _own_id():
    import rospy
    return rospy.get_caller_id()


def _locals_to(subscriber):
    """The local deliveries that reach ``subscriber`` (this node itself: an embedded world's
    runner) and have a subscriber now."""
    if not subscriber or subscriber != _own_id():
        return []
    return [d for d in list(_locals) if not d.closed and _subscriber_impl(d.topic) is not None]


def handed_to(subscriber, topic_manager=None):
    """{topic: (handed, dropped)} over this node's publisher connections to the node
    ``subscriber`` (its caller id) that go through :class:`NoYieldConnection`: how many
    messages each topic handed to that subscriber since its connection opened, and how
    many of those a full queue dropped. Topics of publishers outside :func:`no_yield` are
    not listed (their counts are unknown)."""
    out = {}
    for topic, c in _connections_to(subscriber, topic_manager):
        h, d = out.get(topic, (0, 0))
        with c._lock:
            out[topic] = (h + c.handed, d + c.dropped)
    for loc in _locals_to(subscriber):
        h, d = out.get(loc.topic, (0, 0))
        with loc.cond:
            out[loc.topic] = (h + loc.handed, d + loc.dropped)
    return out


def take_times(subscriber, topic_manager=None):
    """{topic: [sim time, ...]} of the messages without header stamps (headerless types,
    and messages whose stamp is zero: zero_stamped) that this node's publishers handed to
    the node ``subscriber`` since the last call, in the order sent (and forgets them). The
    first call starts the recording for that subscriber (its connections opened later are
    timed from their first message on)."""
    if subscriber:
        _timed_subscribers.add(subscriber)
    holders = [(topic, c, c._lock) for topic, c in _connections_to(subscriber, topic_manager)]
    holders += [(loc.topic, loc, loc.cond) for loc in _locals_to(subscriber)]
    out = {}
    for topic, holder, lock in holders:
        with lock:
            got = holder.times
            if got is not None:
                holder.times = []
        got = [t for t in got if t is not None] if got else None
        if got:
            out.setdefault(topic, []).extend(got)
    return out
