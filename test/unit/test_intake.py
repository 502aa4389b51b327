"""What comes into a run (intake.py) and its recording (recording.Recorder), without a
master: stamps, held unstamped messages and their times, the world's and the apps'
messages told apart, the recording's bytes."""
import collections
import json
import threading
import time

import rosbag
import rospy
from sensor_msgs.msg import Imu
from std_msgs.msg import Float32, String

from testing_instance.run.inbox import Inbox
from testing_instance.run.intake import Intake, stamp_of
from testing_instance.run.recording import (EVENTS_TOPIC, META_TOPIC, Recorder, read_meta,
                                            recording_order)


class FakeRospy(object):
    """get_rostime (the last /clock) and get_name: all on_message needs of rospy."""

    def __init__(self, now=0.0):
        self.now = now

    def get_rostime(self):
        return rospy.Time.from_sec(self.now)

    def get_name(self):
        return '/runner'


def _imu(t):
    m = Imu()
    m.header.stamp = rospy.Time.from_sec(t)
    return m


def _from(msg, caller):
    msg._connection_header = {'callerid': caller}
    return msg


def _intake(now=0.0, recorder=None, embedded=False, own=()):
    it = Intake(Inbox(), recorder or Recorder())
    it.world_node = '/sim_world'
    it.start(FakeRospy(now), embedded=embedded, own_topics=lambda: set(own))
    return it


def test_stamp_of_reads_the_header_and_treats_zero_or_none_as_unstamped():
    assert stamp_of(_imu(1.25)) == 1.25
    assert stamp_of(Imu()) is None
    assert stamp_of(Float32(3.0)) is None


def test_a_stamped_message_goes_to_the_inbox_at_its_stamp_and_counts_for_its_sender():
    it = _intake(now=9.0)
    it.on_message(_from(_imu(1.5), '/sim_world'), '/imu')
    it.on_message(_from(_imu(1.0), '/app'), '/imu')
    assert [(t, topic) for t, _s, topic, _m in it.inbox.take()] == [(1.0, '/imu'),
                                                                    (1.5, '/imu')]
    assert it.inbox.counts == {'/imu': 2} and it.inbox.from_world == {'/imu': 1}


def test_before_stepping_an_unstamped_message_takes_the_clock_and_afterwards_it_is_held():
    it = _intake(now=2.0)
    it.on_message(_from(Float32(1.0), '/sim_world'), '/light')
    assert [t for t, _s, _tp, _m in it.inbox.take()] == [2.0]
    it.hold_unstamped, it.input_node = True, '/sim_world'
    it.on_message(_from(Float32(2.0), '/sim_world'), '/light')
    it.on_message(_from(Float32(3.0), '/app'), '/answer')
    assert it.inbox.take() == [] and it.inbox.counts == {'/light': 2, '/answer': 1}


def test_held_messages_are_timed_by_the_step_answer_and_the_apps_by_the_slice_end():
    """The world's unstamped messages at the times its step answer lists (in order per
    topic), an app's at the end of the slice: the same in every run, whenever they came."""
    it = _intake(now=0.37)          # the clock when they arrived: not their time
    it.hold_unstamped, it.input_node = True, '/sim_world'
    it.subs = {'/light': object(), '/pressure': object()}
    Answer = collections.namedtuple('Answer', 'timed_topics timed_counts times')
    it.note_times(Answer(['/light', '/gone', '/pressure'], [2, 1, 1],
                         [0.1, 0.2, 0.15, 0.3]))
    for v in (1.0, 2.0):
        it.on_message(_from(Float32(v), '/sim_world'), '/light')
    it.on_message(_from(Float32(5.0), '/sim_world'), '/pressure')
    it.on_message(_from(Float32(7.0), '/app'), '/answer')
    it.stamp_held(0.5)
    got = [(t, topic, m.data) for t, _s, topic, m in it.inbox.take()]
    assert got == [(0.1, '/light', 1.0), (0.2, '/light', 2.0), (0.3, '/pressure', 5.0),
                   (0.5, '/answer', 7.0)]
    # a replay's input at its recorded time
    it.input_at('/light', 0.75)
    it.on_message(_from(Float32(3.0), '/sim_world'), '/light')
    it.stamp_held(1.0)
    assert [t for t, _s, _tp, _m in it.inbox.take()] == [0.75]


