"""sim_studio.images without ROS: the image topics of the master, the flycam's first, a page
watching a topic gets each new image once at most RATE a second in its own slot, a topic
that is not an image topic is one error and the page keeps what it watched."""
import asyncio
import types

import numpy as np
import pytest

from sim_studio import images

PUBLISHED = [('/mobile_device/image_raw', 'sensor_msgs/Image'), ('/clock', 'rosgraph_msgs/Clock'),
             ('/flycam/image_raw', 'sensor_msgs/Image'),
             ('/mobile_device/camera_info', 'sensor_msgs/CameraInfo')]


def _image(value):
    return types.SimpleNamespace(encoding='rgb8', width=4, height=2, step=12,
                                 data=bytes(np.full(24, value, np.uint8)),
                                 header=types.SimpleNamespace(
                                     stamp=types.SimpleNamespace(to_sec=lambda: 1.25)))


class _Client(object):
    def __init__(self):
        self.ws = types.SimpleNamespace(closed=False)
        self.slots = {}

    def put(self, key, payload):
        self.slots[key] = payload


def _studio(published=PUBLISHED):
    from sim_studio.world import jpeg_of
    watched = []
    world = types.SimpleNamespace(
        rospy=types.SimpleNamespace(get_published_topics=lambda: published),
        images={}, image_seqs={}, clock=2.0, watch_images=watched.extend,
        image_jpeg=lambda t, q=70: jpeg_of(world.images.get(t)))
    return types.SimpleNamespace(world=world, clients=[], log=print), watched


def _cmd(op, **fields):
    """A parsed command as protocol.parse gives it: .op, .fields, cmd[field]."""
    fields.setdefault('topic', None) if op == 'watch_image' else None
    return type('Cmd', (), {'op': op, 'fields': fields,
                            '__getitem__': lambda self, k: fields[k]})()


def _run(coro):
    return asyncio.new_event_loop().run_until_complete(coro)


def test_the_image_topics_and_the_flycam_first():
    assert images.image_topics(PUBLISHED) == ['/flycam/image_raw', '/mobile_device/image_raw']
    studio, _ = _studio()
    rep = _run(images.handle(studio, _cmd('image_topics'), None))
    assert rep == {'topics': ['/flycam/image_raw', '/mobile_device/image_raw'],
                   'default': '/flycam/image_raw'}
    studio, _ = _studio(PUBLISHED[:2])
    assert _run(images.handle(studio, _cmd('image_topics'), None))['default'] == \
        '/mobile_device/image_raw'


def test_a_watching_page_gets_each_new_image_once_at_the_rate():
    studio, watched = _studio()
    c, other = _Client(), _Client()
    studio.clients += [c, other]
    rep = _run(images.handle(studio, _cmd('watch_image', topic='/flycam/image_raw'), c))
    assert rep == {'topic': '/flycam/image_raw'} and watched == ['/flycam/image_raw']
    w = studio.world
    loop = asyncio.new_event_loop()
    loop.run_until_complete(images.tick(studio, loop, 10.0))
    assert c.slots == {}                              # no image yet
    w.images['/flycam/image_raw'], w.image_seqs['/flycam/image_raw'] = _image(200), 1
    loop.run_until_complete(images.tick(studio, loop, 10.0))
    import json
    m = json.loads(c.slots.pop('image'))
    assert (m['type'], m['topic'], m['t']) == ('image', '/flycam/image_raw', 1.25)
    assert m['jpeg'] and other.slots == {}            # only the page that asked
    loop.run_until_complete(images.tick(studio, loop, 10.0 + 0.2 / images.RATE))
    assert c.slots == {}                              # the same image: not again
    w.images['/flycam/image_raw'], w.image_seqs['/flycam/image_raw'] = _image(10), 2
    loop.run_until_complete(images.tick(studio, loop, 10.0 + 0.5 / images.RATE))
    assert c.slots == {}                              # too soon after the last
    loop.run_until_complete(images.tick(studio, loop, 10.0 + 1.01 / images.RATE))
    assert json.loads(c.slots.pop('image'))['jpeg'] != m['jpeg']
    c.ws.closed = True                                # a page gone is forgotten
    loop.run_until_complete(images.tick(studio, loop, 20.0))
    assert c not in studio.image_watch.topics


def test_a_bad_topic_is_one_error_and_the_watch_stays():
    studio, watched = _studio()
    c = _Client()
    studio.clients.append(c)
    _run(images.handle(studio, _cmd('watch_image', topic='/mobile_device/image_raw'), c))
    with pytest.raises(ValueError, match='/clock is not an image topic'):
        _run(images.handle(studio, _cmd('watch_image', topic='/clock'), c))
    assert studio.image_watch.topics[c] == '/mobile_device/image_raw'
    with pytest.raises(ValueError, match='streams go to a page'):
        _run(images.handle(studio, _cmd('watch_image', topic='/flycam/image_raw'), None))
    assert _run(images.handle(studio, _cmd('watch_image'), c)) == {'topic': None}
    assert c not in studio.image_watch.topics
