"""The sensor base class: every sensor does the same three things (read its parameters, run
on its sim-time schedule, perturb a measurement and publish it), and differs only in its
measurement. The model is hector_gazebo_plugins' SensorModel + UpdateTimer.

A sensor declares::

    @register('libgazebo_ros_magnetic.so', 'libhector_gazebo_ros_magnetic.so')
    class Magnetometer(Sensor):
        PARAMS = [Param('magnitude', float, None, unit='T', check='>=0')]
        DEFAULT_TOPIC = 'magnetic'
        DEFAULT_RATE = 50.0
        ERRORS = {'': dict(dims=3, gaussian_noise=1e-7)}
        def setup(self):                         # outputs: the main one and any others
            self.output('main', MagneticField)
        def measure(self, state, dt):            # link state + environment -> value
            return self.errors[''].apply(self.to_frame(self.env.magnetic_field_world(), state))
        def to_msg(self, value, stamp): ...      # the main message; or ``messages`` for all

The base class reads the common parameters (body, topic, frame, namespace, rate, period,
offset) and the sensor's rows in one place (``sim_world.plugins.params``), builds one
``ErrorModel`` per channel from hector's names (with the channel prefix) or SDF ``<noise>``,
gives the sensor a generator derived from the world's seed and its model and plugin names,
and owns the whole update. On every tick of its ``UpdateTimer``:

1. ``tick(sim_time, dt)`` (state that moves whoever listens: a microphone's track) and
   every error model steps (the draws of a sensor never depend on who subscribes, so the
   same seed gives the same data whether or not anybody listened before);
2. while anybody subscribes to one of its outputs (always in unit tests without ROS, or
   when ``force`` is set, or every tick with ``ALWAYS_MEASURE`` for sensors whose state
   depends on their history: battery charge, GPS time to first fix) it measures
   (``measure(state, dt)`` -> value, None: nothing this tick) and hands the messages of the
   tick (``messages(value, stamp)`` -> {output key: message | [messages] | callable
   building one}; default: the main output's ``to_msg``) to the gate;
3. the gate (``emit``; event sensors call it themselves for events between ticks) applies
   subscriber gating and the fault to every output alike (``set_fault``): ``drop``
   publishes nothing; ``freeze`` repeats the messages each sampled output published in its
   last tick before the fault (new stamps) and stops event outputs; ``noise`` multiplies every error model's sigma; the sensor's
   own faults (``FAULTS_OWN`` + ``on_fault``) act in its measurement. A fault the sensor
   cannot apply (no outputs, no noise) is refused with a ValueError saying why.

A measurement may arrive later, in another thread: ``measure`` returns a ``Pending``
(the camera's frame, rendered in the renderer's worker thread while the world steps on);
the base publishes its messages when it is resolved, through the same gate, stamped and
timed at the tick it was measured for.

Rate: ``updateRate``/``updatePeriod``/``updateOffset`` of the plugin; a plugin inside a
``<sensor>`` element that also gives a rate (``<update_rate>``, the 2011
``<updateRate>``) runs at the slowest positive one of the two, as Gazebo's sensor plugins
do (the sensor updates at its rate, the plugin publishes at most at its own: the thesis's
camera, sensor 30 Hz, controller 100 Hz, runs at 30 Hz).

No sensor overrides ``update``. Actuators (force, LED, vibration, projector, speaker,
thermal display) are ``sim_world.plugins.device.Actuator``: no error models, no faults.
"""
import copy
import hashlib
import threading

import numpy as np

from .device import BASE_PARAMS, DEVICE_FRAME, Device, Output, SensorState, content
from .error_models import error_model_from, error_params
from .params import ParamError, bad_value, convert, find_texts

__all__ = ['Sensor', 'SensorState', 'Output', 'BASE_PARAMS', 'DEVICE_FRAME', 'FAULTS',
           'Pending', 'stable_seed', 'content', 'inject_fault']

#: faults every sensor understands; sensors add their own through ``FAULTS_OWN`` + ``on_fault``
FAULTS = ('none', 'drop', 'freeze', 'noise')


def stable_seed(*keys):
    """Integers from text keys, the same in every process (Python's hash() is salted)."""
    h = hashlib.sha256('\0'.join(str(k) for k in keys).encode()).digest()
    return [int.from_bytes(h[i:i + 4], 'little') for i in range(0, 16, 4)]


