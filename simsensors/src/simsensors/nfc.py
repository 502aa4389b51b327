"""NFC and RFID (thesis 3.3.8): devices with a maximum range, a main direction and a mode;
a proxy connects two of them that see each other, at least one active.

``libgazebo_ros_nfc.so`` on a phone: ``range`` (m, default 0.04, at most 0.10),
``direction`` (omni | +x | -x | +z | -z of the report frame, ``mobile_device_frame`` on the
phone: +z out of the screen), ``coneAngle`` (deg, half-angle around the direction, default
60), ``mode`` (active | passive), ``name`` (default the robot namespace, else the model
name), ``data`` (what a passive phone gives to a reader). Topics in the phone's namespace,
as in the thesis's flow:

* ``nfc/notification`` (mobile_device_sim/NfcNotification {name, type, status}): a partner
  came into (``connected``) or left (``disconnected``) range and direction;
* ``nfc/outgoing`` (mobile_device_sim/NfcOutgoing {receiver, data}, in): the proxy delivers
  ``data`` to the connected partner named ``receiver`` (empty: the only partner); without a
  connected partner of that name: one warning line and nothing is delivered;
* ``nfc/incoming`` (mobile_device_sim/NfcIncoming {sender, data}): what partners sent; an
  active device that connects to a passive tag (or passive phone with ``data``) reads it
  here at once.

``nfc/enable`` (std_msgs/Bool) switches the phone's NFC like its other radios (parameter
``enabled``, default true; flag ``nfc`` and a draw of ``power`` W, default 0, on the power
bus): a switched-off device neither connects nor reads nor sends (``nfc/outgoing``: one
warning line); switching it off ends its connections at once, and both sides get
``disconnected``; switched on, it connects again at the next evaluation.

``libgazebo_ros_nfc_tag.so`` on any model: a passive tag (no topics) with ``data`` (e.g. an
NDEF URL record ``U:http://...``), ``range``, ``direction``, ``name`` (default the model
name). A tag without data: one line naming it, and the tag stays out of the world. Writing
to a tag (outgoing with its name) replaces its data.

The proxy is in the world process (``NfcProxy``, one per world; the thesis's "proxy node"):
it is evaluated once per sim time at the devices' ``updateRate`` (10 Hz of sim time), from the
link poses, so connections follow the simulation exactly and repeat with the same seed.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

from .wifi import RadioSwitch

__all__ = ['NfcDevice', 'NfcTag', 'NfcProxy', 'proxy_of', 'sees', 'AXES']


AXES = {'+x': (1.0, 0.0, 0.0), '-x': (-1.0, 0.0, 0.0), '+z': (0.0, 0.0, 1.0),
        '-z': (0.0, 0.0, -1.0)}
DIRECTIONS = ('omni', '+x', '-x', '+z', '-z')
MAX_RANGE = 0.10


def _range_ok(v):
    return 0 < v <= MAX_RANGE


def sees(pose, direction, cone_deg, other_p):
    """Does a device at ``pose`` with main ``direction`` see the point ``other_p``?"""
    if direction == 'omni':
        return True
    v = np.asarray(other_p, float) - pose.p
    n = float(np.linalg.norm(v))
    if n < 1e-9:
        return True
    axis = pose.rotate(np.asarray(AXES[direction]))
    return float(np.dot(v / n, axis)) >= math.cos(math.radians(cone_deg))


class NfcProxy(object):
    """Connects the world's NFC devices (see module doc)."""

    def __init__(self, world):
        self.world = world
        self.devices = []
        self.pairs = set()        # frozenset({a, b}) of connected devices
        self.t = None

    def add(self, dev):
        self.devices.append(dev)
        self.t = None

    def remove(self, dev):
        if dev in self.devices:
            self.devices.remove(dev)
        for pr in [p for p in self.pairs if dev in p]:
            self.pairs.discard(pr)
            other = next(iter(pr - {dev}))
            other.notify(dev, 'disconnected')

    def drop(self, dev):
        """``dev`` was switched off: its connections end now, both sides told."""
        for pr in sorted([p for p in self.pairs if dev in p], key=self._key):
            self.pairs.discard(pr)
            a, b = sorted(pr, key=lambda d: d.name)
            a.notify(b, 'disconnected')
            b.notify(a, 'disconnected')

    def partners(self, dev):
        return [next(iter(p - {dev})) for p in self.pairs if dev in p]

    def connectable(self, a, b, pa, pb):
        if a.mode != 'active' and b.mode != 'active':
            return False
        d = float(np.linalg.norm(pa.p - pb.p))
        if d > min(a.range, b.range):
            return False
        return sees(pa, a.direction, a.cone, pb.p) and sees(pb, b.direction, b.cone, pa.p)

    def update(self, t):
        if self.t is not None and abs(self.t - t) < 1e-12:
            return
        self.t = t
        devs = sorted(self.devices, key=lambda d: d.name)
        poses = {}
        for d in devs:
            try:
                poses[d] = d.device_pose()
            except KeyError:
                continue
        now = set()
        live = [d for d in devs if d in poses and d.enabled]
        for i, a in enumerate(live):
            for b in live[i + 1:]:
                if self.connectable(a, b, poses[a], poses[b]):
                    now.add(frozenset((a, b)))
        for pr in sorted(self.pairs - now, key=self._key):
            a, b = sorted(pr, key=lambda d: d.name)
            a.notify(b, 'disconnected')
            b.notify(a, 'disconnected')
        for pr in sorted(now - self.pairs, key=self._key):
            a, b = sorted(pr, key=lambda d: d.name)
            a.notify(b, 'connected')
            b.notify(a, 'connected')
            for reader, card in ((a, b), (b, a)):     # an active device reads a passive one
                if reader.mode == 'active' and card.mode == 'passive' and card.data:
                    reader.receive(card, card.data)
        self.pairs = now

    @staticmethod
    def _key(pr):
        return tuple(sorted(d.name for d in pr))

    def send(self, sender, receiver, data):
        """Deliver ``data`` from ``sender`` to its connected partner ``receiver`` (empty:
        the only partner). Returns the partner or raises LookupError saying why not."""
        if not sender.enabled:
            raise LookupError('NFC of %s is switched off (nfc/enable)' % sender.name)
        parts = self.partners(sender)
        if receiver:
            match = [p for p in parts if p.name == receiver]
        else:
            match = parts if len(parts) == 1 else []
        if not match:
            raise LookupError('no connected NFC partner %s (connected: %s)' % (
                repr(receiver) if receiver else '(receiver empty and not exactly one)',
                ', '.join(sorted(p.name for p in parts)) or 'none'))
        partner = match[0]
        partner.receive(sender, data)
        return partner


