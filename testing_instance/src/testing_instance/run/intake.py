"""What comes into a run: the runner's subscriptions, the time of each message, and its way
into the Inbox (for the expectations) and the Recorder.

- ``subscribe(wanted)``: one rospy Subscriber per wanted topic that somebody publishes,
  then (``classify``) which of them the world counts for the slice handshake and which come
  from publishers that do not count (waited for by a quiet period), and
  ``wait_publisher_side``: until the world's publishers list this node (a sensor publishes
  only while subscribed).
- ``on_message``: every message's sim time: its header stamp, else (once stepping) it is
  held and timed by ``stamp_held`` at the end of the slice handshake that collects it: the
  world's by the publication times its step answer lists (``note_times``), an app's by the
  slice's end. So an unstamped message's time is the same in every run. A message the world
  published after its step answer (while paused: its answer to an app's input, such as the
  NFC proxy's delivery of an app's ``nfc/outgoing``) can arrive before the next answer lists
  it: it went out at the slice's end, and the next answer's first time on its topic is its
  own (``unlisted``). Before, it took the runner's clock on arrival, which lags the world's
  under load when the world is a node of its own (bench/load: the NFC example's OK at
  1.05 s or 1.06 s instead of 1.10 s in a loaded warm farm), and the next answer's time for
  it stayed in the queue, where it timed the topic's next such message.
"""
import collections
import time

from sim_world import transport

from ..world.procs import outbound, poll
from .recording import EVENTS_TOPIC, HEAVY_TYPES

#: wall s a new subscription of the runner's may take to connect (both sides) before the run
#: says so and goes on without it
CONNECT_WAIT = 10.0

__all__ = ['Intake', 'stamp_of']


def stamp_of(msg):
    """The message's header stamp (s), or None when it has none (or a zero one)."""
    h = getattr(msg, 'header', None)
    st = getattr(h, 'stamp', None)
    if st is not None and (st.secs or st.nsecs):
        return st.to_sec()
    return None


