"""Live images of any image topic (issue 47 part 1: the flycam's, and any other camera's or
display's): the panel "live images" (static/ext/images.js) lists the world's
sensor_msgs/Image topics, as rqt_image_view does, and shows the one a page picked (at first
the flycam's, ``/flycam/image_raw``, when the world has it).

Ops: ``image_topics`` (the master's sensor_msgs/Image topics, sorted: ``topics``);
``watch_image`` {topic} (this page's live image from now on; without topic: stop): the topic is
subscribed once (queue size 1, ``WorldLink.watch_images``, shared with the display view)
and its latest image goes to that page as ``{"type": "image", "topic", "t", "jpeg"}`` (a
base64 JPEG) at most ``RATE`` times a second of wall time, a new image only, in the page's
own slot (latest wins: a slow page never holds the world or the others back). A topic that
is not an image topic of the master is one error naming it, and the page keeps what it
watched."""
import asyncio
import base64
import json

from .protocol import VERSION

__all__ = ['OPS', 'handle', 'routes', 'image_topics', 'RATE', 'FLYCAM']

RATE = 10.0                    # images per second of wall time at most, per page
FLYCAM = '/flycam/image_raw'
IMAGE = 'sensor_msgs/Image'

OPS = {
    'image_topics': dict(required={}, optional={}, changes_world=False, needs_control=False,
                         doc="the world's sensor_msgs/Image topics (the master's), sorted"),
    'watch_image': dict(required={}, optional={'topic': None}, kinds={'topic': 'str'},
                        changes_world=False, needs_control=False,
                        doc="stream this page the latest image of topic (a sensor_msgs/Image "
                            "topic of the master; without topic: stop) as {type: image, "
                            "topic, t, jpeg}"),
}


def image_topics(published):
    """The image topics of ``published`` ([(topic, type)], rospy.get_published_topics')."""
    return sorted(t for t, ty in published if ty == IMAGE)


def _published(studio):
    return studio.world.rospy.get_published_topics()


class Watch(object):
    """Which page watches which topic, and what went out to it."""

    def __init__(self):
        self.topics = {}          # client -> topic
        self.sent = {}            # client -> (seq, wall) of the last image sent
        self.jpeg = {}            # topic -> (seq, base64 JPEG or None)

    def due(self, clients, seqs, now):
        """[(client, topic, seq)] that get a new image now."""
        out = []
        for c in list(self.topics):
            if c not in clients or c.ws.closed:
                self.topics.pop(c, None)
                self.sent.pop(c, None)
                continue
            topic = self.topics[c]
            seq = seqs.get(topic, 0)
            last_seq, last_at = self.sent.get(c, (-1, 0.0))
            if seq and seq != last_seq and now - last_at >= 1.0 / RATE:
                out.append((c, topic, seq))
        return out


def _watch(studio):
    w = getattr(studio, 'image_watch', None)
    if w is None:
        w = studio.image_watch = Watch()
    return w


async def tick(studio, loop, now):
    w = _watch(studio)
    world = studio.world
    for c, topic, seq in w.due(studio.clients, getattr(world, 'image_seqs', {}), now):
        cached = w.jpeg.get(topic)
        if cached is None or cached[0] != seq:
            jpeg = await loop.run_in_executor(None, world.image_jpeg, topic)
            cached = w.jpeg[topic] = (seq, base64.b64encode(jpeg).decode() if jpeg else None)
        w.sent[c] = (seq, now)
        if cached[1]:
            msg = world.images.get(topic)
            t = msg.header.stamp.to_sec() if msg is not None else world.clock
            c.put('image', json.dumps({'v': VERSION, 'type': 'image', 'topic': topic,
                                       't': round(t, 3), 'jpeg': cached[1]},
                                      separators=(',', ':')))


async def handle(studio, cmd, client):
    loop = asyncio.get_event_loop()
    topics = image_topics(await loop.run_in_executor(None, _published, studio))
    if cmd.op == 'image_topics':
        return {'topics': topics, 'default': FLYCAM if FLYCAM in topics else
                (topics[0] if topics else None)}
    topic = cmd.fields.get('topic')
    w = _watch(studio)
    if not topic:
        w.topics.pop(client, None)
        return {'topic': None}
    if topic not in topics:
        raise ValueError('watch_image: %s is not an image topic of the master (%s)'
                         % (topic, ', '.join(topics) or 'none'))
    if client is None:
        raise ValueError('watch_image: streams go to a page (/ws), not to POST /api/cmd')
    await loop.run_in_executor(None, studio.world.watch_images, [topic])
    w.topics[client] = topic
    w.sent.pop(client, None)
    return {'topic': topic}


def routes(app, studio):
    """The streaming task: a look every 1/RATE s of wall time."""
    import time
    from .extensions import periodic
    periodic(app, studio, 'images', 1.0 / RATE,
             lambda: tick(studio, asyncio.get_event_loop(), time.monotonic()))
