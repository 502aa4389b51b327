"""Replay a recording (run_scenario --replay BAG / replay_scenario FILE BAG).

No world runs: a fresh master, /use_sim_time true, and this process as the clock source. The
recording's world-published topics (its meta message lists them: every topic sim_world
published, plus /gazebo/environment) are published again in the order of their recorded sim
times, with /clock before each; the scenario's apps start again and see exactly the
recorded inputs; the same expectations are evaluated on what comes out. The recorded
timeline events (/scenario/events) start the 'after' windows at their recorded times;
actions are not applied again (their effects are in the recorded inputs). Time advances in
slices of the scenario's ``slice``; after each slice the runner waits until the apps'
outputs have arrived, as in a live run.
"""
import json
import time

from .clock import ReplayClock
from .procs import free_port
from .recording import EVENTS_TOPIC, META_TOPIC, read_meta
from .results import RunError

__all__ = ['replay_run', 'read_meta']


def replay_run(r):
    import rospy
    from rosgraph_msgs.msg import Clock
    from .mcap_io import RecordingError, open_reader
    try:       # a rosbag or an MCAP file (told by its first bytes)
        bag = open_reader(r.replay)
        meta = read_meta(bag)
    except RecordingError as e:
        raise RunError(str(e))
    if meta is None:
        raise RunError('%s is not a run_scenario recording (no %s message)'
                       % (r.replay, META_TOPIC))
    inputs = set(meta['inputs'])
    if r.port is None:
        r.port = free_port()
    r.start_roscore()
    r.wait_master(time.monotonic() + 60.0)
    import rosgraph
    import rosparam  # noqa: F401 - ensures the param API is importable
    rosgraph.Master('/scenario_runner', master_uri=r.master_uri()).setParam(
        '/use_sim_time', True)
    r.init_ros()
    clock = rospy.Publisher('/clock', Clock, queue_size=100)
    pubs = {}
    msgs = []
    try:
        for topic, msg, t in bag.read_messages():
            if topic in inputs:
                if topic not in pubs:
                    pubs[topic] = rospy.Publisher(topic, type(msg), queue_size=10000,
                                                  latch=topic == '/gazebo/environment')
                msgs.append((t.to_sec(), topic, msg))
            elif topic == EVENTS_TOPIC:
                ev = json.loads(msg.data)
                if ev.get('text') == 'event':
                    msgs.append((t.to_sec(), EVENTS_TOPIC, ev))
    except RecordingError as e:
        raise RunError(str(e))
    finally:
        bag.close()
    if r.record_path:
        r.open_bag()
    r.t0 = r.t = float(meta.get('t0', 0.0))
    clock.publish(Clock(rospy.Time.from_sec(r.t)))
    r.start_apps()
    r.topic_types = {}
    r.subscribe_all()
    # wait until every app that subscribes an input is connected to our publisher
    import rosgraph as rg
    _p, subs, _s = rg.Master('/scenario_runner').getSystemState()
    want = {t: [n for n in nodes if n != rospy.get_name()] for t, nodes in subs if t in pubs}
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and any(
            pubs[t].get_num_connections() < len(n) for t, n in want.items()):
        time.sleep(0.02)
    r.replay_meta = meta
    if r.bag is not None:
        r.write_meta()
    src = ReplayClock(msgs, lambda topic, m: pubs[topic].publish(m),
                      lambda t: clock.publish(Clock(rospy.Time.from_sec(t))),
                      lambda ev, t: r.start_after(ev['id'], t), EVENTS_TOPIC)
    end = r.t0 + float(meta.get('duration', r.sc.duration))
    while True:
        r.check_world()
        r.t = src.step_to(min(end, r.t + r.sc.slice))
        r.settle(quiet=0.03)
        r.subscribe_all(wait_connections=False)
        r.drain()
        if r.t >= end - 1e-9:
            break
    r.settle()
    r.drain()
    r.missing_topics_are_errors('is neither in the recording nor published by an app')
