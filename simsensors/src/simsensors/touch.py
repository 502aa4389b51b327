"""The touch screen and the hardware buttons of thesis section 3.3.6 (code snippet 3.3.3):
``libgazebo_ros_touch.so``.

Touches come from contacts, as the thesis proposes: every world body whose collision shape
touches the display link (``bodyName``, default ``mobile_display``) on its front face
(``face``: front = +z of the link, back = -z) is one pointer of a multi-touch screen. The
physics engine's contact points (``world.contacts(model, link)``: position, normal,
penetration depth, like ODE's ``dContactGeom``) of one touching body are merged into one
pointer: its position is the depth-weighted mean of the points, projected onto the display
and given in display pixels of the display's resolution (the video texture on the same link,
``textvid``: x from the left edge, y from the top edge = the phone's camera end, like
Android's MotionEvent); its pressure is ``depth / pressureDepth`` (capped at 1) and its
pressure stage one of ``pressureStages`` equal steps of that depth.

Each body that starts touching gets the lowest free pointer id and a DOWN event; while it
stays, MOVE events follow when it moves by ``moveThreshold`` pixels or changes its pressure
stage; when it leaves, UP. A capacitive screen ignores wood and walls: contacts with static
models (the desk the phone lies on) are not touches unless ``touchStatic`` is true; they
still appear on ``contacts``.

Buttons are links of the phone (``buttons``: ``name:link`` pairs; default every one of
``power_button``, ``volume_up_button``, ``volume_down_button`` the model has): a contact of
any other body with the link (static ones too: pressing the phone's side against the desk
edge presses the button) publishes ``PRESSED``, its end ``RELEASED``.

Without a finger body, the services ``inject_touch`` (mobile_device_sim/InjectTouch: a tap
or a swipe in pixels, with a duration in sim time) and ``press_button``
(mobile_device_sim/PressButton) feed virtual contacts into the same tracker, so they produce
the same events.

Topics (robot namespace): ``touch`` (mobile_device_sim/TouchEvent, on events), ``buttons``
(mobile_device_sim/ButtonEvent, on events), ``contacts`` (mobile_device_sim/ContactsState,
gazebo_msgs' md5sum, every tick while subscribed, the contacts of the display and the
buttons). The contacts are sampled at ``updateRate`` (default 100 Hz of sim time, a phone
touch controller's report rate).
"""
import threading
from collections import deque

import numpy as np

from sim_world import srvcheck
from sim_world.plugins import PluginError, register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['TouchScreen', 'PointerTracker', 'DEFAULT_BUTTONS', 'DOWN', 'UP', 'MOVE']

DOWN, UP, MOVE = 0, 1, 2           # Android's MotionEvent.ACTION_DOWN, ACTION_UP, ACTION_MOVE
RELEASED, PRESSED = 0, 1
DEFAULT_BUTTONS = (('power', 'power_button'), ('volume_up', 'volume_up_button'),
                   ('volume_down', 'volume_down_button'))
LONG_SIDE = 512                    # textvid's default texture: 512 px on the long side


def _buttons(text):
    out = []
    for item in text.split():
        name, sep, link = item.partition(':')
        if not sep or not name or not link:
            raise ValueError('name:link pairs separated by spaces')
        out.append((name, link))
    return out


_buttons.what = 'name:link pairs separated by spaces (e.g. power:power_button)'


class PointerTracker(object):
    """Pointer ids and DOWN/MOVE/UP from the set of touching things at each sample (pure).

    ``update(current)`` takes {key: (x, y, depth, source)} and returns the events
    [(action, pointer id, x, y, depth, source)] in the order UP, MOVE, DOWN."""

    def __init__(self, move_threshold=0.5, stage_of=lambda depth: 0):
        self.active = {}           # key -> [id, x, y, depth, source]
        self.move_threshold = float(move_threshold)
        self.stage_of = stage_of

    def _free_id(self):
        used = set(v[0] for v in self.active.values())
        i = 0
        while i in used:
            i += 1
        return i

    def update(self, current):
        events = []
        for key in sorted(k for k in self.active if k not in current):
            pid, x, y, depth, source = self.active.pop(key)
            events.append((UP, pid, x, y, depth, source))
        for key in sorted(k for k in current if k in self.active):
            x, y, depth, source = current[key]
            a = self.active[key]
            moved = np.hypot(x - a[1], y - a[2]) >= self.move_threshold
            if moved or self.stage_of(depth) != self.stage_of(a[3]):
                a[1:] = [x, y, depth, source]
                events.append((MOVE, a[0], x, y, depth, source))
        for key in sorted(k for k in current if k not in self.active):
            x, y, depth, source = current[key]
            pid = self._free_id()
            self.active[key] = [pid, x, y, depth, source]
            events.append((DOWN, pid, x, y, depth, source))
        return events

    def release_all(self):
        return self.update({})