def proxy_of(world):
    """The world's NFC proxy (one per world, made on first use)."""
    return world.shared('nfc_proxy', NfcProxy)


class _NfcBase(Sensor):
    DEFAULT_RATE = 10.0
    ALWAYS_MEASURE = True
    proxy = None
    enabled = True                # a tag is always on; the phone's NFC has a switch
    name = mode = '?'
    COMMON = [
        Param('range', float, 0.04, aliases=('maxRange', 'max_range'), unit='m',
              check=_range_ok, check_text='> 0 and <= 0.10', doc='maximum distance to a partner (at most 0.10 m)'),
        Param('direction', DIRECTIONS, 'omni', doc='main direction in the report frame'),
        Param('coneAngle', float, 60.0, aliases=('cone_angle',), unit='deg',
              check=(0.0, 180.0), doc='half-angle around the direction'),
    ]

    def register_device(self):
        self.range = self.p.range
        self.direction = self.p.direction
        self.cone = self.p.coneAngle
        self.proxy = proxy_of(self.world)
        self.proxy.add(self)

    def device_pose(self):
        return self.state().pose

    def measure(self, state, dt):
        self.proxy.update(state.t)
        return None

    def notify(self, partner, status):
        pass

    def receive(self, sender, data):
        pass

    def shutdown(self):
        if self.proxy is not None:
            self.proxy.remove(self)
        Sensor.shutdown(self)

    def __repr__(self):
        return '<NFC %s %s>' % (self.name, self.mode)


