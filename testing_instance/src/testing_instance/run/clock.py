"""Clock sources of the runner's loop: ``step_to(t)`` advances sim time to t, returns it.

``WorldClock`` steps a paused world (the /gazebo/step_world lockstep of a live run);
``ReplayClock`` plays a recording's messages (and /clock) up to t. Both are driven slice by
slice by the runner.
"""

__all__ = ['WorldClock', 'ReplayClock']


class WorldClock(object):
    """step(t) is the world's step service (returns the sim time reached); on_error(e) turns
    a failed call into the run's error (it raises)."""

    def __init__(self, step, on_error):
        self._step = step
        self._on_error = on_error

    def step_to(self, t):
        try:
            return self._step(t).sim_time
        except Exception as e:  # noqa: BLE001 - the world died or the watchdog stopped it
            self._on_error(e)
            raise


class ReplayClock(object):
    """msgs: [(t, topic, msg)] sorted by t; publish(topic, msg, t) sends a recorded input,
    tick(t) publishes /clock, on_event(msg, t) handles a recorded timeline event (topic
    ``events_topic``). ``counts``: {topic: messages published so far}, the replay's side of
    the slice handshake (Runner.sync_replayed), as a world's step answer is the world's."""

    def __init__(self, msgs, publish, tick, on_event, events_topic):
        self._msgs = msgs
        self._i = 0
        self.counts = {}
        self._publish = publish
        self._tick = tick
        self._on_event = on_event
        self._events = events_topic

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
