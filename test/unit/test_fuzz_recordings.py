"""Fuzzed recordings for --replay (issue 19 item 3): a rosbag or MCAP recording cut short,
bit-flipped, overwritten, grown, or no recording at all goes through
``testing_instance.run.replay.load_recording`` (what `run_scenario --replay` reads before it
starts anything). Every result is either one RecordingError line naming the file, or a
replayable recording (meta, one legal message type per input topic, messages in time order
that serialize again as the replay publishes them) with at most one warning line naming the
file. Never another exception.

The suite runs 200 derandomized inputs (a few seconds); bench/fuzz runs more, randomised
(MDS_FUZZ_EXAMPLES, MDS_FUZZ_SEED)."""
import io
import json
import os
import re

import pytest

rospy = pytest.importorskip('rospy')
pytest.importorskip('mcap_ros1')
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from testing_instance.io.mcap_io import RecordingError, open_writer  # noqa: E402
from testing_instance.run.replay import load_recording  # noqa: E402

IMU = '/mobile_device/imu_sensor_data'
TYPE_RE = re.compile(r'\A[A-Za-z]\w*/[A-Za-z]\w*\Z')


def write_recording(path, n=40, chunk=None):
    """A small run_scenario-like recording: meta, IMU inputs, timeline events, an output."""
    from sensor_msgs.msg import Imu
    from std_msgs.msg import String
    w = open_writer(path)
    if chunk is not None:           # several chunks: a cut keeps the complete ones
        if path.endswith('.mcap'):
            from mcap_ros1.writer import Writer
            w._f.seek(0)
            w._f.truncate()
            w._w = Writer(w._f, chunk_size=chunk)
        else:
            w._chunk_threshold = chunk
    meta = dict(scenario='/x.yaml', seed=1, real_time_factor=0, inputs=[IMU], t0=0.0,
                duration=1.0, types={IMU: 'sensor_msgs/Imu'})
    w.write('/scenario/meta', String(json.dumps(meta)), rospy.Time(0))
    for i in range(n):
        m = Imu()
        m.header.stamp = rospy.Time.from_sec(0.02 * i)
        m.header.frame_id = 'mobile_device_frame'
        m.linear_acceleration.z = 9.81
        w.write(IMU, m, m.header.stamp)
        if i % 15 == 5:
            w.write('/scenario/events', String(json.dumps(
                dict(text='event', id='e%d' % i, t=0.02 * i, action='log'))), m.header.stamp)
        w.write('/app/out', String('x%d' % i), m.header.stamp)
    w.close()


_ORIGINALS = {}


@pytest.fixture(scope='module')
def originals(tmp_path_factory):
    """{'r.bag': bytes, 'r.mcap': bytes}: the recordings the fuzzer mutates."""
    if not _ORIGINALS:
        d = tmp_path_factory.mktemp('rec')
        for name in ('r.bag', 'r.mcap'):
            write_recording(str(d / name))
            _ORIGINALS[name] = (d / name).read_bytes()
    return _ORIGINALS


def check_loaded(path):
    """load_recording(path) gives one named error line or a replayable recording."""
    try:
        rec = load_recording(path)
    except RecordingError as e:
        text = str(e)
        assert path in text and '\n' not in text, text
        return 'error'
    assert isinstance(rec.meta, dict) and isinstance(rec.meta['inputs'], list)
    times = [m[0] for m in rec.msgs]
    assert times == sorted(times)
    for topic, cls in rec.types.items():
        assert topic in rec.meta['inputs'] and TYPE_RE.match(cls._type), (topic, cls._type)
    for _t, topic, msg in rec.msgs:
        if topic == '/scenario/events':
            assert isinstance(msg, dict) and isinstance(msg['id'], str)
        else:
            assert type(msg)._md5sum == rec.types[topic]._md5sum
            msg.serialize(io.BytesIO())         # what the replay's publisher does
    if rec.warning is not None:
        assert path in rec.warning and '\n' not in rec.warning, rec.warning
        return 'partial'
    return 'ok'


def mutate(data, draw):
    kind = draw(st.sampled_from(['truncate', 'flip', 'flips', 'overwrite', 'insert',
                                 'delete', 'random', 'magic_then_junk', 'empty']))
    b = bytearray(data)
    if not b:
        return draw(st.binary(max_size=64))
    if kind == 'truncate':
        return bytes(b[:draw(st.integers(0, len(b)))])
    if kind in ('flip', 'flips'):
        for _ in range(1 if kind == 'flip' else draw(st.integers(2, 40))):
            i = draw(st.integers(0, len(b) - 1))
            b[i] ^= 1 << draw(st.integers(0, 7))
        return bytes(b)
    if kind == 'overwrite':
        i = draw(st.integers(0, len(b) - 1))
        junk = draw(st.binary(min_size=1, max_size=64))
        b[i:i + len(junk)] = junk
        return bytes(b)
    if kind == 'insert':
        i = draw(st.integers(0, len(b)))
        return bytes(b[:i]) + draw(st.binary(min_size=1, max_size=64)) + bytes(b[i:])
    if kind == 'delete':
        i = draw(st.integers(0, len(b) - 1))
        return bytes(b[:i]) + bytes(b[i + draw(st.integers(1, 256)):])
    if kind == 'random':
        return draw(st.binary(max_size=512))
    if kind == 'magic_then_junk':
        return bytes(b[:16]) + draw(st.binary(max_size=256))
    return b''