@register('libgazebo_ros_nfc.so', 'libnfc.so')
class NfcDevice(RadioSwitch, _NfcBase):
    DEFAULT_TOPIC = 'nfc/notification'
    ENABLE_TOPIC = 'nfc/enable'
    FLAG = 'nfc'
    PARAMS = _NfcBase.COMMON + [
        Param('mode', ('active', 'passive'), 'active'),
        Param('name', str, None, doc='default: the robot namespace, else the model name'),
        Param('data', str, '', doc='what a passive device gives to a reader'),
        Param('outgoingTopicName', str, 'nfc/outgoing'),
        Param('incomingTopicName', str, 'nfc/incoming'),
    ] + RadioSwitch.switch_params(0.0)

    def setup(self):
        from mobile_device_sim.msg import NfcIncoming, NfcNotification, NfcOutgoing
        self.NfcIncoming, self.NfcNotification = NfcIncoming, NfcNotification
        self.mode = self.p.mode
        self.name = self.p.name or self.namespace or self.model.name
        self.data = self.p.data
        # events between ticks (the proxy connects and delivers): through the gate
        self.output('main', NfcNotification, event=True, noisy=False)
        self.incoming_pub = self.output('incoming', NfcIncoming,
                                        topic=self.p.incomingTopicName, event=True,
                                        noisy=False)
        self.subscribe(self.p.outgoingTopicName, NfcOutgoing, self.on_outgoing)
        self.notifications = []       # (sim time, name, type, status)
        self.received = []            # (sim time, sender, data)
        self.register_device()
        self.setup_switch()

    def on_switch(self, on):
        if not on and self.proxy is not None:
            with self.world.lock:
                self.proxy.drop(self)

    def notify(self, partner, status):
        m = self.NfcNotification(name=partner.name, type=partner.mode, status=status)
        self.notifications.append((self.world.sim_time, partner.name, partner.mode, status))
        self.emit('main', m)

    def receive(self, sender, data):
        self.received.append((self.world.sim_time, sender.name, data))
        self.emit('incoming', self.NfcIncoming(sender=sender.name, data=data))

    def on_outgoing(self, msg):
        """nfc/outgoing: deliver to the connected partner; else one warning line."""
        with self.world.lock:
            try:
                return self.proxy.send(self, msg.receiver.strip(), msg.data)
            except LookupError as e:
                self.world.log.warning('%s: nfc/outgoing not delivered: %s', self.label, e)
                return None


@register('libgazebo_ros_nfc_tag.so', 'libnfc_tag.so')
class NfcTag(_NfcBase):
    DEFAULT_TOPIC = None
    PARAMS = _NfcBase.COMMON + [
        Param('data', str, None, aliases=('ndef', 'ndefData'),
              doc='the tag\'s content, e.g. an NDEF URL record "U:http://..."'),
        Param('name', str, None, doc='default: the model name'),
    ]

    def setup(self):
        self.mode = 'passive'
        self.name = self.p.name or self.model.name
        self.data = self.p.data
        self.received = []
        if not self.data:
            self.log_error('%s: NFC tag %s has no data (<data>); the tag is left out'
                           % (self.label, self.name))
            return
        self.register_device()

    def receive(self, sender, data):
        """A reader writes the tag."""
        self.received.append((self.world.sim_time, sender.name, data))
        self.data = data

    def measure(self, state, dt):
        if self.proxy is not None:
            self.proxy.update(state.t)
        return None
