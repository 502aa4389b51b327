"""testing_instance.io.mcap_io: recordings as rosbag or MCAP (ROS 1), no roscore.

The same messages written to a rosbag and an MCAP file read back equal (bytes, times,
topics, types); the MCAP file is what Foxglove reads (profile ros1, ros1msg schemas with the
message definition); a file that is not a recording or is cut short is one clear error."""
import os

import pytest

rospy = pytest.importorskip('rospy')
pytest.importorskip('mcap_ros1')

from testing_instance.io.mcap_io import (RecordingError, open_reader,  # noqa: E402
                                      open_writer)


def _messages():
    from sensor_msgs.msg import Image, Imu
    from std_msgs.msg import String
    out = []
    for i in range(20):
        imu = Imu()
        imu.header.stamp = rospy.Time(0, 10_000_000 * i)
        imu.header.frame_id = 'imu'
        imu.linear_acceleration.z = 9.81 + 0.01 * i
        out.append(('/mobile_device/imu_sensor_data', imu, imu.header.stamp))
    img = Image(height=2, width=3, encoding='rgb8', step=9, data=bytes(range(18)))
    img.header.stamp = rospy.Time(0, 50_000_000)
    out.append(('/mobile_device/image_raw', img, img.header.stamp))
    out.append(('/scenario/events', String('{"id": "e"}'), rospy.Time(0, 70_000_000)))
    return out


def test_bag_and_mcap_written_together_read_back_equal(tmp_path):
    bag, mc = str(tmp_path / 'r.bag'), str(tmp_path / 'r.mcap')
    w = open_writer([bag, mc])
    for topic, msg, t in _messages():
        w.write(topic, msg, t)
    w.close()
    with open(mc, 'rb') as f:
        assert f.read(8) == b'\x89MCAP0\r\n'
    got = {}
    for path in (bag, mc):
        r = open_reader(path)
        got[path] = [(tp, t.to_nsec(), raw) for tp, raw, t in r.read_messages(raw=True)]
        decoded = list(r.read_messages())
        r.close()
        assert len(decoded) == 22
        imu = [m for tp, m, _t in decoded if tp == '/mobile_device/imu_sensor_data']
        assert imu[3].linear_acceleration.z == pytest.approx(9.84)
        assert imu[3]._type == 'sensor_msgs/Imu'
    key = lambda x: (x[0], x[1])  # noqa: E731
    assert sorted(got[bag], key=key) == sorted(got[mc], key=key)
    # Foxglove's view: ros1 profile, ros1msg schema with the full definition
    from mcap.reader import make_reader
    with open(mc, 'rb') as f:
        r = make_reader(f)
        assert r.get_header().profile == 'ros1'
        summ = r.get_summary()
        schemas = {s.name: s for s in summ.schemas.values()}
        assert schemas['sensor_msgs/Imu'].encoding == 'ros1msg'
        assert b'geometry_msgs/Vector3 linear_acceleration' in schemas['sensor_msgs/Imu'].data
        assert {c.message_encoding for c in summ.channels.values()} == {'ros1'}


def test_topics_filter_and_single_mcap(tmp_path):
    mc = str(tmp_path / 'only.mcap')
    w = open_writer(mc)
    for topic, msg, t in _messages():
        w.write(topic, msg, t)
    w.close()
    r = open_reader(mc)
    got = [m.data for _tp, m, _t in r.read_messages(topics=['/scenario/events'])]
    assert got == ['{"id": "e"}']


