"""The sensor base class: every sensor does the same three things (read its parameters, run
on its sim-time schedule, perturb a measurement and publish it), and differs only in its
measurement. The model is hector_gazebo_plugins' SensorModel + UpdateTimer.

A sensor declares::

    @register('libgazebo_ros_magnetic.so', 'libhector_gazebo_ros_magnetic.so')
    class Magnetometer(Sensor):
        PARAMS = [Param('magnitude', float, None, unit='T', check='>=0')]
        DEFAULT_TOPIC = 'magnetic'
        DEFAULT_RATE = 50.0
        MSG = MagneticField                      # the main publisher's type
        ERRORS = {'': dict(dims=3, gaussian_noise=1e-7)}
        def measure(self, state, dt):            # pure: link state + environment -> value
            return self.errors[''].apply(self.to_frame(self.env.magnetic_field_world(), state))
        def to_msg(self, value, stamp): ...      # the message; the base publishes it

The base class reads the common parameters (body, topic, frame, namespace, rate, period,
offset) and the sensor's rows in one place (``sim_world.plugins.params``), builds one
``ErrorModel`` per channel from hector's names (with the channel prefix) or SDF ``<noise>``,
gives the sensor a generator derived from the world's seed and its model and plugin names,
and on every tick of its ``UpdateTimer``:

1. steps every error model (the draws of a sensor never depend on who subscribes, so the
   same seed gives the same data whether or not anybody listened before);
2. measures and publishes while anybody subscribes to one of its topics (always in unit
   tests without ROS, or when ``force`` is set, or every tick with ``ALWAYS_MEASURE`` for
   sensors whose state depends on their history: battery charge, GPS time to first fix);
3. applies injected faults (``set_fault``: drop, freeze, noise multiplier, or the sensor's
   own ones through ``on_fault``).
"""
import hashlib
import logging

import numpy as np

from . import Plugin, PluginError
from .error_models import error_model_from, error_params
from .params import Param, ParamError

__all__ = ['Sensor', 'SensorState', 'Publisher', 'BASE_PARAMS', 'DEVICE_FRAME', 'FAULTS',
           'stable_seed']

log = logging.getLogger('sim_world.sensor')

#: Android's device frame (x right, y up along the long edge, z out of the screen)
DEVICE_FRAME = 'mobile_device_frame'

#: faults every sensor understands; sensors add their own through ``FAULTS`` + ``on_fault``
FAULTS = ('none', 'drop', 'freeze', 'noise')

BASE_PARAMS = [
    Param('bodyName', str, None, aliases=('body_name', 'bodyname'),
          doc='link the sensor is mounted on (default: the <gazebo reference> link or the '
              'model root)'),
    Param('topicName', str, None, aliases=('topic_name', 'topic'),
          doc='main topic, relative to robotNamespace'),
    Param('frameName', str, None, aliases=('frame_name', 'frameId', 'frame_id'),
          doc='frame_id of the messages (default mobile_device_frame where the model has it)'),
    Param('robotNamespace', str, None, aliases=('robot_namespace',)),
    Param('updateRate', float, None, aliases=('update_rate',), unit='Hz', check='>=0',
          doc='Hz of sim time (0: every world step)'),
    Param('updatePeriod', float, None, aliases=('update_period',), unit='s', check='>=0'),
    Param('updateOffset', float, 0.0, aliases=('update_offset',), unit='s', check='>=0'),
    Param('alwaysOn', bool, True, aliases=('always_on',)),
]


def stable_seed(*keys):
    """Integers from text keys, the same in every process (Python's hash() is salted)."""
    h = hashlib.sha256('\0'.join(str(k) for k in keys).encode()).digest()
    return [int.from_bytes(h[i:i + 4], 'little') for i in range(0, 16, 4)]


class SensorState(object):
    """What a measurement reads: sim time, the world pose of the report frame, the body's
    world pose and world-frame velocities."""
    __slots__ = ('t', 'pose', 'body_pose', 'lin', 'ang')

    def __init__(self, t, pose, body_pose, lin, ang):
        self.t, self.pose, self.body_pose, self.lin, self.ang = t, pose, body_pose, lin, ang


class Publisher(object):
    """A topic of a sensor: the rospy publisher (None without ROS) and the last message
    (unit tests read ``last`` and ``count`` without a roscore)."""

    def __init__(self, topic, msg_type, ros_pub=None):
        self.topic, self.type, self.ros = topic, msg_type, ros_pub
        self.last = None
        self.count = 0

    def wanted(self):
        return self.ros is None or self.ros.get_num_connections() > 0

    def publish(self, msg):
        self.last = msg
        self.count += 1
        if self.ros is not None:
            self.ros.publish(msg)

    def unregister(self):
        if self.ros is not None:
            self.ros.unregister()
            self.ros = None


