"""Replay a recording (run_scenario --replay BAG / replay_scenario FILE BAG).

No world runs: a fresh master, /use_sim_time true, and this process as the clock source. The
recording's world-published topics (its meta message lists them: every topic sim_world
published, plus /gazebo/environment) are published again in the order of their recorded sim
times, with /clock before each; the scenario's apps start again and see exactly the
recorded inputs; the same expectations are evaluated on what comes out. The recorded
timeline events (/scenario/events) start the 'after' windows at their recorded times;
actions are not applied again (their effects are in the recorded inputs). Time advances in
slices of the scenario's ``slice`` by the run's one loop (``Runner.run_timeline``) with a
``ReplayClock``; after each slice the runner waits until the apps' outputs have arrived, as
in a live run.
"""
import json
import math
import re
import time

from ..scenario.results import RunError
from ..world.procs import poll
from .clock import ReplayClock
from .intake import stamp_of
from .recording import EVENTS_TOPIC, META_TOPIC, read_meta

__all__ = ['replay_run', 'read_meta', 'load_recording', 'Loaded']


class Loaded(object):
    """A recording read for replay: ``meta`` (dict), ``types`` {input topic: message class},
    ``msgs`` [(t, topic, msg)] sorted by t (inputs, and the timeline events as dicts on
    EVENTS_TOPIC), ``warning``: None, or one line saying the file is damaged and only what
    was read before the damage is replayed."""

    def __init__(self, path, meta, types, msgs, warning):
        self.path, self.meta, self.types, self.msgs, self.warning = \
            path, meta, types, msgs, warning


_TYPE_RE = re.compile(r'\A[A-Za-z][A-Za-z0-9_]*/[A-Za-z][A-Za-z0-9_]*\Z')


def _check_meta(path, meta):
    if not isinstance(meta, dict):
        raise ValueError('its %s message is not a JSON object' % META_TOPIC)
    inputs = meta.get('inputs')
    if not isinstance(inputs, list) or not all(isinstance(t, str) for t in inputs):
        raise ValueError('its %s message has no list of input topics' % META_TOPIC)
    import rosgraph.names
    for t in inputs:
        if not t.startswith('/') or not rosgraph.names.is_legal_name(t):
            raise ValueError('its %s message lists the input %r, which is not a ROS topic '
                             'name' % (META_TOPIC, t))
    if not isinstance(meta.get('pipeline', False), bool):
        raise ValueError('its %s message has pipeline %r, not true or false'
                         % (META_TOPIC, meta['pipeline']))
    for k, lo in (('t0', 0.0), ('duration', None)):
        v = meta.get(k)
        if v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or v < 0 or v > 1e9 or (lo is None and v == 0):
            raise ValueError('its %s message has %s %r, not a time in seconds'
                             % (META_TOPIC, k, v))