def test_not_a_recording_and_truncated_are_one_clear_error(tmp_path):
    junk = tmp_path / 'junk.mcap'
    junk.write_text('hello, no recording here\n')
    with pytest.raises(RecordingError, match=r'junk.mcap is not a recording \(neither a '
                       r'rosbag nor an MCAP file'):
        open_reader(str(junk))
    with pytest.raises(RecordingError, match='cannot open the recording'):
        open_reader(str(tmp_path / 'missing.bag'))
    mc = str(tmp_path / 'cut.mcap')
    w = open_writer(mc)
    for topic, msg, t in _messages():
        w.write(topic, msg, t)
    w.close()
    data = open(mc, 'rb').read()
    cut = tmp_path / 'cut_short.mcap'
    cut.write_bytes(data[:len(data) // 2])
    r = open_reader(str(cut))
    with pytest.raises(RecordingError, match=r'cut_short.mcap \(truncated or damaged\?\)'):
        list(r.read_messages())
    assert os.path.getsize(str(cut)) < len(data)


def test_a_long_recording_does_not_grow_the_writer(tmp_path):
    """bench/soak found rosbag keeping an index entry per written message in memory (~200
    bytes each); the runner's writer forgets them and the file stays whole and indexed."""
    import tracemalloc
    import rospy
    from std_msgs.msg import String
    from testing_instance.io.mcap_io import open_writer, open_reader
    w = open_writer(str(tmp_path / 'long.bag'))
    m = String('x' * 20)

    def write(a, b):
        for i in range(a, b):
            w.write('/t%d' % (i % 7), m, rospy.Time.from_sec(1 + i * 0.001))
    write(0, 5000)                                  # connections, first chunk
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    write(5000, 45000)
    grown = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    w.close()
    # the current chunk's entries stay (rosbag writes them with the chunk): well under the
    # 200 bytes per message of the plain rosbag.Bag
    assert grown / 40000.0 < 40, grown / 40000.0
    r = open_reader(str(tmp_path / 'long.bag'))
    ts = [t.to_sec() for _tp, _m, t in r.read_messages()]
    r.close()
    assert len(ts) == 45000 and ts == sorted(ts) and abs(ts[-1] - (1 + 44999 * 0.001)) < 1e-6


def test_the_runners_bag_is_rosbags_bytes_written_a_chunk_at_a_time(tmp_path):
    """The runner's rosbag writer (bagwriter.BagWriter) writes byte for byte what
    rosbag.Bag writes: several chunks, a topic first seen in a later chunk, messages out of
    time order on one topic (rosbag's index keeps each topic's entries sorted), a unicode
    topic-free string field, the index and the chunk infos, the header rewritten at close.
    The file is written a chunk at a time, not four or five writes a message."""
    import rosbag
    from sensor_msgs.msg import Imu
    from std_msgs.msg import String
    from testing_instance.io.bagwriter import BagWriter

    class Counting(object):
        def __init__(self, f):
            self.f, self.calls = f, 0

        def write(self, data):
            self.calls += 1
            return self.f.write(data)

        def __getattr__(self, name):
            return getattr(self.f, name)

    def write(bag, n=6000):
        for i in range(n):
            m = Imu()
            m.header.stamp = rospy.Time(1 + i // 100, (i % 100) * 10_000_000)
            m.header.frame_id = 'imu'
            m.linear_acceleration.z = 9.81 + 1e-4 * i
            t = m.header.stamp
            if i % 7 == 0:                 # a held app message, timed at its slice's end
                t = rospy.Time(t.secs, 990_000_000)
            bag.write('/mobile_device/imu_sensor_data' if i % 3 else '/other', m, t)
            if i == 4000:
                bag.write('/app/out', String(u'gr\u00fc\u00dfe'), t)
        bag.close()

    plain, mine = str(tmp_path / 'plain.bag'), str(tmp_path / 'mine.bag')
    write(rosbag.Bag(plain, 'w'))
    b = BagWriter(mine)
    counting = Counting(b._file)
    b._file = counting
    write(b)
    with open(plain, 'rb') as f1, open(mine, 'rb') as f2:
        one, two = f1.read(), f2.read()
    assert len(one) > 2 * 768 * 1024                     # more than two chunks
    assert one == two
    assert counting.calls < 10, counting.calls           # a write a chunk, two at close
    b.close()                                            # closing again does nothing
    with pytest.raises(ValueError):
        b.write('/x', String('late'), rospy.Time(9))
    r = open_reader(mine)
    got = [(tp, t.to_sec()) for tp, _m, t in r.read_messages()]
    r.close()
    assert len(got) == 6001 and ('/app/out', 41.0) in got
