"""The decoded barcode of the phone camera (issue 47 part 4): the studio decodes the camera
panel's image with the scenario runner's own decoder (``testing_instance.scenario.expect.
Predicate.image_facts``: simvid.barcode, zbar), at most ``RATE`` times a second of wall
time, in a worker thread, only while a page that asked for it is connected (``{"op":
"barcode", "on": true}``: the page does at its start; a script that did not costs nothing)
and only for an image it has not decoded yet, and streams the result to those pages
(``{"type": "barcode", "topic", "t", "codes": [{type, data}], "error"}``, latest wins). The page (static/ext/barcode.js) shows it under the camera
view; in assert mode a click on a decoded text adds the runner's image expectation
``{topic: CAMERA, eventually: {barcode: TEXT}, window: [start, end]}`` (op
``expect_barcode``), which ``run_scenario`` judges with the same decoder."""
import asyncio

from .protocol import ProtocolError

__all__ = ['OPS', 'handle', 'routes', 'decode', 'expectation', 'RATE']

RATE = 2.0          # decodes per second of wall time at most
MODES = ('eventually', 'always')


def _window_check(f):
    if (f['start'] is None) != (f['end'] is None):
        raise ProtocolError('expect_barcode: a window needs both start and end')
    if f['start'] is not None and not f['start'] < f['end']:
        raise ProtocolError('expect_barcode: the window needs start < end, got [%g, %g]'
                            % (f['start'], f['end']))


OPS = {
    'barcode': dict(
        required={}, optional={'on': None}, kinds={'on': 'bool'},
        doc="the barcodes decoded now in the camera panel's latest image (the runner's "
            'decoder): `topic`, `t` (its stamp), `codes` [{type, data}], `error`; `on` '
            'true/false: stream them to this page (2 Hz, a new image only) or stop'),
    'expect_barcode': dict(
        required={'topic': 'str', 'text': 'str', 'mode': MODES},
        optional={'start': None, 'end': None, 'name': None},
        changes_world=False, needs_control=True, field_check=_window_check,
        doc="add the runner's image expectation `barcode: text` on topic (always or "
            'eventually, in the window [start, end] s; default the whole run) to the '
            "recording's scenario; replies with `expect` and `yaml`"),
}


def decode(msg):
    """[{'type', 'data'}] of the barcodes in the sensor_msgs/Image ``msg``, decoded by the
    scenario runner's own code (the facts an image expectation with ``barcode`` is judged
    on: ``Predicate.image_facts``); raises the runner's FieldError when it cannot decode."""
    from testing_instance.scenario.expect import Predicate
    facts = Predicate({'barcode': ''}).image_facts(msg)
    return [{'type': text.split(',', 1)[0], 'data': data}
            for data, text in zip(facts['barcodes'], facts['barcode_texts'])]


def expectation(f):
    """The scenario's expectation entry (without its name) of ``expect_barcode``'s fields."""
    e = {'topic': f['topic'], f['mode']: {'barcode': f['text']}}
    if f['start'] is not None:
        e['window'] = [f['start'], f['end']]
    return e


def _stamp(msg):
    try:
        return round(msg.header.stamp.to_sec(), 3)
    except AttributeError:
        return None


class Reader(object):
    """The latest decode of the camera's image (one per new image)."""

    def __init__(self, studio):
        self.studio = studio
        self.seq = None
        self.result = None               # the stream message's fields
        self.errors = set()              # the decode errors already logged
        self.watchers = set()            # the clients that asked for the stream

    def watching(self, clients):
        """The clients that asked for the stream and are still connected."""
        self.watchers &= set(clients)
        return [c for c in clients if c in self.watchers]

    def due(self):
        w = self.studio.world
        return getattr(w, 'image', None) is not None and getattr(w, 'image_seq', 0) != self.seq

    def read(self):
        """Decode the latest camera image (in a worker thread); the message's fields."""
        w = self.studio.world
        msg, seq = w.image, w.image_seq
        codes, error = [], None
        try:
            codes = decode(msg)
        except Exception as e:  # noqa: BLE001 - zbar missing, an odd encoding: say it once
            error = 'cannot decode barcodes of %s: %s' % (w.camera_topic, e)
            if error not in self.errors:
                self.errors.add(error)
                self.studio.log('studio: %s' % error)
        self.seq = seq
        self.result = {'topic': w.camera_topic, 't': _stamp(msg), 'codes': codes,
                       'error': error}
        return self.result


def _reader(studio):
    r = getattr(studio, 'barcode_reader', None)
    if r is None:
        r = studio.barcode_reader = Reader(studio)
    return r


async def tick(studio, loop):
    """One look: decode a new camera image while a page that asked is connected, and send
    the latest result to those pages."""
    r = _reader(studio)
    watchers = r.watching(studio.clients)
    if not watchers:
        return
    if r.due():
        await loop.run_in_executor(None, r.read)
    if r.result is not None:
        studio.broadcast('barcode', r.result, watchers)


async def handle(studio, cmd, client):
    loop = asyncio.get_event_loop()
    f = cmd.fields
    if cmd.op == 'barcode':
        r = _reader(studio)
        if f['on'] is not None:
            if client is None:
                raise ValueError('barcode: the stream goes to a page (/ws), not to POST '
                                 '/api/cmd')
            (r.watchers.add if f['on'] else r.watchers.discard)(client)
            return {'on': f['on']}
        if getattr(studio.world, 'image', None) is None:
            raise ValueError('barcode: no image from the camera topic %s yet'
                             % getattr(studio.world, 'camera_topic', None))
        if r.due():
            await loop.run_in_executor(None, r.read)
        return dict(r.result)
    entry = studio.recorder.add_expect(expectation(f), f['name'] or 'barcode')
    studio._tell_recording()
    return {'expect': entry, 'yaml': studio.recorder.yaml()}


def routes(app, studio):
    """The reader's task: a look every 1/RATE s of wall time."""
    from .extensions import periodic
    periodic(app, studio, 'barcode', 1.0 / RATE,
             lambda: tick(studio, asyncio.get_event_loop()))
