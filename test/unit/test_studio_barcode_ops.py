"""The studio's decoded barcode (sim_studio/barcode.py) and the phones' display stream
(server.Studio._stream_displays, world.WorldLink.watch_images), without a roscore: the office
desk's QR paper as a camera image, decoded with the scenario runner's own decoder; the
expectation a click makes, checked by the validator; the display images as their own
latest-wins stream."""
import asyncio
import base64
import json
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import FakeWorld, FakeWs, PHONE, run  # noqa: E402

from sim_studio import barcode  # noqa: E402
from sim_studio.recorder import check  # noqa: E402
from sim_studio.server import Client, Studio  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
QR = os.path.join(ROOT, 'sim_world', 'worlds', 'media', 'qr_paper.png')
URL = 'http://vmi.lmt.ei.tum.de'
CAMERA = '/mobile_device/image_raw'


def image(rgb):
    from simvid.imageconv import array_to_image
    return array_to_image(rgb, 'rgb8')


def qr_image():
    from PIL import Image
    return image(np.asarray(Image.open(QR).convert('RGB')))


class World(FakeWorld):
    camera_topic = CAMERA

    def __init__(self):
        FakeWorld.__init__(self)
        self.image = None
        self.images, self.image_seqs, self.watched, self.encoded = {}, {}, [], []

    def show(self, msg, topic=CAMERA):
        self.images[topic] = msg
        self.image_seqs[topic] = self.image_seqs.get(topic, 0) + 1
        if topic == CAMERA:
            self.image = msg
            self.image_seq += 1

    def watch_images(self, topics):
        self.watched.append(list(topics))

    def image_jpeg(self, topic, width=None):
        from sim_studio.world import jpeg_of
        self.encoded.append(topic)
        return jpeg_of(self.images.get(topic), width=width)


def studio(world=None, models=(PHONE,)):
    s = Studio(world or World(), list(models), rate=40)
    s.logged = []
    s.log = s.logged.append
    return s


def test_the_studio_decodes_with_the_runners_decoder_and_the_runner_accepts_its_text():
    from testing_instance.scenario.expect import Predicate
    msg = qr_image()
    codes = barcode.decode(msg)
    assert codes == [{'type': 'QR-Code', 'data': URL}]
    pred = Predicate({'barcode': codes[0]['data']})       # what the expectation will say
    assert pred.test(pred.image_facts(msg))
    assert barcode.decode(image(np.full((60, 80, 3), 200, np.uint8))) == []


def watch(s, c, on=True):
    rep = asyncio.new_event_loop().run_until_complete(
        s.handle_text(json.dumps({'v': 1, 'op': 'barcode', 'on': on}), c))
    assert rep['ok'] and rep['on'] is on, rep


def test_a_new_camera_image_is_decoded_once_and_only_while_a_page_that_asked_is_there():
    s = studio()
    loop = asyncio.new_event_loop()
    s.world.show(qr_image())
    c, script = Client(FakeWs(), '127.0.0.1'), Client(FakeWs(), '127.0.0.1')
    s.clients += [c, script]
    loop.run_until_complete(barcode.tick(s, loop))
    assert s.barcode_reader.result is None                    # nobody asked: no decode
    watch(s, c)
    loop.run_until_complete(barcode.tick(s, loop))
    assert 'barcode' not in script.slots                      # only to the page that asked
    m = json.loads(c.slots.pop('barcode'))
    assert m['type'] == 'barcode' and m['topic'] == CAMERA and m['error'] is None
    assert m['codes'] == [{'type': 'QR-Code', 'data': URL}]
    seq = s.barcode_reader.seq
    s.barcode_reader.result['codes'] = 'kept'                 # not decoded again...
    loop.run_until_complete(barcode.tick(s, loop))
    assert s.barcode_reader.seq == seq and json.loads(c.slots['barcode'])['codes'] == 'kept'
    s.world.show(image(np.zeros((40, 40, 3), np.uint8)))      # ...until a new image
    loop.run_until_complete(barcode.tick(s, loop))
    assert json.loads(c.slots.pop('barcode'))['codes'] == []
    s.clients.remove(c)                                       # the page left: no decode
    s.world.show(qr_image())
    loop.run_until_complete(barcode.tick(s, loop))
    assert s.barcode_reader.result['codes'] == [] and not s.barcode_reader.watchers
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'barcode', 'on': True})))
    assert not rep['ok'] and 'not to POST /api/cmd' in rep['error']