@register('libgazebo_ros_touch.so', 'libgazebo_ros_touch_sensor.so')
class TouchScreen(Sensor):
    DEFAULT_TOPIC = 'touch'
    DEFAULT_RATE = 100.0
    ALWAYS_MEASURE = True          # events depend on the history (pointer ids, DOWN/UP)
    USES_POSE = False              # reads contacts and the display's pose itself
    PARAMS = [
        Param('face', ('front', 'back'), 'front', doc='face of the display link that senses'),
        Param('displayWidth', int, None, aliases=('display_width',), unit='px', check='>0',
              doc='default: the video texture of the display link (textvid)'),
        Param('displayHeight', int, None, aliases=('display_height',), unit='px', check='>0'),
        Param('pressureDepth', float, 0.001, aliases=('pressure_depth',), unit='m',
              check='>0', doc='penetration depth of pressure 1.0'),
        Param('pressureStages', int, 3, aliases=('pressure_stages',), check=(1, 100),
              doc='pressure stages over 0..pressureDepth'),
        Param('moveThreshold', float, 0.5, aliases=('move_threshold',), unit='px',
              check='>=0', doc='movement that makes a MOVE event'),
        Param('touchStatic', bool, False, aliases=('touch_static',),
              doc='count contacts with static models (desk, walls) as touches'),
        Param('buttons', _buttons, None,
              doc='name:link pairs; default power:power_button volume_up:volume_up_button '
                  'volume_down:volume_down_button (those the model has)'),
        Param('buttonTopicName', str, 'buttons', aliases=('button_topic',)),
        Param('contactsTopicName', str, 'contacts', aliases=('contacts_topic', 'bumperTopicName')),
    ]

    def setup(self):
        from mobile_device_sim.msg import ButtonEvent, ContactsState, TouchEvent
        self.TouchEvent, self.ButtonEvent, self.ContactsState = TouchEvent, ButtonEvent, \
            ContactsState
        p = self.p
        if p.bodyName is None and self.spec.link is None and 'mobile_display' in self.model.links:
            self.body = 'mobile_display'
        self.half = self._half_extent()
        self._size = None
        if p.buttons is None:
            self.button_links = [(n, l) for n, l in DEFAULT_BUTTONS if l in self.model.links]
        else:
            self.button_links = []
            for n, l in p.buttons:
                if l not in self.model.links:
                    self.log_error('%s: buttons: %r is not a link of the model; button %s '
                                   'ignored' % (self.label, l, n))
                else:
                    self.button_links.append((n, l))
        self.output('main', TouchEvent, event=True, noisy=False)
        self.button_pub = self.output('buttons', ButtonEvent, topic=p.buttonTopicName,
                                      event=True, noisy=False)
        self.contacts_pub = self.output('contacts', ContactsState, topic=p.contactsTopicName,
                                        noisy=False)
        step = p.pressureDepth / p.pressureStages
        self.tracker = PointerTracker(p.moveThreshold,
                                      lambda d: min(p.pressureStages - 1, int(d / step)))
        self.pressed = {}          # button -> source
        self._lock = threading.Lock()
        self._inject = []          # [dict(key, start, end, x0, y0, x1, y1, depth)]
        self._inject_buttons = []  # [dict(button, start, end)]
        self._n_inject = 0
        self.events = deque(maxlen=1000)         # (t, action, id, x, y, pressure, stage)
        self.button_events = deque(maxlen=1000)  # (t, button, state)
        from mobile_device_sim.srv import InjectTouch, PressButton
        self.service('inject_touch', InjectTouch, self._srv_inject)
        self.service('press_button', PressButton, self._srv_press)

    # -- geometry ------------------------------------------------------------------------------
    def _half_extent(self):
        link = self.model.links[self.body]
        for items in (link.visuals, link.collisions):
            for v in items:
                if v.geometry.kind == 'box':
                    return np.asarray(v.geometry.size, float) / 2.0
        raise PluginError('%s: link %r has no box visual or collision to be a touch screen'
                          % (self.label, self.body))

    @property
    def size(self):
        """(width, height) px: parameters, else the display's video texture on the link,
        else textvid's default (512 px on the long side, square pixels)."""
        if self._size is None:
            w, h = self.p.displayWidth, self.p.displayHeight
            tex = None
            for pl in self.world.find_plugins(self.model.name):
                tex = pl.texture_size(self.body) or tex
            if tex is None:
                fw, fh = 2 * self.half[1], 2 * self.half[0]     # +z face: width along y
                tex = (int(round(LONG_SIDE * fw / fh)), LONG_SIDE) if fh >= fw else \
                    (LONG_SIDE, int(round(LONG_SIDE * fh / fw)))
            self._size = (w or tex[0], h or tex[1])
        return self._size

    def to_pixels(self, q):
        """Display pixels (x, y) of a point in the display link's frame. The image on the
        +z face has its top at +x and its right at -y of the link (sim_world.render.shapes); on
        the back face the image is mirrored."""
        w, h = self.size
        hx, hy = self.half[0], self.half[1]
        sy = -1.0 if self.p.face == 'front' else 1.0
        x = (hy + sy * q[1]) / (2 * hy) * w
        y = (hx - q[0]) / (2 * hx) * h
        return float(x), float(y)

    def from_pixels(self, x, y):
        w, h = self.size
        hx, hy = self.half[0], self.half[1]
        sy = -1.0 if self.p.face == 'front' else 1.0
        return np.array([hx - y / h * 2 * hx, sy * (x / w * 2 * hy - hy), 0.0])

    # -- services (ROS threads) ------------------------------------------------------------------
    def inject_touch(self, x, y, duration, pressure=0.5, x_end=-1.0, y_end=-1.0):
        """Queue a tap/swipe; returns (ok, status text, key)."""
        w, h = self.size
        try:
            x, y, x_end, y_end = (srvcheck.number(v, what, unit='px') for v, what in (
                (x, 'x'), (y, 'y'), (x_end, 'x_end'), (y_end, 'y_end')))
            duration = srvcheck.duration(duration)
            pressure = srvcheck.number(pressure, 'pressure', 0, 1)
            swipe = x_end >= 0 or y_end >= 0
            for what, (u, v) in (('', (x, y)), ('end ', (x_end, y_end) if swipe else (x, y))):
                if not (0 <= u <= w and 0 <= v <= h):
                    raise srvcheck.BadRequest('%s(%r, %r) is outside the display (0..%d, 0..%d '
                                              'px)' % (what, u, v, w, h))
        except srvcheck.BadRequest as e:
            return False, 'inject_touch: %s' % e, None
        with self._lock:
            self._n_inject += 1
            key = 'inject#%d' % self._n_inject
            now = self.world.sim_time
            self._inject.append(dict(key=key, start=now, end=now + duration, x0=x, y0=y,
                                     x1=x_end if swipe else x, y1=y_end if swipe else y,
                                     depth=(pressure or 0.5) * self.p.pressureDepth))
        return True, 'touch at (%g, %g) px for %g s' % (x, y, duration), key

    def press_button(self, button, duration):
        names = [n for n, _ in self.button_links]
        try:
            srvcheck.name(button, 'button', names, kind='button of %s' % self.model.name)
            duration = srvcheck.duration(duration)
        except srvcheck.BadRequest as e:
            return False, 'press_button: %s' % e
        with self._lock:
            now = self.world.sim_time
            self._inject_buttons.append(dict(button=button, start=now, end=now + duration))
        return True, '%s pressed for %g s' % (button, duration)

    def _srv_inject(self, req):
        from mobile_device_sim.srv import InjectTouchResponse
        ok, text, key = self.inject_touch(req.x, req.y, req.duration, req.pressure or 0.5,
                                          req.x_end, req.y_end)
        if not ok:
            self.log_error('%s: %s' % (self.label, text))
        return InjectTouchResponse(ok, text, -1)

    def _srv_press(self, req):
        from mobile_device_sim.srv import PressButtonResponse
        ok, text = self.press_button(req.button, req.duration)
        if not ok:
            self.log_error('%s: %s' % (self.label, text))
        return PressButtonResponse(ok, text)

    # -- sampling ----------------------------------------------------------------------------------
    def current_touches(self, t, contacts):
        """{key: (x px, y px, depth, source)} of the bodies touching the screen now."""
        pose = self.world.link_pose(self.model.name, self.body)
        inv = pose.inverse()
        zaxis = pose.rotate(np.array([0.0, 0.0, 1.0 if self.p.face == 'front' else -1.0]))
        groups = {}
        # a fixed order (the engines' broadphase order may differ from run to run): the
        # same contacts give the same sums, bit for bit
        for c in sorted(contacts, key=lambda c: (c.other_model, c.other_link,
                                                 tuple(c.position), c.depth)):
            if not self.p.touchStatic and self.world.models[c.other_model].static:
                continue
            if float(np.dot(c.normal, zaxis)) > -0.5:   # not pressing onto the sensing face
                continue
            groups.setdefault('%s::%s' % (c.other_model, c.other_link), []).append(c)
        out = {}
        for key, cs in groups.items():
            d = np.array([c.depth for c in cs])
            wts = d if d.sum() > 0 else np.ones(len(cs))
            pos = np.average([c.position for c in cs], axis=0, weights=wts)
            q = inv * pos
            if abs(q[0]) > self.half[0] or abs(q[1]) > self.half[1]:
                continue
            x, y = self.to_pixels(q)
            out[key] = (x, y, float(d.max()), key)
        with self._lock:
            keep = []
            for inj in self._inject:
                if inj.get('done'):          # its last sample was at the end point: UP now
                    continue
                keep.append(inj)
                inj['done'] = t >= inj['end']
                span = inj['end'] - inj['start']
                f = min(1.0, max(0.0, (t - inj['start']) / span)) if span > 0 else 1.0
                x = inj['x0'] + f * (inj['x1'] - inj['x0'])
                y = inj['y0'] + f * (inj['y1'] - inj['y0'])
                out[inj['key']] = (x, y, inj['depth'], 'inject')
            self._inject = keep
        return out

    def current_buttons(self, t, contacts_by_link):
        now = {}
        for name, link in self.button_links:
            cs = contacts_by_link.get(link, ())
            if cs:
                now[name] = '%s::%s' % (cs[0].other_model, cs[0].other_link)
        with self._lock:
            keep = []
            for b in self._inject_buttons:
                if b.get('done'):
                    continue
                keep.append(b)
                b['done'] = t >= b['end']
                now.setdefault(b['button'], 'inject')
            self._inject_buttons = keep
        return now

    def measure(self, state, dt):
        """(touch events, button changes, contacts) of this sample; the events are kept in
        ``events`` / ``button_events`` whoever listens."""
        t = state.t
        every = {}                  # one query for the whole phone, split by link
        for c in self.world.contacts(self.model.name):
            every.setdefault(c.link, []).append(c)
        screen = every.get(self.body, [])
        by_link = dict((link, every.get(link, [])) for _, link in self.button_links)
        touches = self.current_touches(t, screen)
        events = [self._touch(t, *e) for e in self.tracker.update(touches)]
        buttons = self.current_buttons(t, by_link)
        changes = [(n, PRESSED, s) for n, s in sorted(buttons.items()) if n not in self.pressed]
        changes += [(n, RELEASED, s) for n, s in sorted(self.pressed.items())
                    if n not in buttons]
        self.pressed = buttons
        for n, st, _ in changes:
            self.button_events.append((t, n, st))
        return events, changes, screen + sum(by_link.values(), [])

    def messages(self, value, stamp):
        events, changes, contacts = value
        buttons = []
        for n, state, source in changes:
            m = self.ButtonEvent()
            m.header.stamp, m.header.frame_id = stamp, self.frame_id
            m.button, m.state, m.source = n, state, source
            buttons.append(m)
        return [('main', [self._touch_msg(stamp, e) for e in events]),
                ('buttons', buttons),
                ('contacts', lambda: self.contacts_msg(stamp, contacts))]

    def _touch(self, t, action, pid, x, y, depth, source):
        """One touch event, kept in ``events``."""
        p = self.p
        pressure = min(1.0, depth / p.pressureDepth)
        stage = self.tracker.stage_of(depth)
        self.events.append((t, action, pid, x, y, pressure, stage))
        return (action, pid, x, y, depth, source, pressure, stage)

    def _touch_msg(self, stamp, e):
        action, pid, x, y, depth, source, pressure, stage = e
        m = self.TouchEvent()
        m.header.stamp, m.header.frame_id = stamp, self.frame_id
        m.action, m.pointer_id, m.x, m.y = action, pid, x, y
        m.pressure = pressure
        m.pressure_stage = stage
        m.depth = depth
        m.width, m.height = self.size
        m.source = source
        return m

    def contacts_msg(self, stamp, contacts):
        from mobile_device_sim.msg import ContactState
        m = self.ContactsState()
        m.header.stamp, m.header.frame_id = stamp, 'world'
        pairs = {}
        for c in contacts:
            pairs.setdefault((c.link, c.other_model, c.other_link), []).append(c)
        for (link, om, ol), cs in sorted(pairs.items()):
            s = ContactState()
            s.collision1_name = '%s::%s' % (self.model.name, link)
            s.collision2_name = '%s::%s' % (om, ol)
            s.info = 'Debug:  i:(%d/%d)     my geom:%s   other geom:%s' % (
                0, len(cs), s.collision1_name, s.collision2_name)
            for c in cs:
                from geometry_msgs.msg import Vector3, Wrench
                s.contact_positions.append(Vector3(*[float(v) for v in c.position]))
                s.contact_normals.append(Vector3(*[float(v) for v in c.normal]))
                s.depths.append(c.depth)
                s.wrenches.append(Wrench())
            m.states.append(s)
        return m

    def reset(self):
        Sensor.reset(self)
        stamp = self.stamp()
        for e in self.tracker.release_all():     # every pointer up: through the gate
            self.emit('main', self._touch_msg(stamp, self._touch(self.world.sim_time, *e)))
        with self._lock:
            self._inject, self._inject_buttons = [], []
        self.pressed = {}
