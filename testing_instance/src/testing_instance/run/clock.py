"""The clocks of the run's one loop (``Runner.run_timeline``): a live run's world stepped in
lockstep (``WorldClock``), or a recording played back (``ReplayClock``).

The loop asks a clock four things, the same way for both:

- ``step_to(t)``: advance sim time to t; the time reached;
- ``handshake()``: wait until every message of the slice just run is in (the world's, or
  the replay's own, by count; the apps' by evidence), then time the held ones;
- ``look()``: subscribe the topics that appeared since;
- ``finish()``: the last slice's messages;

and reads how to run with it: ``longest`` (s of sim time a step goes at most when nothing
else is due), ``settle_every`` (a handshake at least this often), ``acts`` (the timeline's
actions and `when` conditions apply: live only; a replay's inputs hold their effects) and
``absent`` (how a topic that never appeared is told).
"""
import time

from sim_world import transport

from ..scenario.results import RunError

__all__ = ['WorldClock', 'ReplayClock', 'MAX_SLICE', 'SETTLE_EVERY', 'HANDSHAKE_WATCHDOG',
           'TOPIC_RECHECK']

MAX_SLICE = 0.25         # s of sim time between checks when nothing else is due (the
                         # sensors' publisher queues hold 100 messages: lossless at 100 Hz)
SETTLE_EVERY = 0.25      # s of sim time: wait for in-flight messages at least this often
HANDSHAKE_WATCHDOG = 30.0    # wall s: the counted messages must be in by then
TOPIC_RECHECK = 1.0      # s of sim time: ask the master for new topics at least this often


def _counts_line(missing):
    """'topic (received of wanted), ...' of Inbox.wait_counts' missing topics."""
    return ', '.join('%s (%d of %d)' % (t, got, n) for t, (got, n) in sorted(missing.items()))


class WorldClock(object):
    """A live run: the paused world, stepped with /gazebo/step_world. ``run``: the Runner
    (its world, intake, inbox, apps, actions' hands and sim time ``t``)."""
    acts = True
    absent = ''

    def __init__(self, run):
        self.run = run
        apps = bool(run.sc.apps)
        # apps answer asynchronously: with apps, every slice is a step and a handshake, so
        # that their outputs are timed to within a slice
        self.longest = run.sc.slice if apps else MAX_SLICE
        self.settle_every = run.sc.slice if apps else SETTLE_EVERY
        self.published = None      # {topic: n} the world handed us, from the last step
        self.dropped = {}          # {topic: n} its queues dropped, from the last step
        self.counted_once = False  # a handshake has counted the world's topics
        self.topics_checked = 0.0  # sim time of the last look at the master's topics
        self.topics_new = False    # embedded: this process declared a publisher since

    def step_to(self, t):
        try:
            return self.step(t).sim_time
        except Exception as e:  # noqa: BLE001 - the world died or the watchdog stopped it
            self.stopped(e)
            raise

    def step(self, until, pipeline=None):
        """One /gazebo/step_world call to sim time ``until``; its answer."""
        r = self.run
        if r.hands.inputs_sent:
            r.hands.inputs_sent = False
            if r.embedded:
                # this process's receive threads take the actions' messages off their
                # sockets before the step (a world node's step request waits for its own)
                transport.settle()
        res = r.step_srv(until=until, subscriber=r.rospy.get_name(),
                         pipeline=r.sc.pipeline if pipeline is None else pipeline)
        if not res.success:
            raise RunError('the world refused the step to sim time %.3f s: %s'
                           % (until, res.status_message), r.world_log())
        r.intake.note_times(res)
        self.published = {t: c - d for t, c, d in zip(res.topics, res.counts, res.dropped)}
        self.dropped = {t: d for t, d in zip(res.topics, res.dropped) if d}
        return res

    def stopped(self, e):
        r = self.run
        r.world.stopped()                 # roslaunch tears down after its node died
        r.check_world()
        raise RunError('the world stopped answering at sim time %.3f s (step_world: %s)'
                       % (r.t, e), r.world_log())

    def handshake(self):
        """The slice handshake: wait until every message of the slice just run is in.
        The world's messages exactly (its step answer counts what it handed to this node's
        connections), the apps' by evidence (appwatch), topics of other publishers by a
        quiet period. A generous watchdog names what never arrived."""
        r = self.run
        w0 = time.monotonic()
        if self.published is None and r.world_node is not None:
            self.step_to(r.t)            # paused: only asks for the counts
        intake = r.intake
        want = {t: n for t, n in (self.published or {}).items() if t in intake.subs}
        self.published = None
        missing = r.inbox.wait_counts(want, HANDSHAKE_WATCHDOG)
        if missing:
            r.check_world()
            raise RunError('slice handshake: %.0f s of wall time after the step to sim time '
                           '%.3f s, messages the world published have not arrived: %s'
                           % (HANDSHAKE_WATCHDOG, r.t, _counts_line(missing)),
                           r.world_log())
        # topics of the world it does not count (outside its counted publishers)
        intake.uncounted.update(t for t in intake.world_topics if t not in want and
                                t in intake.subs and r.world_node is not None and
                                self.counted_once)
        self.counted_once = True
        if intake.uncounted:
            r.inbox.settle(0.02)
        r.answered(w0)

    def look(self):
        """Topics that appeared late (apps, spawned models), when they may have."""
        r = self.run
        if self.topics_stale():
            # (before the look: a publisher declared meanwhile marks it again)
            r.hands.spawned = self.topics_new = False
            r.subscribe_all()
            self.topics_checked = r.t

    def finish(self):
        """The last slice's messages (the handshake: exactly those the world handed over);
        pipelined, the apps have not had the last slice yet: it is sent now, and what they
        answer is timed at the end."""
        self.handshake()
        if self.run.sc.pipeline:
            self.step(self.run.t, pipeline=False)
            self.handshake()

    def new_own_topic(self, topic):
        """A publisher declared in this process (an embedded world's): the next periodic
        look at the master's topics is not skipped (topics_stale). Not a look at once:
        the sim_world node's runs look by the same sim-time rule, and a latched message's
        time in the recording is when it was subscribed."""
        self.topics_new = True

    def topics_stale(self):
        """Look for new topics now? After a spawn, while a topic that an expectation or a
        waiting condition reads is not subscribed yet, and every TOPIC_RECHECK s of sim time
        (a master round trip per slice was the runner's largest cost in a recording run)
        unless nothing can have declared a publisher since the last look: an embedded run
        without other processes that may publish, where this process declared none."""
        r = self.run
        if r.hands.spawned:
            return True
        if r.t - self.topics_checked >= TOPIC_RECHECK - 1e-9 and (
                self.topics_new or self.others_publish()):
            return True
        subs = r.intake.subs
        if any(e.topic not in subs and e.verdict is None for e in r.expectations):
            return True
        return r.conditions.unsubscribed(subs)

    def others_publish(self):
        """Can a process other than this one declare a publisher on this run's master? Not
        in an embedded run without apps and with no other node of its launch file still
        running (the phone's spawner has exited by sim time 0; a node that exits
        unregisters its publishers): the master is the run's own (its port is the run's),
        rosout publishes before the first look, and this process's new publishers are
        heard (new_own_topic)."""
        r = self.run
        return not r.embedded or bool(r.sc.apps) or any(
            p.alive() for p in r.world.launch_procs)