def test_an_image_the_decoder_cannot_read_is_one_log_line_and_the_reader_goes_on():
    s = studio()
    loop = asyncio.new_event_loop()
    s.clients.append(Client(FakeWs(), '127.0.0.1'))
    watch(s, s.clients[0])
    for _ in range(2):
        bad = image(np.zeros((4, 4, 3), np.uint8))
        bad.encoding = '32FC1'
        s.world.show(bad)
        loop.run_until_complete(barcode.tick(s, loop))
    m = json.loads(s.clients[0].slots['barcode'])
    assert m['codes'] == [] and 'cannot decode barcodes of %s' % CAMERA in m['error']
    assert len(s.logged) == 1 and m['error'] in s.logged[0]
    s.world.show(qr_image())
    loop.run_until_complete(barcode.tick(s, loop))
    assert json.loads(s.clients[0].slots['barcode'])['codes'][0]['data'] == URL


def test_the_barcode_op_decodes_the_latest_image_and_says_when_there_is_none():
    s = studio()
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'barcode'})))
    assert not rep['ok'] and 'no image from the camera topic %s' % CAMERA in rep['error']
    s.world.show(qr_image())
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'barcode'})))
    assert rep['ok'] and rep['codes'] == [{'type': 'QR-Code', 'data': URL}], rep


def test_expect_barcode_adds_the_runners_image_expectation_and_the_yaml_validates():
    s = studio()
    body = {'v': 1, 'op': 'expect_barcode', 'topic': CAMERA, 'text': URL,
            'mode': 'eventually', 'start': 0, 'end': 2.5}
    rep = run(s.handle_text(json.dumps(body)))
    assert rep['ok'], rep
    assert rep['expect'] == {'name': 'barcode', 'topic': CAMERA,
                             'eventually': {'barcode': URL}, 'window': [0.0, 2.5]}
    line = '  - {name: barcode, topic: %s, eventually: {barcode: "%s"}, window: [0, 2.5]}' \
        % (CAMERA, URL)
    assert line in rep['yaml'].splitlines(), rep['yaml']
    assert 'duration: 2.5' in rep['yaml'] and check(rep['yaml']) == []
    # no window: the whole run; a second one gets a name of its own
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'expect_barcode', 'topic': CAMERA,
                                        'text': 'a: "b"', 'mode': 'always'})))
    assert rep['expect'] == {'name': 'barcode_2', 'topic': CAMERA,
                             'always': {'barcode': 'a: "b"'}}
    assert check(rep['yaml']) == []
    import yaml
    assert yaml.safe_load(rep['yaml'])['expect'][1]['always'] == {'barcode': 'a: "b"'}


@pytest.mark.parametrize('extra, words', [
    ({'start': 1}, 'a window needs both start and end'),
    ({'start': 2, 'end': 1}, 'start < end'),
    ({'mode': 'sometimes'}, 'one of eventually, always'),
    ({'text': ''}, 'non-empty string'),
    ({'field': 'data'}, 'unknown field field'),
])
def test_a_bad_expect_barcode_is_one_error_and_adds_nothing(extra, words):
    s = studio()
    body = dict({'v': 1, 'op': 'expect_barcode', 'topic': CAMERA, 'text': URL,
                 'mode': 'eventually'}, **extra)
    rep = run(s.handle_text(json.dumps(body)))
    assert not rep['ok'] and words in rep['error'], rep
    assert s.recorder.expects == [] and len(s.logged) == 1


# -- the displays' own image stream ------------------------------------------------------------
APP_SCREEN = '/qr_app/screen'