@settings(max_examples=int(os.environ.get('MDS_FUZZ_EXAMPLES', '200')), deadline=None,
          derandomize=not os.environ.get('MDS_FUZZ_SEED'), database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large])
@pytest.mark.usefixtures('originals')
@given(data=st.data())
def test_fuzzed_recordings_load_or_are_one_named_error(tmp_path, data):
    name = data.draw(st.sampled_from(sorted(_ORIGINALS)))
    blob = _ORIGINALS[name]
    for _ in range(data.draw(st.integers(1, 2))):
        blob = mutate(blob, data.draw)
    path = str(tmp_path / ('fuzzed_' + name))
    with open(path, 'wb') as f:
        f.write(blob)
    check_loaded(path)


def test_the_originals_load_whole(originals, tmp_path):
    for name, blob in originals.items():
        p = tmp_path / name
        p.write_bytes(blob)
        rec = load_recording(str(p))
        assert rec.warning is None
        assert len([m for m in rec.msgs if m[1] == IMU]) == 40
        assert [m[2]['id'] for m in rec.msgs if m[1] == '/scenario/events'] == \
            ['e5', 'e20', 'e35']


def _cut_in_half(tmp_path, ext):
    """A 400-message recording in 4 kB chunks, cut in the middle, loaded: (record, path,
    the IMU messages kept)."""
    whole = str(tmp_path / ('chunks.' + ext))
    write_recording(whole, n=400, chunk=4096)
    blob = open(whole, 'rb').read()
    p = tmp_path / ('cut.' + ext)
    p.write_bytes(blob[:len(blob) // 2])
    rec = load_recording(str(p))
    return rec, p, len([m for m in rec.msgs if m[1] == IMU])


def test_an_mcap_cut_short_replays_what_precedes_the_cut_with_one_warning(tmp_path):
    rec, p, n = _cut_in_half(tmp_path, 'mcap')
    assert rec.warning and str(p) in rec.warning and 'replaying the' in rec.warning
    assert 50 < n < 400, n


def test_a_bag_cut_short_replays_its_complete_chunks_with_one_warning(tmp_path):
    rec, p, n = _cut_in_half(tmp_path, 'bag')
    assert rec.warning and 'has no index' in rec.warning and str(p) in rec.warning
    assert 50 < n < 400, n


@pytest.mark.parametrize('meta, why', [
    ('{"inputs": "nope"}', 'no list of input topics'),
    ('[1, 2]', 'not a JSON object'),
    ('{"inputs": ["/ok", "bad topic"]}', 'not a ROS topic name'),
    ('{"inputs": [], "duration": NaN}', 'duration nan'),
    ('{"inputs": [], "t0": -1}', 't0 -1'),
    ('{"inputs": [], "duration": 1e300}', 'not a time in seconds'),
    ('{"inputs": [], "duration": 0}', 'not a time in seconds'),
    ('{"inputs": [], "pipeline": "yes"}', "pipeline 'yes', not true or false"),
    ('{"inputs": [', 'not a replayable recording'),
])
def test_a_damaged_meta_message_is_one_named_error(tmp_path, meta, why):
    from std_msgs.msg import String
    for ext in ('bag', 'mcap'):
        p = str(tmp_path / ('m.' + ext))
        w = open_writer(p)
        w.write('/scenario/meta', String(meta), rospy.Time(0))
        w.close()
        with pytest.raises(RecordingError, match=re.escape(why)) as e:
            load_recording(p)
        assert p in str(e.value)


def test_an_event_without_id_stops_the_replay_there(tmp_path):
    from std_msgs.msg import String
    from sensor_msgs.msg import Imu
    for ext in ('bag', 'mcap'):
        p = str(tmp_path / ('e.' + ext))
        w = open_writer(p)
        w.write('/scenario/meta', String(json.dumps(dict(inputs=[IMU], duration=1))),
                rospy.Time(0))
        w.write(IMU, Imu(), rospy.Time(0, 1000))
        w.write('/scenario/events', String('{"text": "event"}'), rospy.Time(0, 2000))
        w.write(IMU, Imu(), rospy.Time(0, 3000))
        w.close()
        rec = load_recording(p)
        assert [m[1] for m in rec.msgs] == [IMU]
        assert 'names no event id' in rec.warning and p in rec.warning