class Sensor(Device):
    #: channel prefix -> dict(dims=..., error model defaults..., sdf=(paths of <noise>),
    #: aliases={field: (names,)})
    ERRORS = {}
    #: measure on every tick, subscribed or not (state that depends on history)
    ALWAYS_MEASURE = False
    #: the sensor's own faults (applied in its measurement through ``on_fault``)
    FAULTS_OWN = ()

    def __init__(self, spec, model, world):
        Device.__init__(self, spec, model, world)
        self.errors = {}
        self.fault = 'none'
        self.fault_value = 0.0
        self.noise_scale = 1.0

    # -- declaration -------------------------------------------------------------------------
    @classmethod
    def base_rows(cls):
        rows = list(BASE_PARAMS)
        for prefix, d in cls.ERRORS.items():
            d = dict(d)
            dims = d.pop('dims', 1)
            d.pop('sdf', None)
            aliases = d.pop('aliases', None)
            rows.extend(error_params(prefix, dims, d, aliases))
        return rows

    def load_more(self):
        p = self.p
        self.timer.rate = self.read_rate()
        for prefix, d in self.ERRORS.items():
            d = dict(d)
            try:
                self.errors[prefix] = error_model_from(
                    p, prefix, d.get('dims', 1), rng=self.rng, spec=self.spec,
                    sdf_paths=d.get('sdf', ()), defaults=d)
            except (ParamError, ValueError) as e:     # what is wrong with the SDF <noise>
                self.log_error('%s: <noise> of channel %r: %s; no noise on it'
                               % (self.label, prefix or 'value', e))
                self.errors[prefix] = error_model_from(
                    _Defaults(self.param_rows()), prefix, d.get('dims', 1), rng=self.rng,
                    defaults=d)

    def read_rate(self):
        """Hz of the timer: ``updatePeriod`` if given, else the slowest positive
        ``updateRate`` given on the plugin and on its ``<sensor>`` element (0: every step
        when only zeros are given), else DEFAULT_RATE. A bad value beyond the first (which
        parse_params reported) is one error line too."""
        p = self.p
        if p.updatePeriod:
            return 1.0 / p.updatePeriod
        row = next(r for r in self.param_rows() if r.name == 'updateRate')
        rates = [p.updateRate] if 'updateRate' in p.given else []
        for text in find_texts(self.spec, row)[1:]:
            try:
                rates.append(convert(row, text))
            except ParamError as e:
                self.world.log.error('%s', bad_value(self.label, row, e, text))
        if not rates:
            return p.updateRate if p.updateRate is not None else self.DEFAULT_RATE
        positive = [r for r in rates if r > 0]
        return min(positive) if positive else 0.0

    # -- the update: owned here ------------------------------------------------------------------
    def update(self, sim_time):
        dt = self.timer.last_dt
        self.tick(sim_time, dt)
        for e in self.errors.values():
            e.step(dt)
        if not (self.ALWAYS_MEASURE or self.subscribed()):
            return
        value = self.measure(self.state(sim_time), dt)
        if value is None:
            return
        stamp = self.stamp()
        if isinstance(value, Pending):   # arrives later (another thread): same gate
            value.then(lambda v: self._publish(v, stamp, sim_time))
            return
        self._publish(value, stamp, sim_time)

    def _publish(self, value, stamp, now):
        """The messages of the tick at sim time ``now`` through the gate."""
        if value is None:
            return
        self.last_value = value
        if self.ALWAYS_MEASURE and not self._any_wanted():
            return                       # measured for its history; nobody to tell
        msgs = self.messages(value, stamp)
        for key, m in (msgs.items() if isinstance(msgs, dict) else msgs):
            if callable(m):              # built only when it can pass the gate
                if self.fault == 'drop' or not (self.force or self.outputs[key].wanted()):
                    continue
                m = m()
            for one in (m if isinstance(m, list) else (m,)):
                self.emit(key, one, now)

    def _any_wanted(self):
        return self.force or any(o.wanted() for o in self.pubs)

    def tick(self, sim_time, dt):
        """Called on every tick before the error models step and whoever listens."""

    def measure(self, state, dt):
        raise NotImplementedError

    def messages(self, value, stamp):
        """{output key: message, [messages] or a callable building one} of one tick."""
        if self.pub is None:
            return {}
        return {'main': lambda: self.to_msg(value, stamp)}

    def to_msg(self, value, stamp):
        raise NotImplementedError

    def emit(self, key, msg, now=None):
        """The gate: faults first (drop: nothing; freeze: the messages the output published
        in its last tick before the fault, again, in order, with new stamps; nothing for
        events), then subscribers and on-change (Device.emit). ``now``: the sim time of the
        tick the message belongs to (default: the world's)."""
        out = self.outputs[key]
        if msg is None or self.fault == 'drop':
            return False
        if now is None:
            now = self.world.sim_time
        if self.fault == 'freeze':
            if out.event:
                return False
            if out.held:
                t, i = out.held_i
                i = i if t == now else 0
                if i >= len(out.held):
                    return False          # more messages this tick than the frozen tick had
                out.held_i = (now, i + 1)
                msg = _restamped(out.held[i], msg() if callable(msg) else msg)
        sent = Device.emit(self, key, msg, now)
        if sent and self.fault == 'freeze' and not out.held:
            out.held = out.batch          # nothing before the fault: the first tick after
        return sent

    # -- faults ------------------------------------------------------------------------------------
    def has_noise(self):
        """Anything a ``noise`` fault can scale (an error model with a sigma > 0)."""
        return any(np.any(e.gaussian_noise > 0) for e in self.errors.values())

    def set_fault(self, fault, value=0.0):
        """Inject a fault: 'none' (clear), 'drop' (publish nothing), 'freeze' (repeat every
        output's last message), 'noise' (multiply every noise sigma by value), or one of the
        sensor's own (``FAULTS_OWN``). Raises ValueError naming what is wrong, or why this
        sensor cannot apply it."""
        name = type(self).__name__
        known = FAULTS + tuple(self.FAULTS_OWN)
        if fault not in known:
            raise ValueError('fault %r is not known to %s (known: %s)'
                             % (fault, name, ', '.join(known)))
        if fault != 'none' and not self.outputs:
            raise ValueError('fault %r: %s of model %s publishes no topic (its data reaches '
                             'a receiver\'s plugin: set the fault there)'
                             % (fault, name, self.model.name))
        if fault == 'noise':
            if not (value >= 0):
                raise ValueError('noise fault needs a multiplier >= 0, got %r' % value)
            if not self.has_noise():
                raise ValueError('fault \'noise\': %s of model %s has no noise to scale (no '
                                 'error model with a sigma > 0)' % (name, self.model.name))
        if fault in self.FAULTS_OWN:
            self.on_fault(fault, value)
        elif self.fault in self.FAULTS_OWN:
            self.on_fault('none', 0.0)
        self.fault, self.fault_value = fault, value
        self.noise_scale = value if fault == 'noise' else 1.0
        for e in self.errors.values():
            e.noise_scale = self.noise_scale
        for o in self.pubs:
            o.held = list(o.batch) if fault == 'freeze' else None
            o.held_i = (None, 0)

    def on_fault(self, fault, value):
        """A sensor's own fault set (or 'none': cleared); read ``self.fault`` in measure."""

    def reset(self):
        Device.reset(self)
        for e in self.errors.values():
            e.reset()