def test_a_world_message_sent_while_paused_is_timed_at_the_slice_end_not_by_the_clock():
    """The NFC proxy's delivery of an app's answer goes out while the world is paused at
    the slice's end, after the step answer: it can arrive before any answer lists it. It is
    timed at the slice's end, not by the runner's clock (which lags the world's under load:
    bench/load saw 1.05 s for 1.10 s), and the next answer's time for it is not used again
    for the topic's next message (which used to take the stale 1.10)."""
    Answer = collections.namedtuple('Answer', 'timed_topics timed_counts times')
    it = _intake(now=1.05)          # the runner's /clock lags
    it.hold_unstamped, it.input_node = True, '/sim_world'
    it.subs = {'/nfc/incoming': object()}
    it.on_message(_from(String('OK'), '/sim_world'), '/nfc/incoming')
    it.stamp_held(1.1)
    assert [(t, m.data) for t, _s, _tp, m in it.inbox.take()] == [(1.1, 'OK')]
    # the next step's answer lists it first, then one published in that step at 1.12
    it.note_times(Answer(['/nfc/incoming'], [2], [1.1, 1.12]))
    it.on_message(_from(String('again'), '/sim_world'), '/nfc/incoming')
    it.stamp_held(1.15)
    assert [(t, m.data) for t, _s, _tp, m in it.inbox.take()] == [(1.12, 'again')]
    assert it.mislisted == [] and not it.unlisted['/nfc/incoming']


def test_a_time_given_on_arrival_that_the_world_lists_otherwise_is_said():
    said = []
    Answer = collections.namedtuple('Answer', 'timed_topics timed_counts times')
    it = _intake(now=0.0)
    it.say = said.append
    it.hold_unstamped, it.input_node = True, '/sim_world'
    it.subs = {'/led': object()}
    it.on_message(_from(String('red'), '/sim_world'), '/led')
    it.stamp_held(0.5)
    it.note_times(Answer(['/led'], [1], [0.45]))
    assert it.mislisted == [('/led', 0.5, 0.45)]
    assert said and '/led' in said[0] and '0.450' in said[0]


def test_a_world_topic_the_world_does_not_count_keeps_the_arrival_time():
    it = _intake(now=0.7)
    it.hold_unstamped, it.input_node = True, '/sim_world'
    it.subs, it.uncounted = {'/other': object()}, {'/other'}
    it.on_message(_from(String('x'), '/sim_world'), '/other')
    it.stamp_held(1.0)
    assert [t for t, _s, _tp, _m in it.inbox.take()] == [0.7] and it.unlisted == {}


def test_a_replays_input_it_did_not_time_keeps_its_arrival():
    it = _intake(now=0.7)
    it.hold_unstamped, it.input_node = True, '/runner'      # a replay: this node
    it.subs = {'/led': object()}
    it.on_message(_from(String('red'), '/runner'), '/led')
    it.stamp_held(1.0)
    assert [t for t, _s, _tp, _m in it.inbox.take()] == [0.7] and it.unlisted == {}


def test_embedded_the_worlds_messages_have_no_header_and_the_nodes_own_do():
    """An embedded world hands its messages over as objects (no connection header): they
    are the world's. A message of this node's own action publisher is not."""
    it = _intake(embedded=True, own=['/cmd'])
    it.on_message(_imu(1.0), '/imu')                       # handed over in this process
    it.on_message(_from(_imu(1.0), '/sim_world'), '/cmd')  # our own publisher, looped back
    assert it.inbox.from_world == {'/imu': 1} and it.inbox.counts['/cmd'] == 1


