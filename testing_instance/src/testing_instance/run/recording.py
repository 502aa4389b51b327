"""The run's recording (``--record``): names of its meta and timeline topics, its reader of
the meta, and the ``Recorder`` the runner writes through.

A recording holds every message the runner subscribed to, at its sim time (the stamp, or
the time the slice handshake gave an unstamped message), the timeline's events on
``/scenario/events`` and one ``/scenario/meta`` message (seed, inputs, t0, duration,
types) that a replay reads first.

The file's order is the same in every run of a scenario and seed, whatever way it is run
(embedded, with a world node, attached, loaded, replayed): the messages wait in the
Recorder until the end of the slice handshake that completes them (``flush``: the runner
calls it once the slice's unstamped messages are timed) and go to the file in
``recording_order``: by recorded time, then topic, then arrival within the topic. Written
as they arrived, messages of different topics at one sim time were in the order their
threads happened to run: an app's answer, a latched topic, a replayed input and every
message of a world node come over sockets, and two runs of one scenario gave files that
differed in that order (while each topic's own messages were the same)."""
import json
import threading

# not recorded unless named in `record:` or used by an expectation (each one makes the
# renderer draw a frame per message)
HEAVY_TYPES = ('sensor_msgs/Image', 'sensor_msgs/CompressedImage', 'sensor_msgs/PointCloud2')
EVENTS_TOPIC = '/scenario/events'
META_TOPIC = '/scenario/meta'

__all__ = ['HEAVY_TYPES', 'EVENTS_TOPIC', 'META_TOPIC', 'read_meta', 'recording_order',
           'Recorder']


def read_meta(bag):
    """The run's meta dict (seed, inputs, t0, duration...) of an open rosbag.Bag, or None."""
    for _topic, msg, _t in bag.read_messages(topics=[META_TOPIC]):
        return json.loads(msg.data)
    return None


def recording_order(rows):
    """``rows`` [(secs, nsecs, arrival, topic, msg)] (the recorded time, a number that grows
    with each message received) in the order they go to the file: by recorded time, then
    topic, then arrival (a topic's own messages stay in the order they came)."""
    return sorted(rows, key=lambda r: (r[0], r[1], r[3], r[2]))


class Recorder(object):
    """Writes the run's recording to every ``--record`` path (a rosbag, an MCAP file, or
    both: mcap_io.GuardedWriter); records nothing until ``open``.

    Thread-safe: the subscriber threads (or an embedded world's thread) write while the
    loop writes events. ``write``, ``event`` and ``meta`` keep the message until the next
    ``flush`` (the end of a slice handshake) or ``close``, which write what was kept in
    ``recording_order`` (module doc). A storage fault never raises: ``close`` returns one
    line per fault, which the runner reports as the run's ERROR after its verdicts."""

    def __init__(self):
        self._writer = None
        self._lock = threading.Lock()
        self._time = None
        self._kept = []              # [(secs, nsecs, arrival, topic, msg)] until the flush
        self._n = 0

    @property
    def active(self):
        """Is a recording open (``--record`` given and not yet closed)?"""
        return self._writer is not None

    def open(self, paths):
        """Start recording to ``paths``; mcap_io.RecordingError if a file cannot be made."""
        from rospy import Time
        from ..io.mcap_io import GuardedWriter
        self._time = Time.from_sec
        self._writer = GuardedWriter(paths)

    def write(self, topic, msg, t):
        """``msg`` on ``topic`` at sim time ``t`` (s), written at the next flush."""
        with self._lock:
            if self._writer is not None:
                when = self._time(max(t, 1e-9))
                self._n += 1
                self._kept.append((when.secs, when.nsecs, self._n, topic, msg))

    def flush(self):
        """Write what was kept since the last flush, in ``recording_order``."""
        with self._lock:
            self._flush()

    def _flush(self):
        kept, self._kept = self._kept, []
        if self._writer is None or not kept:
            return
        from rospy import Time
        write = self._writer.write
        for secs, nsecs, _n, topic, msg in recording_order(kept):
            write(topic, msg, Time(secs, nsecs))

    def event(self, t, text, **fields):
        """A timeline event at sim time ``t``: a JSON object on EVENTS_TOPIC."""
        if self._writer is not None:
            self._json(EVENTS_TOPIC, dict(fields, t=round(t, 6), text=text), t)

    def meta(self, meta, t):
        """The run's meta (a dict) on META_TOPIC at sim time ``t``."""
        if self._writer is not None:
            self._json(META_TOPIC, meta, t)

    def _json(self, topic, obj, t):
        from std_msgs.msg import String
        self.write(topic, String(json.dumps(obj, sort_keys=True)), t)

    def close(self):
        """Write what is kept, close every file; returns the storage faults' lines (empty:
        all written)."""
        with self._lock:
            self._flush()
            w, self._writer = self._writer, None
        return w.close() if w is not None else []
