"""``studio --foxglove``: the studio's world on foxglove-sdk's WebSocket server
(sim_studio.foxglove_server), without a roscore: a stand-in world, the SDK's real server,
and a plain WebSocket client speaking Foxglove's ws-protocol (subprotocol, advertise,
subscribe, binary message data) that decodes the protobuf messages with the schemas the
server advertises."""
import asyncio
import base64
import json
import struct
import sys
import time

import pytest

pytest.importorskip('foxglove')

from sim_studio import foxglove_server as fs  # noqa: E402
from sim_studio.node import parser  # noqa: E402
from sim_studio.server import Studio  # noqa: E402

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import PHONE, FakeWorld  # noqa: E402

LINK = {'name': 'body', 'pose': {'position': [0, 0, 0.1], 'orientation': [0, 0, 0, 1]},
        'visuals': [{'geometry': {'kind': 'box', 'size': [0.07, 0.15, 0.008]},
                     'origin': {'position': [0, 0, 0], 'orientation': [0, 0, 0, 1]},
                     'rgba': [0.1, 0.1, 0.1, 1]},
                    {'geometry': {'kind': 'cylinder', 'radius': 0.01, 'length': 0.002},
                     'origin': {'position': [0, 0.05, 0.005], 'orientation': [0, 0, 0, 1]},
                     'rgba': [0, 0, 0, 1]}]}


class Fix(object):
    """sensor_msgs/NavSatFix's fields the bridge reads."""
    class header(object):
        frame_id = 'gps'

        class stamp(object):
            @staticmethod
            def to_sec():
                return 2.5
    latitude, longitude, altitude = 48.137, 11.575, 519.0
    position_covariance = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 4.0]
    position_covariance_type = 2


class FakeRospy(object):
    def __init__(self):
        self.subs = []

    def Subscriber(self, topic, _typ, cb, queue_size=None):
        rospy = self

        class Sub(object):
            def unregister(self):
                rospy.subs.remove(self)
        s = Sub()
        s.topic, s.cb = topic, cb
        self.subs.append(s)
        return s


def decoder(channel):
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    assert channel['encoding'] == 'protobuf'
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel['schema']))
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel['schemaName']))


async def listen(port, topics, until):
    """Subscribe to ``topics``; {topic: [decoded message]} once ``until(got)`` or 10 s."""
    import aiohttp
    got = {t: [] for t in topics}
    async with aiohttp.ClientSession() as ses:
        async with ses.ws_connect('ws://127.0.0.1:%d/' % port,
                                  protocols=('foxglove.sdk.v1', 'foxglove.websocket.v1')) \
                as ws:
            assert ws.protocol in ('foxglove.sdk.v1', 'foxglove.websocket.v1')
            subs = {}
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and not until(got):
                try:
                    m = await ws.receive(timeout=0.1)
                except asyncio.TimeoutError:
                    continue
                if m.type == aiohttp.WSMsgType.TEXT:
                    d = json.loads(m.data)
                    if d['op'] == 'advertise':
                        want = [c for c in d['channels'] if c['topic'] in topics]
                        for i, c in enumerate(want):
                            subs[i + 1] = (c['topic'], decoder(c))
                        await ws.send_str(json.dumps({'op': 'subscribe', 'subscriptions': [
                            {'id': i, 'channelId': c['id']}
                            for i, c in zip(sorted(subs), want)]}))
                elif m.type == aiohttp.WSMsgType.BINARY and m.data[0] == 1:
                    sub, stamp = struct.unpack('<IQ', m.data[1:13])
                    topic, cls = subs[sub]
                    got[topic].append((stamp, cls.FromString(m.data[13:])))
                else:
                    assert m.type == aiohttp.WSMsgType.BINARY, m
    return got


def bridge(rospy=None):
    s = Studio(FakeWorld(), [dict(PHONE, links=[LINK])], camera_rate=50)
    s.log = lambda text: None
    s.world.image_seq = 1
    return fs.FoxgloveBridge(s, rospy or FakeRospy(), 0, rate=50).start()


def serve(b, topics, until, during=None):
    async def go():
        task = asyncio.ensure_future(b.run())
        try:
            return await listen(b.port, topics, until)
        finally:
            task.cancel()
    try:
        return asyncio.new_event_loop().run_until_complete(go())
    finally:
        b.stop()


def test_a_client_gets_the_scene_tf_and_camera_images_in_foxgloves_schemas():
    b = bridge()
    cam = '/mobile_device/image_raw/compressed'
    b.studio.world.camera_topic = None
    b.image_ch.close()
    from foxglove.channels import CompressedImageChannel
    b.image_ch = CompressedImageChannel(cam)
    got = serve(b, ['/scene', '/tf', cam], lambda g: all(g.values()))
    stamp, tf = got['/tf'][0]
    assert stamp == 2500000000                           # the world's sim time, ns
    frames = {t.child_frame_id: t for t in tf.transforms}
    assert set(frames) >= {'mobile_device', 'desk', 'mobile_device/body'}
    t = frames['mobile_device/body']
    assert t.parent_frame_id == 'world'
    assert (t.translation.x, t.translation.y, t.translation.z) == pytest.approx((1, 2, 3.1))
    _s, scene = got['/scene'][0]
    (e,) = scene.entities
    assert e.frame_id == 'mobile_device/body' and e.frame_locked
    assert [c.size.y for c in e.cubes] == [pytest.approx(0.15)]
    assert [c.size.x for c in e.cylinders] == [pytest.approx(0.02)]
    _s, img = got[cam][0]
    assert img.format == 'jpeg' and img.data == b'\xff\xd8 a jpeg'


def test_the_fix_is_subscribed_only_while_a_client_listens_and_becomes_a_location_fix():
    rospy = FakeRospy()
    b = bridge(rospy)
    b.publish_once()
    assert rospy.subs == []                 # nobody listens: the phone's GPS is not woken
    seen = []

    def until(got):
        seen.append([s.topic for s in rospy.subs])
        for s in rospy.subs:             # the phone's GPS "publishes" once subscribed
            s.cb(Fix())
        return bool(got['/mobile_device/fix'])
    got = serve(b, ['/mobile_device/fix'], until)
    assert ['/mobile_device/fix'] in seen and b.sent['fix'] >= 1
    assert rospy.subs == []                 # let go when the bridge stops
    stamp, fix = got['/mobile_device/fix'][0]
    assert (fix.latitude, fix.longitude, fix.altitude) == (48.137, 11.575, 519.0)
    assert list(fix.position_covariance) == Fix.position_covariance
    assert stamp == 2500000000 and fix.frame_id == 'gps'


def test_nothing_is_built_for_channels_nobody_listens_to():
    b = bridge()
    try:
        b.publish_once()
        assert b.sent == {'scene': 0, 'tf': 0, 'image': 0, 'fix': 0}
        assert b._image_due()[0] is False          # no JPEG is made for nobody
        assert b._fix_subs == {}                    # the phone's GPS is not woken
    finally:
        b.stop()


def test_the_option_takes_an_optional_port_before_launch_arguments():
    def parse(*argv):
        a = parser().parse_args(list(argv))
        return fs.split_port(a.foxglove, a.args)
    assert parse() == (None, [])
    assert parse('--foxglove') == (fs.DEFAULT_PORT, [])
    assert parse('--foxglove', '9100', 'seed:=3') == (9100, ['seed:=3'])
    assert parse('--foxglove', 'seed:=3') == (fs.DEFAULT_PORT, ['seed:=3'])
    with pytest.raises(SystemExit, match='a port number, got x'):
        parse('--foxglove', 'x')