def phone(name, topic):
    return dict(PHONE, name=name, display=dict(PHONE['display'], image_topic=topic))


def tick(s, now):
    loop = asyncio.new_event_loop()
    return loop.run_until_complete(s._stream_displays(loop, now))


def shown(c, model):
    m = json.loads(c.slots.pop('display:' + model))
    assert m['type'] == 'display' and m['model'] == model
    return m


def test_each_display_streams_its_own_topic_latest_wins_a_new_image_only():
    from PIL import Image
    import io
    s = studio(models=[phone('mobile_device', APP_SCREEN), phone('phone2', CAMERA),
                       dict(PHONE, name='blank', display=dict(PHONE['display']))])
    s.display_rate = 10.0
    c = Client(FakeWs(), '127.0.0.1')
    s.clients.append(c)
    tick(s, 100.0)
    assert s.world.watched == [[CAMERA, APP_SCREEN]]          # subscribed once a page watches
    assert c.slots == {}                                      # no image yet: nothing
    green = np.zeros((30, 40, 3), np.uint8)
    green[:, :, 1] = 200
    s.world.show(image(green), APP_SCREEN)
    s.world.show(qr_image())
    tick(s, 100.2)
    m = shown(c, 'mobile_device')
    assert m['topic'] == APP_SCREEN
    px = np.asarray(Image.open(io.BytesIO(base64.b64decode(m['jpeg']))).convert('RGB'))
    assert px.shape == (30, 40, 3) and abs(px[..., 1].mean() - 200) < 8 and px[..., 2].max() < 20
    assert shown(c, 'phone2')['topic'] == CAMERA and 'display:blank' not in c.slots
    s.world.show(image(green), APP_SCREEN)
    tick(s, 100.25)                                           # a new one, but too soon
    assert c.slots == {}
    tick(s, 100.35)
    assert shown(c, 'mobile_device') and c.slots == {}
    tick(s, 100.6)                                            # the same images: not again
    assert c.slots == {} and s.world.watched == [[CAMERA, APP_SCREEN]]
    n = len(s.world.encoded)
    s.want_display = True                                     # a new page: the latest again,
    tick(s, 100.7)                                            # from the JPEGs already made
    assert set(c.slots) == {'display:mobile_device', 'display:phone2'}
    assert len(s.world.encoded) == n


def test_a_large_display_image_is_sent_scaled_to_the_pages_view():
    from PIL import Image
    import io
    from sim_studio.server import DISPLAY_WIDTH
    s = studio(models=[phone('mobile_device', CAMERA)])
    s.world.show(qr_image())                                  # 840 x 1188
    c = Client(FakeWs(), '127.0.0.1')
    s.clients.append(c)
    tick(s, 50.0)
    img = Image.open(io.BytesIO(base64.b64decode(shown(c, 'mobile_device')['jpeg'])))
    assert img.size == (DISPLAY_WIDTH, round(1188 * DISPLAY_WIDTH / 840))
    assert barcode.decode(image(np.asarray(img.convert('RGB'))))[0]['data'] == URL


def test_the_world_link_watches_each_display_topic_once_beside_the_camera():
    from sim_studio.world import WorldLink

    class Rospy(object):
        subs = []

        def Subscriber(self, topic, typ, cb, callback_args=None, queue_size=None,  # noqa
                       buff_size=None):
            self.subs.append((topic, queue_size))
            return (cb, callback_args)

    w = WorldLink(Rospy(), CAMERA)
    w.watch_images([CAMERA, APP_SCREEN])
    w.watch_images([APP_SCREEN])
    assert Rospy.subs == [(APP_SCREEN, 1)]
    cb, topic = w.subs[0]
    msg = qr_image()
    cb(msg, topic)
    w._on_image(msg)
    assert w.image_seqs == {APP_SCREEN: 1, CAMERA: 1} and w.images[APP_SCREEN] is msg
    jpeg = w.image_jpeg(APP_SCREEN)
    assert jpeg[:2] == b'\xff\xd8' and w.image_jpeg('/nothing') is None