class Sensor(Plugin):
    PARAMS = []
    DEFAULT_TOPIC = None
    DEFAULT_RATE = 10.0
    MSG = None
    #: channel prefix -> dict(dims=..., error model defaults..., sdf=(paths of <noise>),
    #: aliases={field: (names,)})
    ERRORS = {}
    #: measure on every tick, subscribed or not (state that depends on history)
    ALWAYS_MEASURE = False
    #: publish the main message on every tick (False: the sensor publishes itself)
    PUBLISH_EVERY_TICK = True
    #: publisher queue: at real_time_factor 0 the world publishes bursts faster than a
    #: subscriber (a recorder) reads; 100 keeps a 100 Hz topic lossless over the testing
    #: instance's 0.25 s lockstep slices (10 dropped messages at real-time factor 5)
    QUEUE_SIZE = 100
    LATCH = False

    def __init__(self, spec, model, world):
        Plugin.__init__(self, spec, model, world)
        self.force = False
        self.pubs = []
        self.subs = []
        self.srvs = []
        self.pub = None
        self.errors = {}
        self.last_value = None
        self.last_msg = None
        self.fault = 'none'
        self.fault_value = 0.0
        self._logged = set()

    # -- declaration -------------------------------------------------------------------------
    @classmethod
    def param_rows(cls):
        rows = list(BASE_PARAMS)
        for prefix, d in cls.ERRORS.items():
            d = dict(d)
            dims = d.pop('dims', 1)
            d.pop('sdf', None)
            aliases = d.pop('aliases', None)
            rows.extend(error_params(prefix, dims, d, aliases))
        rows = [Param(r.name, r.type, cls.DEFAULT_RATE, r.aliases, r.unit, r.check, r.doc)
                if r.name == 'updateRate' else
                Param(r.name, r.type, cls.DEFAULT_TOPIC, r.aliases, r.unit, r.check, r.doc)
                if r.name == 'topicName' else r for r in rows]
        names = set()
        out = []
        for r in rows + list(cls.PARAMS):     # a sensor's own row replaces a base row
            if r.name in names:
                out = [x for x in out if x.name != r.name]
            names.add(r.name)
            out.append(r)
        return out

    # -- lifecycle -----------------------------------------------------------------------------
    def load(self):
        self.p = self.parse(self.param_rows())
        p = self.p
        self.body = p.bodyName or self.spec.link or self.model.root_link
        if self.body not in self.model.links:
            raise PluginError('%s: bodyName %r is not a link of the model'
                              % (self.label, self.body))
        frame = p.frameName
        if frame is None:
            frame = DEVICE_FRAME if DEVICE_FRAME in self.model.links else self.body
        self.frame_id = frame
        frame_link = frame if frame in self.model.links else self.body
        poses = self.model.link_poses()
        self.frame_offset = poses[self.body].inverse() * poses[frame_link]
        self._frame_is_body = frame_link == self.body
        rate = p.updateRate if p.updateRate is not None else self.DEFAULT_RATE
        if p.updatePeriod:
            rate = 1.0 / p.updatePeriod
        self.timer.rate = rate
        self.timer.offset = p.updateOffset
        self.timer.reset(getattr(self.world, 'sim_time', 0.0))
        self.rng = self.world.rng(self.model.name, self.spec.name or self.spec.filename) \
            if hasattr(self.world, 'rng') else np.random.default_rng(stable_seed(
                self.model.name, self.spec.filename))
        for prefix, d in self.ERRORS.items():
            d = dict(d)
            try:
                self.errors[prefix] = error_model_from(
                    p, prefix, d.get('dims', 1), rng=self.rng, spec=self.spec,
                    sdf_paths=d.get('sdf', ()), defaults=d)
            except (ParamError, ValueError) as e:
                self.log_error('%s: <noise> of channel %r must be %s; no noise on it'
                               % (self.label, prefix or 'value', e))
                self.errors[prefix] = error_model_from(
                    _Defaults(self.param_rows()), prefix, d.get('dims', 1), rng=self.rng,
                    defaults=d)
        self.topic = self.resolve(p.topicName or self.DEFAULT_TOPIC or self.spec.name)
        if self.MSG is not None:
            self.pub = self._make_pub(self.topic, self.MSG, self.LATCH)
        self.setup()
        if self.ros:
            import rospy
            rospy.loginfo('%s %s: %s at %g Hz of sim time, frame %s',
                          type(self).__name__, self.model.name, self.topic, self.timer.rate,
                          self.frame_id)

    def setup(self):
        """More publishers, subscribers, services (after parameters are read)."""

    @property
    def namespace(self):
        ns = self.p.robotNamespace if hasattr(self, 'p') else None
        if ns is None:
            ns = self.model.robot_namespace
        return (ns or '').strip('/')

    @property
    def ros(self):
        return bool(getattr(self.world, 'ros_enabled', False))

    @property
    def env(self):
        return self.world.environment

    # -- ROS wiring ------------------------------------------------------------------------------
    def _make_pub(self, topic, msg_type, latch=False):
        ros_pub = None
        if self.ros:
            import rospy
            ros_pub = rospy.Publisher(topic, msg_type, queue_size=self.QUEUE_SIZE, latch=latch)
        pub = Publisher(topic, msg_type, ros_pub)
        self.pubs.append(pub)
        return pub

    def advertise(self, rel_topic, msg_type, latch=False):
        """A further topic (relative names in the robot namespace)."""
        return self._make_pub(self.resolve(rel_topic), msg_type, latch)

    def subscribe(self, rel_topic, msg_type, callback, queue_size=10):
        if not self.ros:
            return None
        import rospy
        sub = rospy.Subscriber(self.resolve(rel_topic), msg_type, callback,
                               queue_size=queue_size)
        self.subs.append(sub)
        return sub

    def service(self, rel_name, srv_type, callback):
        if not self.ros:
            return None
        import rospy
        srv = rospy.Service(self.resolve(rel_name), srv_type, callback)
        self.srvs.append(srv)
        return srv

    def log_error(self, text):
        """One error line per distinct text (a bad command repeated 100 times: one line)."""
        if text in self._logged:
            return
        self._logged.add(text)
        logger = getattr(self.world, 'log', None) or log
        logger.error('%s', text)

    def log_info(self, text):
        logger = getattr(self.world, 'log', None) or log
        logger.info('%s', text)

    def power(self, component, watts):
        """Report a power draw (W) of this phone's ``component`` to the battery."""
        bus = getattr(self.world, 'power', None)
        if bus is not None:
            bus.set_draw(self.model.name, component, watts)

    def subscribed(self):
        """Anybody listening to any topic of this sensor (always True without ROS)."""
        if self.force or not self.ros:
            return True
        return any(p.ros is not None and p.ros.get_num_connections() > 0 for p in self.pubs)

    # -- measurement -----------------------------------------------------------------------------
    def state(self, t=None):
        t = self.world.sim_time if t is None else t
        entity = '%s::%s' % (self.model.name, self.body)
        cache = getattr(self.world, 'pass_states', None)    # one plugin pass of the world
        got = cache.get(entity) if cache is not None else None
        if got is None:
            got = self.world.entity_state(entity)
            if cache is not None:
                cache[entity] = got
        body, lin, ang = got
        pose = body if self._frame_is_body else body * self.frame_offset
        return SensorState(t, pose, body, lin, ang)

    def to_frame(self, v_world, state):
        """A world-frame vector in the report frame."""
        return state.pose.inverse().rotate(np.asarray(v_world, float))

    def measure(self, state, dt):
        raise NotImplementedError

    def to_msg(self, value, stamp):
        raise NotImplementedError

    def stamp(self):
        """The header stamp: sim time (rospy.Time; rospy imports without a roscore)."""
        return self.world.ros_now()

    def update(self, sim_time):
        dt = self.timer.last_dt
        for e in self.errors.values():
            e.step(dt)
        if not (self.ALWAYS_MEASURE or self.subscribed()):
            return
        if self.fault == 'drop':
            if self.ALWAYS_MEASURE:
                self.measure(self.state(sim_time), dt)
            return
        if self.fault == 'freeze' and self.last_value is not None:
            value = self.last_value
            if self.ALWAYS_MEASURE:
                self.measure(self.state(sim_time), dt)
        else:
            value = self.measure(self.state(sim_time), dt)
            self.last_value = value
        if value is None or not self.PUBLISH_EVERY_TICK or self.pub is None:
            return
        if not self.pub.wanted() and not self.force:
            return
        msg = self.to_msg(value, self.stamp())
        self.last_msg = msg
        self.pub.publish(msg)

    # -- faults ------------------------------------------------------------------------------------
    def set_fault(self, fault, value=0.0):
        """Inject a fault: 'none' (clear), 'drop' (stop publishing), 'freeze' (keep
        publishing the last value), 'noise' (multiply every noise sigma by value), or one of
        the sensor's own (``on_fault``). Raises ValueError naming what is wrong."""
        if fault not in FAULTS:
            if not self.on_fault(fault, value):
                raise ValueError('fault %r is not known to %s (known: %s)'
                                 % (fault, type(self).__name__,
                                    ', '.join(FAULTS + tuple(self.extra_faults()))))
            self.fault = fault
            self.fault_value = value
            return
        if fault == 'noise' and not (value >= 0):
            raise ValueError('noise fault needs a multiplier >= 0, got %r' % value)
        if self.fault not in FAULTS:
            self.on_fault('none', 0.0)
        self.fault, self.fault_value = fault, value
        for e in self.errors.values():
            e.noise_scale = value if fault == 'noise' else 1.0

    def extra_faults(self):
        return ()

    def on_fault(self, fault, value):
        """Sensor-specific faults; return True when ``fault`` is one of them."""
        return False

    def reset(self):
        Plugin.reset(self)
        for e in self.errors.values():
            e.reset()
        self.last_value = None

    def shutdown(self):
        for s in self.subs:
            s.unregister()
        for s in self.srvs:
            s.shutdown()
        for p in self.pubs:
            p.unregister()
        self.subs, self.srvs = [], []


class _Defaults(object):
    """ParamValues-like view of the rows' defaults."""

    def __init__(self, rows):
        self._d = {r.name: r.default for r in rows}
        self.given = set()

    def __getitem__(self, k):
        return self._d[k]

    def __contains__(self, k):
        return k in self._d
