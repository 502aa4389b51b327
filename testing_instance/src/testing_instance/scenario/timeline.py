"""The runner's timeline in sim time, pure (no ROS, no clock): the agenda, the `when`
conditions and the slice plan.

The agenda holds what is due at a sim time (timeline actions, motion steps, 'after' chains)
in time order, ties in insertion order. ``Conditions`` knows which timeline events have
happened and when, and which wait for a condition: a topic condition holds from the first
message (in stamp order) whose field passes its predicate, a reach condition once a model
is within a tolerance of a position. ``next_stop`` is the lockstep rule: the world is
stepped to the next instant that matters, never past the scenario's end.
"""
import heapq
import math

from .expect import FieldError, Predicate, get_field

__all__ = ['Agenda', 'Conditions', 'ConditionError', 'next_stop', 'DUE_EPS']

DUE_EPS = 5e-4        # s: an entry this close to the current time is due now


class Agenda(object):
    def __init__(self):
        self._heap = []
        self._seq = 0

    def __len__(self):
        return len(self._heap)

    def push(self, t, fn, what):
        """Call fn(t_now) when the sim time reaches t (rounded to 1 ns)."""
        self._seq += 1
        heapq.heappush(self._heap, (round(t, 9), self._seq, fn, what))

    def next_time(self):
        return self._heap[0][0] if self._heap else None

    def pop_due(self, t):
        """The next entry due at sim time t as (fn, what), or None."""
        if self._heap and self._heap[0][0] <= t + DUE_EPS:
            _t, _s, fn, what = heapq.heappop(self._heap)
            return fn, what
        return None


class ConditionError(Exception):
    """A condition cannot be evaluated (its field is not on the message): the run's ERROR."""


class Conditions(object):
    def __init__(self, events):
        """events: the scenario's timeline (dicts with 'id', and 'when' for conditions)."""
        self.events = [ev for ev in events if 'when' in ev]
        self.happened = {}        # event id -> sim time it happened (every event)
        self.hits = {}            # event id -> sim time its topic condition held
        self._by_topic = {}       # topic -> [(event, its predicate)]
        for ev in self.events:
            w = ev['when']
            if isinstance(w, dict) and 'topic' in w:
                pred = Predicate({k: v for k, v in w.items() if k not in ('topic', 'field')})
                self._by_topic.setdefault(w['topic'], []).append((ev, pred))

    def topics(self):
        """The topics the conditions read."""
        return list(self._by_topic)

    def happen(self, event_id, t):
        """Event ``event_id`` happens at sim time ``t``; False if it already had."""
        if event_id in self.happened:
            return False
        self.happened[event_id] = t
        return True

    def pending(self):
        """The events still waiting for their condition."""
        return [ev for ev in self.events if ev['id'] not in self.happened]

    def wait_for_messages(self):
        """Does a pending condition read a topic (so each slice's messages are needed)?"""
        return any('topic' in ev['when'] for ev in self.pending())

    def unsubscribed(self, subscribed):
        """Does a pending condition read a topic not in ``subscribed``?"""
        return any(ev['when'].get('topic') not in subscribed for ev in self.pending()
                   if 'topic' in ev['when'])

    def feed(self, topic, t, msg):
        """A message of ``topic`` at sim time ``t``: the first one that passes a pending
        condition's predicate is its hit. ConditionError: the field is not there."""
        for ev, pred in self._by_topic.get(topic, ()):
            if ev['id'] in self.happened or ev['id'] in self.hits:
                continue
            w = ev['when']
            try:
                v = get_field(msg, w.get('field'))
                if pred.is_image:
                    v = pred.image_facts(v)
            except FieldError as err:
                raise ConditionError('%s.when: %s' % (ev['id'], err))
            if pred.test(v):
                self.hits[ev['id']] = t

    def due(self, where):
        """The pending events whose condition holds now, one by one (the caller fires each
        before the next is looked at: its action may move a model another one waits for).
        ``where(event_id, model)``: the model's (x, y, z) now."""
        for ev in self.pending():
            if ev['id'] in self.happened:        # fired by an earlier one's chain
                continue
            if ev['id'] in self.hits:
                yield ev
                continue
            reach = ev['when'].get('reach')
            if reach:
                p = where(ev['id'], reach['model'])
                d = math.sqrt(sum((a - b) ** 2 for a, b in zip(p, reach['position'])))
                if d <= float(reach.get('tolerance', 0.1)):
                    yield ev


def next_stop(t, end, step, agenda_next=None, conditions_pending=False, cond_slice=None):
    """The sim time to step the world to from t: ``step`` on, the next agenda entry or,
    while a `when` condition waits, ``cond_slice`` on; at least 1 ms on, at most ``end``."""
    nxt = min(end, t + step)
    if agenda_next is not None:
        nxt = min(nxt, agenda_next)
    if conditions_pending:
        nxt = min(nxt, t + (step if cond_slice is None else cond_slice))
    if nxt <= t + 1e-9:
        nxt = t + 1e-3
    return nxt