class Pending(object):
    """A measurement that arrives later, from another thread (``resolve(value)``); the
    base's ``then(fn)`` runs ``fn(value)`` once it is there (at once if it already is), in
    the thread that resolves it, or in the caller's."""
    __slots__ = ('_lock', '_fn', '_value', '_done')

    def __init__(self):
        self._lock = threading.Lock()
        self._fn = None
        self._value = None
        self._done = False

    def resolve(self, value):
        with self._lock:
            self._value, self._done = value, True
            fn = self._fn
        if fn is not None:
            fn(value)

    def then(self, fn):
        with self._lock:
            self._fn = fn
            done, value = self._done, self._value
        if done:
            fn(value)


def inject_fault(plugins, fault, value=0.0):
    """Set ``fault`` on the sensors among ``plugins`` (those a /gazebo/set_sensor_fault call
    names: a topic name may match an output device's too, e.g. ``temperature``); ValueError
    saying why not when none is a sensor (an output device, a camera, a video texture) or a
    sensor refuses it. Nothing is set unless every sensor takes it."""
    sensors = [p for p in plugins if isinstance(p, Sensor)]
    if not sensors:
        raise ValueError('%s: not a sensor of the sensor layer (%s): faults apply to sensors'
                         % (', '.join(p.label for p in plugins),
                            ', '.join(type(p).__name__ for p in plugins)))
    done = []
    try:
        for p in sensors:
            old = (p.fault, p.fault_value)
            p.set_fault(fault, value)
            done.append((p, old))
    except ValueError:
        for p, old in done:
            p.set_fault(*old)
        raise


def _restamped(held, new):
    """A copy of the held message with the new message's stamp."""
    m = copy.deepcopy(held)
    h = getattr(m, 'header', None)
    nh = getattr(new, 'header', None)
    if h is not None and nh is not None:
        h.stamp = nh.stamp
    return m


class _Defaults(object):
    """ParamValues-like view of the rows' defaults."""

    def __init__(self, rows):
        self._d = {r.name: r.default for r in rows}
        self.given = set()

    def __getitem__(self, k):
        return self._d[k]

    def __contains__(self, k):
        return k in self._d
