"""The runner's timeline in sim time, pure (no ROS, no clock): the agenda and the slice plan.

The agenda holds what is due at a sim time (timeline actions, motion steps, 'after' chains)
in time order, ties in insertion order. ``next_stop`` is the lockstep rule: the world is
stepped to the next instant that matters, never past the scenario's end.
"""
import heapq

__all__ = ['Agenda', 'next_stop', 'DUE_EPS']

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