class Intake(object):
    def __init__(self, inbox, recorder, say=None, debug=False):
        self.inbox = inbox
        self.recorder = recorder
        self.say = say or (lambda s: None)
        self.debug = debug
        self.rospy = None          # set by start() once the node is initialised
        self.embedded = False      # the world is this node: its messages have no header
        self.own_topics = frozenset  # () -> the topics this node's own publishers use
        self.subs = {}             # topic -> rospy.Subscriber
        self.topic_types = {}      # topic -> type, of the topics somebody publishes
        self.world_node = None     # the caller id serving /gazebo/step_world
        self._master = None        # rosgraph.Master, kept (master())
        self.world_topics = set()  # subscribed topics the world publishes
        self.uncounted = set()     # subscribed topics with publishers that do not count
        self.hold_unstamped = False  # once stepping: unstamped messages are held
        self.input_node = None     # the caller id of the inputs: the world, or a replay
        self.input_times = {}      # topic -> deque of sim times of its unstamped inputs
        self.unlisted = {}         # topic -> deque of the times given to the world's messages
        #                            that arrived before an answer listed them (note_times)
        self.mislisted = []        # (topic, time given, time listed) where they differ
        self._listener = None      # rospy's registration listener (on_new_publisher)

    def start(self, rospy, embedded=False, own_topics=None):
        self.rospy = rospy
        self.embedded = embedded
        if own_topics is not None:
            self.own_topics = own_topics

    def on_new_publisher(self, callback):
        """callback(topic) whenever this process declares a publisher from now on: an
        embedded world's plugins made after a spawn or later in a run. rospy's registration
        listeners, through which rospy itself tells the master."""
        self._listener = transport.on_new_publisher(callback)

    def world_name(self):
        """The world node's name: the node serving /gazebo/step_world (/lab/sim_world in a
        namespace), else the default /sim_world."""
        return self.world_node or '/sim_world'

    # -- subscribing -----------------------------------------------------------------------
    def published_types(self):
        """{topic: type} of the topics somebody publishes (getTopicTypes would also list
        topics only subscribed to); OSError or rosgraph.MasterException when the master
        does not answer."""
        self.topic_types = dict(self.master().getPublishedTopics('/'))
        return self.topic_types

    def master(self):
        """The master's API for this intake's own look-ups (the runner's thread): one
        rosgraph.Master, whose connection stays open (rosmaster speaks HTTP/1.1; a new
        proxy a call cost a TCP connection and a handler thread in the master: 2.4 ms of
        each periodic look for new topics in a run, 0.96 against 0.60 ms alone)."""
        if self._master is None:
            import rosgraph
            self._master = rosgraph.Master('/scenario_runner')
        return self._master

    def subscribe(self, wanted, check_fields=None, apps=(), wait_connections=True):
        """Subscribe every topic of ``wanted`` that is published and not yet subscribed
        (``check_fields(topic, cls)`` first); returns the new topics."""
        import roslib.message
        new = []
        for topic in wanted:
            if topic in self.subs or topic == EVENTS_TOPIC:
                continue
            typ = self.topic_types.get(topic)
            if typ is None:
                continue
            cls = roslib.message.get_message_class(typ)
            if cls is None:
                continue
            if check_fields is not None:
                check_fields(topic, cls)
            # rospy's recv() allocates buff_size for every read: 16 MB only for images and
            # clouds (one read a frame); a 16 MB buffer per read of a 300-byte IMU message
            # fragmented the heap (bench/soak: +5.4 % RSS over an hour)
            self.subs[topic] = self.rospy.Subscriber(
                topic, cls, self.on_message, callback_args=topic, queue_size=1000,
                buff_size=1 << 24 if typ in HEAVY_TYPES else 1 << 16, tcp_nodelay=True)
            new.append(topic)
        if not new:
            return new
        pubs = self._publishers()          # one master round trip serves both
        self.classify(new, apps, pubs)
        if wait_connections:
            deadline = time.monotonic() + CONNECT_WAIT
            poll(lambda: all(self.subs[t].get_num_connections() for t in new), deadline)
            unconnected = [t for t in new if self.subs[t].get_num_connections() == 0]
            if unconnected:
                # said, not silent: what they publish until they connect is not in the run
                self.say('WARNING no publisher of %s connected to the runner within %g s of '
                         'wall time; their messages until one does are lost'
                         % (', '.join(unconnected), CONNECT_WAIT))
            self.wait_publisher_side(new, deadline, pubs)
            if self.debug:
                self.say('subscribed %s; unconnected: %s' % (new, unconnected))
        return new

    def _publishers(self):
        """getSystemState's publishers ([topic, [node, ...]], ...), or None when the master
        does not answer."""
        try:
            return self.master().getSystemState()[0]
        except Exception:  # noqa: BLE001 - OSError, rosgraph.MasterException
            return None

    def classify(self, topics, apps=(), pubs=None):
        """Which new topics the world counts for the handshake, which come from publishers
        that do not count (waited for with a quiet period). ``apps``: the apps' node names
        (their outputs are waited for by evidence, appwatch). ``pubs``: getSystemState's
        publishers, asked for when not given."""
        if pubs is None:
            pubs = self._publishers()
        if pubs is None:
            self.uncounted.update(topics)
            return
        by_topic = dict((t, set(ns)) for t, ns in pubs)
        for t in topics:
            nodes = by_topic.get(t, set())
            if self.world_node in nodes:
                self.world_topics.add(t)
            if nodes - {self.world_node} - set(apps) or self.world_node is None:
                self.uncounted.add(t)

    def wait_publisher_side(self, topics, deadline, pubs=None):
        """Wait until the world's publishers count this node as a subscriber: a sensor
        publishes only while subscribed, so a connection still being accepted on the world's
        side would cost the first message in one run and not in another. ``pubs``:
        getSystemState's publishers, asked for when not given."""
        from xmlrpc.client import ServerProxy
        master = self.master()
        me = self.rospy.get_name()
        world = self.world_name()
        if pubs is None:
            pubs = self._publishers()
        if pubs is None:
            return
        want = {t for t, ns in pubs if world in ns and t in topics}
        if not want:
            return     # none is the world's (or no world node: a replay, other launch files)
        try:
            node_uri = master.lookupNode(world)
        except Exception:  # noqa: BLE001 - the world node is gone
            return
        node = ServerProxy(node_uri)

        missing = [want]

        def accepted():
            try:
                missing[0] = want - {t for sub, t in outbound(node, me) if sub == me}
            except Exception:  # noqa: BLE001 - the world node is gone: nothing to wait for
                return True
            return not missing[0]
        if not poll(accepted, deadline, first=0.002):
            self.say('WARNING the world node %s did not take the runner\'s connection to %s '
                     'within %g s of wall time; its messages until it does are lost'
                     % (world, ', '.join(sorted(missing[0])), CONNECT_WAIT))

    def undelivered(self):
        """A subscribed topic of which rospy has deserialised more messages than reached the
        inbox (still in its callback queue), or None."""
        for topic, sub in list(self.subs.items()):
            if transport.received_count(sub) > self.inbox.counts.get(topic, 0):
                return topic
        return None

    def close(self, unregister=True):
        """Unsubscribe everything (``unregister=False``: the master is gone, rospy's own
        clean-up at exit is one quiet call instead of a failing one per topic), and stop
        listening for new publishers (a later run in this process has its own listener)."""
        for s in self.subs.values():
            if unregister:
                s.unregister()
        listener, self._listener = self._listener, None
        if listener is not None:
            transport.remove_listener(listener)

    # -- timing ----------------------------------------------------------------------------
    def on_message(self, msg, topic):
        """A subscription's callback (an embedded world calls it in its own thread)."""
        t = stamp_of(msg)
        hdr = transport.connection_header(msg)
        # a message handed over in this process (an embedded world's) has no header
        caller = hdr.get('callerid') if hdr else (self.world_node if self.embedded else None)
        if self.embedded and hdr and topic in self.own_topics():
            caller = None   # this node's own action publisher, not the world it also is
        world = caller == self.world_node
        if t is None and self.hold_unstamped:
            self.inbox.hold(topic, msg, from_world=world, tag=self.rospy.get_rostime(
                ).to_sec() if caller == self.input_node else None)
            return
        if t is None:
            t = self.rospy.get_rostime().to_sec()
        if self.debug and not hasattr(msg, 'header'):
            self.say('  debug: %s at %.3f' % (topic, t))
        self.inbox.put(t, topic, msg, from_world=world)
        if self.recorder.active:
            self.recorder.write(topic, msg, t)

    def note_times(self, answer):
        """The step answer's publication times of the world's unstamped messages."""
        k = 0
        for topic, n in zip(answer.timed_topics, answer.timed_counts):
            if topic in self.subs:
                times = list(answer.times[k:k + n])
                given = self.unlisted.get(topic)
                while given and times:       # timed already (_time_held): not again
                    t_given, t_listed = given.popleft(), times.pop(0)
                    if abs(t_given - t_listed) > 1e-9:
                        self.mislisted.append((topic, t_given, t_listed))
                        self.say('intake: %s: a message timed %.3f s on arrival was listed '
                                 'at %.3f s by the world' % (topic, t_given, t_listed))
                self.input_times.setdefault(topic, collections.deque()).extend(times)
            k += n

    def input_at(self, topic, t):
        """An unstamped input a replay publishes at its recorded sim time ``t``."""
        self.input_times.setdefault(topic, collections.deque()).append(t)

    def stamp_held(self, t_end, apps_later=False):
        """Time the held messages at the end of the slice handshake of the slice that ended
        at sim time ``t_end``, and record them (the Recorder writes the slice at its
        ``flush``, which the runner calls next). ``apps_later`` (a replay of a pipelined
        run): the apps' messages wait for the next slice's end, as live."""
        def time_of(topic, tag):
            return self._time_held(topic, tag, t_end)
        later = (lambda topic, tag: tag is None) if apps_later else None
        for t, topic, msg in self.inbox.stamp_held(time_of, later):
            if self.debug:
                self.say('  debug: %s at %.3f' % (topic, t))
            if self.recorder.active:
                self.recorder.write(topic, msg, t)

    def _time_held(self, topic, tag, t_end):
        """The time of a held message: an input's (the world's, live; the recording's, in a
        replay) the sim time it went out at, in order per topic; an app's the end of the
        slice. A live world's message that no answer has listed yet went out while the world
        was paused at ``t_end``, after its last answer (module doc): ``t_end``, and the next
        answer's time for it is dropped. A replay's that it did not time, or one on a topic
        whose publishers the world does not count (and so does not time): its arrival."""
        if tag is None:
            return t_end
        q = self.input_times.get(topic)
        if q:
            return q.popleft()
        if self.input_node is not None and self.input_node == self.world_node and \
                topic not in self.uncounted:
            self.unlisted.setdefault(topic, collections.deque()).append(t_end)
            return t_end
        return tag

    def world_inputs(self, pubs):
        """The recording's inputs (what a replay feeds): the subscribed topics the world
        node publishes (``pubs``: getSystemState's publishers), not this node's own."""
        own = self.own_topics()      # an embedded world's node is ours too
        world = self.world_name()
        inputs = sorted(t for t, nodes in pubs if t in self.subs and world in nodes
                        and t not in own)
        if '/gazebo/environment' not in inputs:
            inputs.append('/gazebo/environment')
        return inputs