class ReplayClock(object):
    """A replay: ``msgs`` [(t, topic, msg)] sorted by t, played up to each step's time:
    ``publish(topic, msg, t)`` sends a recorded input, ``tick(t)`` publishes /clock,
    ``on_event(msg, t)`` handles a recorded timeline event (topic ``events_topic``).
    ``counts``: {topic: messages published so far}, the replay's side of the slice
    handshake, as a world's step answer is the world's. ``run``: the Runner (None: only
    ``step_to``). Every step is a slice of the scenario's ``slice`` and a handshake."""
    acts = False
    absent = ' in the recording or from an app'
    settle_every = 0.0

    def __init__(self, msgs, publish, tick, on_event, events_topic, run=None):
        self._msgs = msgs
        self._i = 0
        self.counts = {}
        self._publish = publish
        self._tick = tick
        self._on_event = on_event
        self._events = events_topic
        self.run = run
        self.longest = run.sc.slice if run is not None else None
        self.replayed_subs = None  # the topics it counts (handshake)

    def step_to(self, t_next):
        msgs = self._msgs
        while self._i < len(msgs) and msgs[self._i][0] <= t_next + 1e-9:
            t, topic, msg = msgs[self._i]
            self._i += 1
            if topic == self._events:
                self._on_event(msg, t)
                continue
            self._tick(t)
            self._publish(topic, msg, t)
            self.counts[topic] = self.counts.get(topic, 0) + 1
        self._tick(t_next)
        return t_next

    def handshake(self):
        """Wait until every message the replay published on a topic this node subscribes
        to has come back through its subscription (rospy connects this node to itself over
        TCP), then for the apps by evidence (appwatch), as live. No quiet period: a replay
        waited 30 ms of wall time after each 0.05 s slice, most of a replay's wall time. A
        generous watchdog names what never arrived."""
        r = self.run
        w0 = time.monotonic()
        if self.replayed_subs is None:
            # the topics subscribed before the replay published anything (it subscribes
            # everything it wants first): a later subscription missed the earlier messages
            self.replayed_subs = set(r.intake.subs)
        want = {t: n for t, n in self.counts.items() if t in self.replayed_subs}
        missing = r.inbox.wait_counts(want, HANDSHAKE_WATCHDOG, world=False)
        if missing:
            raise RunError('slice handshake: %.0f s of wall time after the replay reached sim '
                           'time %.3f s, messages it published have not come back: %s'
                           % (HANDSHAKE_WATCHDOG, r.t, _counts_line(missing)))
        r.answered(w0)

    def look(self):
        """The apps' outputs that appeared (no wait for connections: nothing is published
        to the runner that it has not subscribed before the replay began)."""
        self.run.subscribe_all(wait_connections=False)

    def finish(self):
        """A pipelined run's answers to the last slice: timed at its end."""
        self.run.stamp_held(last=True)
