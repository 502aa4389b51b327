"""The runner's inbox: messages of the subscribed topics, taken slice by slice in stamp order.

Subscriber threads ``put`` (stamp, topic, msg); the loop ``take``s the slice's batch sorted
by (stamp, topic, arrival). The inbox counts what arrived per topic, all of it (``counts``)
and what came from the world node (``from_world``), so the runner, told by the world how many
messages it handed to the runner's connections, waits for exactly those (``wait_counts``);
``settle`` (no message for ``quiet`` s of wall time) is left for topics whose publishers
do not count (other nodes of a launch file).

Messages without a stamp of their own (``std_msgs`` outputs of apps and of the world) are
``hold``: counted at once, timed later by ``stamp_held(time_of)``, which the runner calls at
the end of each slice handshake: the world's by the sim times its step answer lists, the
apps' by the slice's end. Their time is then the same in every run, not the moment the
runner's clock happened to read on arrival.
"""
import threading
import time

__all__ = ['Inbox']


class Inbox(object):
    def __init__(self):
        self._cv = threading.Condition()
        self._buffer = []
        self._held = []
        self._waited = set()              # seqs of held messages kept for one more call
        self._seq = 0
        self.counts = {}                  # topic -> messages received so far
        self.from_world = {}              # topic -> of those, from the world node
        self.last_wall = time.monotonic()

    def put(self, t, topic, msg, from_world=False):
        with self._cv:
            self._seq += 1
            self._buffer.append((t, self._seq, topic, msg))
            self.counts[topic] = self.counts.get(topic, 0) + 1
            if from_world:
                self.from_world[topic] = self.from_world.get(topic, 0) + 1
            self.last_wall = time.monotonic()
            self._cv.notify_all()

    def hold(self, topic, msg, from_world=False, tag=None):
        """An unstamped message, counted now, timed by the next ``stamp_held``."""
        with self._cv:
            self._seq += 1
            self._held.append((self._seq, topic, msg, tag))
            self.counts[topic] = self.counts.get(topic, 0) + 1
            if from_world:
                self.from_world[topic] = self.from_world.get(topic, 0) + 1
            self.last_wall = time.monotonic()
            self._cv.notify_all()

    def stamp_held(self, time_of, later=None):
        """Time every held message, in arrival order, by time_of(topic, tag); returns them
        as [(t, topic, msg)]. With ``later(topic, tag)`` (a replay of a pipelined run, for
        the apps' answers) a message it is true for stays held until the next call, once:
        live, the app got the slice's messages as the next slice began, and its answer
        was timed at that one's end."""
        with self._cv:
            held, self._held = self._held, []
            if later is not None:
                wait = [h for h in held if h[0] not in self._waited and later(h[1], h[3])]
                self._waited = {h[0] for h in wait}
                if wait:
                    held = [h for h in held if h[0] not in self._waited]
                    self._held = wait + self._held
        out = [(time_of(topic, tag), seq, topic, msg) for seq, topic, msg, tag in held]
        with self._cv:
            self._buffer.extend(out)
        return [(t, topic, msg) for t, _seq, topic, msg in out]

    def take(self):
        """Everything received since the last take, as (t, seq, topic, msg) sorted by
        (stamp, topic, arrival)."""
        with self._cv:
            batch, self._buffer = self._buffer, []
        batch.sort(key=lambda x: (x[0], x[2], x[1]))
        return batch

    def settle(self, quiet=0.02, longest=3.0):
        """Wait until no message arrived for ``quiet`` s of wall time (at most ``longest``)."""
        t0 = time.monotonic()
        with self._cv:
            while True:
                now = time.monotonic()
                idle = now - max(self.last_wall, t0)
                if idle >= quiet or now - t0 > longest:
                    return
                self._cv.wait(min(quiet - idle, longest - (now - t0)) + 1e-4)

    def wake(self, timeout):
        """Wait up to timeout s for the next message."""
        with self._cv:
            self._cv.wait(timeout)

    def wait_counts(self, want, timeout, world=True):
        """Wait until from_world[topic] (all counts with world=False) >= n for every
        (topic, n) in want; return what is still missing as {topic: (received, wanted)}
        ({} when everything arrived)."""
        deadline = time.monotonic() + timeout
        have = self.from_world if world else self.counts
        with self._cv:
            while True:
                missing = {tp: (have.get(tp, 0), n) for tp, n in want.items()
                           if have.get(tp, 0) < n}
                left = deadline - time.monotonic()
                if not missing or left <= 0:
                    return missing
                self._cv.wait(left)