def test_recorded_messages_keep_their_times_and_the_recorder_writes_events_and_meta(tmp_path):
    rec = Recorder()
    assert not rec.active
    rec.write('/imu', _imu(1.0), 1.0)              # nothing open: nothing written, no error
    assert rec.close() == []
    path = str(tmp_path / 'r.bag')
    rec.open(path)
    it = _intake(recorder=rec)
    it.on_message(_from(_imu(0.5), '/sim_world'), '/imu')
    rec.event(0.25, 'event', id='go', action='walk')
    rec.meta({'seed': 3, 'inputs': ['/imu']}, 0.0)
    threads = [threading.Thread(target=lambda i=i: rec.write('/n', Float32(i), 1.0 + i))
               for i in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert rec.close() == [] and not rec.active
    with rosbag.Bag(path) as b:
        msgs = [(topic, t.to_sec()) for topic, _m, t in b.read_messages()]
        events = [json.loads(m.data) for _tp, m, _t in b.read_messages(topics=[EVENTS_TOPIC])]
        assert read_meta(b) == {'seed': 3, 'inputs': ['/imu']}
    assert ('/imu', 0.5) in msgs and (META_TOPIC, 1e-9) in [
        (tp, round(t, 9)) for tp, t in msgs]
    assert events == [{'action': 'walk', 'id': 'go', 't': 0.25, 'text': 'event'}]
    assert sorted(t for tp, t in msgs if tp == '/n') == [1.0 + i for i in range(8)]


def test_recording_order_is_time_then_topic_then_arrival():
    rows = [(1, 0, 1, '/b', 'b1'), (0, 5, 2, '/z', 'z'), (1, 0, 3, '/a', 'a'),
            (1, 0, 4, '/b', 'b2'), (0, 500000000, 5, '/a', 'early')]
    assert [r[4] for r in recording_order(rows)] == ['z', 'early', 'a', 'b1', 'b2']


def _file_order(path):
    """(topic, log time ns) of an MCAP file's messages in the order they are in the file."""
    from mcap.reader import make_reader
    with open(path, 'rb') as f:
        return [(ch.topic, m.log_time) for _s, ch, m in
                make_reader(f).iter_messages(log_time_order=False)]


def test_a_slices_messages_go_to_the_file_in_one_order_whichever_thread_came_first(tmp_path):
    """Messages of different topics at one sim time reach the intake in whatever order the
    subscriber threads run (an app's answer, a latched topic, a world node's messages over
    sockets): the recording is the same file, byte for byte, for every such order. What
    came in is written at the end of the slice handshake (stamp_held, then the Recorder's
    flush), by time, then topic, then arrival within a topic."""
    def world(t):
        return lambda: _from(_imu(t), '/sim_world')

    def app(v):
        return lambda: _from(Float32(v), '/app')           # unstamped: at the slice's end
    per_topic = {'/mobile_device/imu': [world(0.25), world(0.25)],
                 '/mobile_device/fix': [world(0.25), world(0.5)],
                 '/mobile_device/audio': [world(0.2)],
                 '/app/answer': [app(2.0), app(1.0)]}
    files = []
    for n, order in enumerate((['/mobile_device/imu', '/mobile_device/fix', '/mobile_device/imu',
                                '/app/answer', '/mobile_device/audio', '/mobile_device/fix',
                                '/app/answer'],
                               ['/app/answer', '/mobile_device/fix', '/app/answer',
                                '/mobile_device/audio', '/mobile_device/imu',
                                '/mobile_device/fix', '/mobile_device/imu'])):
        rec = Recorder()
        paths = [str(tmp_path / ('r%d.bag' % n)), str(tmp_path / ('r%d.mcap' % n))]
        rec.open(paths)
        it = _intake(recorder=rec)
        it.hold_unstamped, it.input_node = True, '/sim_world'
        left = {topic: list(msgs) for topic, msgs in per_topic.items()}
        for topic in order:
            it.on_message(left[topic].pop(0)(), topic)
        rec.event(0.5, 'event', id='go', action='walk')
        it.stamp_held(0.5)        # the handshake's end (Runner.answered): the slice is
        rec.flush()               # timed and written
        assert rec.close() == []
        files.append([open(p, 'rb').read() for p in paths])
    assert files[0] == files[1]
    ms = 1000000
    assert _file_order(str(tmp_path / 'r1.mcap')) == [
        ('/mobile_device/audio', 200 * ms), ('/mobile_device/fix', 250 * ms),
        ('/mobile_device/imu', 250 * ms), ('/mobile_device/imu', 250 * ms),
        ('/app/answer', 500 * ms), ('/app/answer', 500 * ms), ('/mobile_device/fix', 500 * ms),
        (EVENTS_TOPIC, 500 * ms)]
    with rosbag.Bag(str(tmp_path / 'r1.bag')) as b:    # a topic's own order: its arrival
        answers = [m.data for _tp, m, _t in b.read_messages(topics=['/app/answer'])]
    assert answers == [2.0, 1.0]


def test_a_recording_that_cannot_be_made_is_an_error_naming_the_file(tmp_path):
    from testing_instance.io.mcap_io import RecordingError
    rec = Recorder()
    (tmp_path / 'file').write_text('a file, not a folder')
    bad = str(tmp_path / 'file' / 'r.bag')
    try:
        rec.open(bad)
    except RecordingError as e:
        assert str(tmp_path / 'file') in str(e) and 'cannot create the recording' in str(e)
    else:
        raise AssertionError('no error for %s' % bad)
    assert not rec.active


def test_world_inputs_are_the_subscribed_topics_of_the_world_node_not_our_own():
    it = _intake(own=['/cmd'])
    it.world_node = '/lab/sim_world'
    it.subs = {'/lab/imu': 1, '/cmd': 1, '/app/out': 1}
    pubs = [('/lab/imu', ['/lab/sim_world']), ('/cmd', ['/lab/sim_world']),
            ('/app/out', ['/app']), ('/lab/gps', ['/lab/sim_world'])]
    assert it.world_inputs(pubs) == ['/lab/imu', '/gazebo/environment']


def test_string_messages_are_recorded_whole(tmp_path):
    rec = Recorder()
    rec.open(str(tmp_path / 's.bag'))
    rec.write('/s', String('x' * 10000), 2.0)
    rec.close()
    with rosbag.Bag(str(tmp_path / 's.bag')) as b:
        assert [m.data for _tp, m, _t in b.read_messages()] == ['x' * 10000]


def _graph(monkeypatch, asked, unconnected=(), unaccepted=()):
    """A master and world node: the world publishes /mobile_device/imu and /mixed (with
    /other), /app publishes /app/out; the runner's subscriptions to ``unconnected`` never
    connect, the world never takes its connections to ``unaccepted``. Returns a rospy."""
    import rosgraph
    import xmlrpc.client

    class Master(object):
        def __init__(self, *a, **k):
            asked['Master'] += 1

        def getPublishedTopics(self, ns):
            return [('/mobile_device/imu', 'sensor_msgs/Imu')]

        def getSystemState(self):
            asked['getSystemState'] += 1
            return ([('/mobile_device/imu', ['/sim_world']),
                     ('/app/out', ['/app']), ('/mixed', ['/sim_world', '/other'])], [], [])

        def lookupNode(self, name):
            asked['lookupNode'] += 1
            return 'http://localhost:1/'

    class Proxy(object):
        def __init__(self, uri):
            pass

        def getBusInfo(self, me):
            asked['getBusInfo'] += 1
            return [1, '', [[i, me, 'o', 'TCPROS', t, True] for i, t in enumerate(
                ['/mobile_device/imu', '/mixed']) if t not in unaccepted]]

    class Sub(object):
        def __init__(self, topic, cls, cb, **kw):
            self.topic = topic

        def get_num_connections(self):
            return 0 if self.topic in unconnected else 1

    class Rospy(FakeRospy):
        Subscriber = Sub
    monkeypatch.setattr(rosgraph, 'Master', Master)
    monkeypatch.setattr(xmlrpc.client, 'ServerProxy', Proxy)
    return Rospy()


def test_subscribing_asks_the_master_for_its_state_once_and_classifies_by_it(monkeypatch):
    """One getSystemState per subscribe that found new topics: it tells the world's topics
    from the others' (classify) and which the world must accept (wait_publisher_side)."""
    asked = collections.Counter()
    rospy_ = _graph(monkeypatch, asked)
    it = Intake(Inbox(), Recorder())
    it.world_node = '/sim_world'
    it.start(rospy_)
    it.topic_types = {'/mobile_device/imu': 'sensor_msgs/Imu', '/app/out': 'std_msgs/String',
                      '/mixed': 'std_msgs/Float32'}
    new = it.subscribe(['/mobile_device/imu', '/app/out', '/mixed', '/not/published'],
                       apps=['/app'])
    assert sorted(new) == ['/app/out', '/mixed', '/mobile_device/imu']
    assert asked['getSystemState'] == 1, asked
    assert asked['getBusInfo'] == 1                  # both world topics accepted at once
    assert it.world_topics == {'/mobile_device/imu', '/mixed'}
    assert it.uncounted == {'/mixed'}                # /other publishes it too
    # nothing new: no master round trip at all
    assert it.subscribe(['/mobile_device/imu', '/app/out']) == []
    assert asked['getSystemState'] == 1
    # one master proxy for the intake's look-ups: its connection stays open
    assert it.published_types() == {'/mobile_device/imu': 'sensor_msgs/Imu'}
    assert asked['Master'] == 1


def test_a_subscription_that_does_not_connect_is_said_not_passed_over(monkeypatch):
    """The runner's subscription with no publisher connected, and one the world never took
    on its side, after CONNECT_WAIT: one WARNING each, naming the topics; the run goes on."""
    from testing_instance.run import intake
    monkeypatch.setattr(intake, 'CONNECT_WAIT', 0.2)
    said = []
    it = Intake(Inbox(), Recorder(), said.append)
    it.world_node = '/sim_world'
    it.start(_graph(monkeypatch, collections.Counter(), unconnected={'/app/out'},
                    unaccepted={'/mixed'}))
    it.topic_types = {'/mobile_device/imu': 'sensor_msgs/Imu', '/app/out': 'std_msgs/String',
                      '/mixed': 'std_msgs/Float32'}
    t0 = time.monotonic()
    assert sorted(it.subscribe(['/mobile_device/imu', '/app/out', '/mixed'])) == [
        '/app/out', '/mixed', '/mobile_device/imu']
    assert time.monotonic() - t0 < 5.0
    assert said == [
        'WARNING no publisher of /app/out connected to the runner within 0.2 s of wall time; '
        'their messages until one does are lost',
        "WARNING the world node /sim_world did not take the runner's connection to /mixed "
        'within 0.2 s of wall time; its messages until it does are lost']


def test_on_new_publisher_hears_this_processes_publishers_only(monkeypatch):
    """Intake.on_new_publisher: rospy's registration listeners (as rospy tells the master)
    call back for each publisher this process declares, not for subscribers or services."""
    from rospy.impl import registration
    from rospy.impl.registration import Registration, RegistrationListeners
    listeners = RegistrationListeners()       # this test's own, not the process's
    monkeypatch.setattr(registration, 'get_registration_listeners', lambda: listeners)
    heard = []
    it = Intake(Inbox(), Recorder())
    it.on_new_publisher(heard.append)
    listeners.notify_added('/mobile_device/late', 'std_msgs/String', Registration.PUB)
    listeners.notify_added('/mobile_device/sub', 'std_msgs/String', Registration.SUB)
    listeners.notify_added('/gazebo/srv', 'rosrpc://x:1', Registration.SRV)
    assert heard == ['/mobile_device/late']
    it.close()                                # the run is over: no longer told
    listeners.notify_added('/mobile_device/later', 'std_msgs/String', Registration.PUB)
    assert heard == ['/mobile_device/late'] and listeners.listeners == []
    it.close()                                # twice: nothing to remove