def load_recording(path):
    """Read a run_scenario recording (rosbag or MCAP) for replay, completely, before anything
    starts. A file that cannot be replayed raises RecordingError with one line naming the file
    and what is wrong; a damaged file whose start is readable (cut short, a message that does
    not decode) gives what was read before the damage and ``warning``."""
    from ..io.mcap_io import RecordingError, open_reader
    bag = open_reader(path)
    rows, damage = [], None
    try:
        try:
            for topic, msg, t in bag.read_messages():
                rows.append((topic, msg, t))
        except RecordingError as e:
            damage = str(e)
    finally:
        bag.close()
    damage = damage or bag.damage
    meta = None
    for topic, msg, _t in rows:
        if topic == META_TOPIC:
            try:
                meta = json.loads(getattr(msg, 'data', None))
                _check_meta(path, meta)
            except (TypeError, ValueError) as e:
                raise RecordingError('%s is not a replayable recording: %s'
                                     % (path, str(e).splitlines()[0] if str(e) else
                                        'its %s message is damaged' % META_TOPIC))
            break
    if meta is None:
        if damage:
            raise RecordingError('%s; nothing read before the damage can be replayed (no %s '
                                 'message)' % (damage, META_TOPIC))
        raise RecordingError('%s is not a run_scenario recording (no %s message)'
                             % (path, META_TOPIC))
    inputs = set(meta['inputs'])
    types, msgs = {}, []
    for topic, msg, t in rows:
        if topic in inputs:
            if topic not in types and not _TYPE_RE.match(getattr(msg, '_type', '') or ''):
                damage = damage or '%s: topic %s has the message type %r' % (
                    path, topic, getattr(msg, '_type', None))
                break
            cls = types.setdefault(topic, type(msg))
            if type(msg) is not cls and getattr(msg, '_md5sum', None) != cls._md5sum:
                damage = damage or '%s: topic %s holds messages of two types, %s and %s' % (
                    path, topic, cls._type, getattr(msg, '_type', type(msg).__name__))
                break
            msgs.append((t.to_sec(), topic, msg))
        elif topic == EVENTS_TOPIC:
            try:
                ev = json.loads(msg.data)
                if not isinstance(ev, dict):
                    raise ValueError('not a JSON object')
            except (AttributeError, TypeError, ValueError) as e:
                damage = damage or '%s: a %s message does not decode (%s)' % (
                    path, EVENTS_TOPIC, e)
                break
            if ev.get('text') == 'event':
                if not isinstance(ev.get('id'), str):
                    damage = damage or '%s: a %s message names no event id' % (
                        path, EVENTS_TOPIC)
                    break
                msgs.append((t.to_sec(), EVENTS_TOPIC, ev))
    msgs.sort(key=lambda m: m[0])
    warning = None
    if damage:
        warning = ('%s; replaying the %d messages read before the damage%s'
                   % (damage, len(msgs), ' (up to sim time %.3f s)' % msgs[-1][0] if msgs
                      else ''))
    return Loaded(path, meta, types, msgs, warning)


def replay_run(r):
    import rospy
    from rosgraph_msgs.msg import Clock
    from ..io.mcap_io import RecordingError
    try:       # a rosbag or an MCAP file (told by its first bytes), read before anything starts
        rec = load_recording(r.replay)
    except RecordingError as e:
        raise RunError(str(e))
    if rec.warning:
        r.say('WARNING ' + rec.warning)
    meta = rec.meta
    inputs = set(meta['inputs'])
    # the apps' answers are timed as the recording's run timed them (older recordings do
    # not say: the scenario file's key)
    r.sc.pipeline = bool(meta.get('pipeline', r.sc.pipeline))
    r.start_master(time.monotonic() + 60.0)    # its own master and rosout, sim time set
    r.init_ros()
    clock = rospy.Publisher('/clock', Clock, queue_size=100)
    pubs = {topic: rospy.Publisher(topic, cls, queue_size=10000,
                                   latch=topic == '/gazebo/environment')
            for topic, cls in rec.types.items()}
    msgs = rec.msgs
    if r.record_path:
        r.open_recording()
    r.start_at(float(meta.get('t0', 0.0)))
    clock.publish(Clock(rospy.Time.from_sec(r.t)))
    r.start_apps()
    r.subscribe_all()
    # wait until every subscriber of a replayed topic is connected to our publisher: the
    # apps', and this node's own (rospy connects to itself over TCP: its publisher counts
    # the connection only once it has accepted it; a message published before that was
    # lost, the recording's first magnetometer message once under load)
    import rosgraph as rg
    _p, subs, _s = rg.Master('/scenario_runner').getSystemState()
    want = {t: len(nodes) for t, nodes in subs if t in pubs}
    poll(lambda: all(pubs[t].get_num_connections() >= n for t, n in want.items()),
         time.monotonic() + 10.0)
    r.replay_meta = meta
    r.write_meta()
    def publish(topic, m, t):
        if stamp_of(m) is None:     # timed by its recorded time (_time_held)
            r.intake.input_at(topic, t)
        pubs[topic].publish(m)
    r.clock = ReplayClock(msgs, publish,
                          lambda t: clock.publish(Clock(rospy.Time.from_sec(t))),
                          lambda ev, t: r.start_after(ev['id'], t), EVENTS_TOPIC, run=r)
    # unstamped messages: the recording's by their recorded times, the apps' at the end of
    # the slice, as live
    r.intake.input_node, r.intake.hold_unstamped = rospy.get_name(), True
    # the run's one loop, each step a slice and a handshake (exactly what the replay
    # published, then the apps' answers), to the recording's end
    r.run_timeline(r.clock, r.t0 + float(meta.get('duration', r.sc.duration)))
