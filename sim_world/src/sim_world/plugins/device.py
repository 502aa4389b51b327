"""What every sensor and actuator of a model shares: the common parameters (body, topic,
frame, namespace, rate), the outputs (declared topics), the ROS wiring (subscribers,
services), one error line per distinct text, and the power bus.

``Device`` is the base of ``sim_world.plugins.sensor.Sensor`` (measures, publishes through
the fault gate) and of ``Actuator`` here (takes commands, acts on the world, publishes its
state without error models or faults).

An output is declared once, in ``setup``::

    self.pub = self.output('main', Imu)                         # the main topic (topicName)
    self.alt_pub = self.output('altitude', Float64, topic=self.p.altitudeTopicName)

and everything published goes through ``emit(key, msg)``, the one gate: it publishes only
while somebody subscribes (a latched output always; without ROS always), and an output
declared ``on_change`` (with ``repeat`` s) publishes only when the message's content (all
but its header) differs from the last one it published, or ``repeat`` s of sim time later.
"""
import threading
import weakref

import numpy as np

from ..logonce import LogOnce
from . import Plugin, PluginError
from .params import Param

__all__ = ['Device', 'Actuator', 'Output', 'BASE_PARAMS', 'DEVICE_FRAME', 'SensorState',
           'content']


#: Android's device frame (x right, y up along the long edge, z out of the screen)
DEVICE_FRAME = 'mobile_device_frame'

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


class SensorState(object):
    """What a measurement reads: sim time, the world pose of the report frame, the body's
    world pose and world-frame velocities (None for a device that reads no pose)."""
    __slots__ = ('t', 'pose', 'body_pose', 'lin', 'ang')

    def __init__(self, t, pose=None, body_pose=None, lin=None, ang=None):
        self.t, self.pose, self.body_pose, self.lin, self.ang = t, pose, body_pose, lin, ang


def content(msg):
    """A message's data without its header (what ``on_change`` and tests compare)."""
    slots = getattr(msg, '__slots__', None)
    if not slots:
        return msg
    return tuple(_plain(getattr(msg, s)) for s in slots if s != 'header')


def _plain(v):
    if hasattr(v, '__slots__') and hasattr(v, '_type'):
        return content(v)
    if isinstance(v, (list, tuple)):
        return tuple(_plain(x) for x in v)
    return v


class Output(object):
    """One declared topic of a device: the rospy publisher (None without ROS), the last
    message and the count (unit tests read ``last`` and ``count`` without a roscore).

    ``noisy``: the messages carry a value with an error model (a ``noise`` fault changes
    them); ``event``: messages are events (touch, buttons, notifications), not samples (a
    ``freeze`` fault stops them instead of repeating the last one); ``on_change``/``repeat``:
    see the module doc."""

    def __init__(self, key, topic, msg_type, ros_pub=None, latch=False, noisy=True,
                 event=False, on_change=False, repeat=0.0):
        self.key, self.topic, self.type, self.ros = key, topic, msg_type, ros_pub
        self.latch, self.noisy, self.event = latch, noisy, event
        self.on_change, self.repeat = on_change, float(repeat)
        self.last = None
        self.count = 0
        self.batch, self.batch_t = [], None   # the messages published at sim time batch_t
        self.held = None              # freeze: the batch repeated (a sensor's fault)
        self.held_i = (None, 0)       # (sim time, index into held) while repeating
        self.sent = None              # on_change: (content, sim time) last published

    def wanted(self):
        return self.ros is None or self.latch or self.ros.get_num_connections() > 0

    def publish(self, msg):
        self.last = msg
        self.count += 1
        if self.ros is not None:
            self.ros.publish(msg)

    def changed(self, msg, now):
        """on_change outputs: True when ``msg`` is new or its repeat period has passed."""
        if not self.on_change:
            return True
        c = content(msg)
        s = self.sent
        if s is not None and s[0] == c and not (self.repeat > 0 and
                                                now - s[1] >= self.repeat - 1e-9):
            return False
        self.sent = (c, now)
        return True

    def note(self, msg, now):
        """Remember ``msg`` as published at sim time ``now`` (the batch of one tick)."""
        if now != self.batch_t:
            self.batch, self.batch_t = [], now
        self.batch.append(msg)

    def reset(self):
        self.held = None
        if not self.latch:            # a latched message stays what late subscribers get
            self.sent = None
        self.batch, self.batch_t = [], None

    def unregister(self):
        if self.ros is not None:
            self.ros.unregister()
            self.ros = None


class Device(Plugin):
    """Common parameters, outputs, ROS wiring, error lines and power of sensors and
    actuators."""
    PARAMS = []
    DEFAULT_TOPIC = None
    DEFAULT_RATE = 10.0
    #: the measurement reads the body's pose and velocities (False: sim time only)
    USES_POSE = True
    #: publisher queue: at real_time_factor 0 the world publishes bursts faster than a
    #: subscriber (a recorder) reads; 100 keeps a 100 Hz topic lossless over the testing
    #: instance's 0.25 s lockstep slices (10 dropped messages at real-time factor 5)
    QUEUE_SIZE = 100
    p = None                      # the parsed parameters (load)

    def __init__(self, spec, model, world):
        Plugin.__init__(self, spec, model, world)
        self.force = False
        self.outputs = {}
        self.pubs = []
        self.subs = []
        self.srvs = []
        self.pub = None
        self.last_value = None
        self.last_msg = None
        self.once = LogOnce(world.log)

    # -- declaration -------------------------------------------------------------------------
    @classmethod
    def base_rows(cls):
        return list(BASE_PARAMS)

    @classmethod
    def param_rows(cls):
        rows = [Param(r.name, r.type, cls.DEFAULT_RATE, r.aliases, r.unit, r.check, r.doc)
                if r.name == 'updateRate' else
                Param(r.name, r.type, cls.DEFAULT_TOPIC, r.aliases, r.unit, r.check, r.doc)
                if r.name == 'topicName' else r for r in cls.base_rows()]
        names = set()
        out = []
        for r in rows + list(cls.PARAMS):     # a device's own row replaces a base row
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
        self.frame_id = self.tf_frame(frame)
        frame_link = frame if frame in self.model.links else self.body
        poses = self.model.link_poses()
        self.frame_offset = poses[self.body].inverse() * poses[frame_link]
        self._frame_is_body = frame_link == self.body
        rate = p.updateRate if p.updateRate is not None else self.DEFAULT_RATE
        if p.updatePeriod:
            rate = 1.0 / p.updatePeriod
        self.timer.rate = rate
        self.timer.offset = p.updateOffset
        self.timer.reset(self.world.sim_time)
        self.rng = self.world.rng(self.model.name, self.spec.name or self.spec.filename)
        self.load_more()
        topic = p.topicName if 'topicName' in p else None   # (the camera names its own)
        self.topic = self.resolve(topic or self.DEFAULT_TOPIC or self.spec.name)
        self.setup()
        if self.ros:
            import rospy
            rospy.loginfo('%s %s: %s at %g Hz of sim time, frame %s',
                          type(self).__name__, self.model.name, self.topic, self.timer.rate,
                          self.frame_id)

    def load_more(self):
        """The base class's own part of loading (error models), before ``setup``."""

    def setup(self):
        """Outputs, subscribers, services (after parameters are read)."""

    @property
    def namespace(self):
        ns = self.p.robotNamespace if self.p is not None else None
        if ns is None:
            ns = self.model.robot_namespace
        return (ns or '').strip('/')

    @property
    def ros(self):
        return bool(self.world.ros_enabled)

    @property
    def env(self):
        return self.world.environment

    # -- outputs and ROS wiring --------------------------------------------------------------------
    def output(self, key, msg_type, topic=None, latch=False, noisy=True, event=False,
               on_change=False, repeat=0.0, queue_size=None):
        """Declare an output: ``key`` 'main' is the main topic (``topicName``); others
        publish on ``topic`` (relative names in the robot namespace; default ``key``);
        ``queue_size``: the publisher's (default QUEUE_SIZE; a camera's images: fewer).
        Returns the Output (also ``self.outputs[key]``; the main one is ``self.pub``)."""
        if topic is None:
            topic = self.topic if key == 'main' else self.resolve(key)
        else:
            topic = self.resolve(topic)
        ros_pub = None
        if self.ros:
            from sim_world import transport     # counted for the slice handshake
            ros_pub = transport.publisher(topic, msg_type, latch=latch,
                                          queue_size=queue_size or self.QUEUE_SIZE)
        out = Output(key, topic, msg_type, ros_pub, latch, noisy, event, on_change, repeat)
        self.outputs[key] = out
        self.pubs.append(out)
        if key == 'main':
            self.pub = out
        return out

    def emit(self, key, msg, now=None):
        """The gate every message of this device goes through (see the module doc); True
        when it was published. ``now``: sim time of the tick it belongs to (default the
        world's; a frame rendered in another thread is published later)."""
        out = self.outputs[key]
        if msg is None or not (self.force or out.wanted()):
            return False
        if callable(msg):
            msg = msg()
        if now is None:
            now = self.world.sim_time
        if not out.changed(msg, now):
            return False
        if key == 'main':
            self.last_msg = msg
        out.publish(msg)
        out.note(msg, now)
        return True

    def subscribe(self, rel_topic, msg_type, callback, queue_size=10):
        if not self.ros:
            return None
        from sim_world import transport
        sub = transport.subscriber(self.resolve(rel_topic), msg_type, callback,
                                   queue_size=queue_size)
        self.subs.append(sub)
        return sub

    def service(self, rel_name, srv_type, callback):
        if not self.ros:
            return None
        from sim_world import srvcheck, transport
        # a refusal (srvcheck.BadRequest) or a bug in the callback: success false and one
        # line in this plugin's log, never a traceback; the plugin keeps serving
        callback = srvcheck.answers(
            srv_type._response_class, rel_name,
            log=lambda text: self.log_error('%s: %s' % (self.label, text)))(callback)
        srv = transport.service(self.resolve(rel_name), srv_type, callback)
        self.srvs.append(srv)
        return srv

    def ros_names(self):
        """Its outputs' topics and its services (Plugin.ros_names)."""
        return {o.topic for o in self.pubs} | {s.resolved_name for s in self.srvs}

    def subscribed(self):
        """Anybody listening to any topic of this device (always True without ROS)."""
        if self.force or not self.ros:
            return True
        return any(p.ros is not None and p.ros.get_num_connections() > 0 for p in self.pubs)

    def log_error(self, text):
        """One error line per distinct text (a bad command repeated 100 times: one line)."""
        self.once.error(text)

    def log_info(self, text):
        self.world.log.info('%s', text)

    def power(self, component, watts):
        """Report a power draw (W) of this phone's ``component`` to the battery."""
        self.world.power.set_draw(self.model.name, component, watts)

    def power_flag(self, name, value):
        """Set a switch of this phone on the power bus (wifi on, display brightness ...)."""
        self.world.power.set_flag(self.model.name, name, value)

    def paint(self, draw):
        """``draw(renderer)`` if the world has a renderer (LEDs, the thermal display, the
        projector change what cameras see; without a camera there is nothing to draw).
        True when it drew."""
        r = self.world.renderer_if_created
        if r is None:
            return False
        draw(r)
        return True

    def paint_link(self, rgb):
        """Draw the body link unlit in ``rgb`` (0..1; None: its own material) in every
        camera (an LED, the thermal display); a link without a visual: nothing to draw.
        The colour the renderer already has is not drawn again: a change waits until the
        renderer has finished the frame it is drawing (Renderer.set_link_color), and the
        thermal display at a steady temperature painted the same colour at each of its
        ticks, holding the world's step for a frame ten times a sim second."""
        r = self.world.renderer_if_created
        if r is None:
            return
        key = None if rgb is None else tuple(float(v) for v in rgb)
        last = getattr(self, '_painted', None)
        if last is not None and last[0]() is r and last[1] == key:
            return
        try:
            r.set_link_color(self.model.name, self.body, rgb, lit=False)
        except KeyError:
            return
        self._painted = (weakref.ref(r), key)

    # -- state -------------------------------------------------------------------------------------
    def state(self, t=None):
        t = self.world.sim_time if t is None else t
        if not self.USES_POSE:
            return SensorState(t)
        body, lin, ang = self.world.pass_state('%s::%s' % (self.model.name, self.body))
        pose = body if self._frame_is_body else body * self.frame_offset
        return SensorState(t, pose, body, lin, ang)

    def to_frame(self, v_world, state):
        """A world-frame vector in the report frame."""
        return state.pose.inverse().rotate(np.asarray(v_world, float))

    def stamp(self):
        """The header stamp: sim time (rospy.Time; rospy imports without a roscore)."""
        return self.world.ros_now()

    def reset(self):
        Plugin.reset(self)
        for o in self.pubs:
            o.reset()
        self.last_value = None

    def shutdown(self):
        for s in self.subs:
            s.unregister()
        for s in self.srvs:
            s.shutdown()
        for p in self.pubs:
            p.unregister()
        self.subs, self.srvs = [], []


class Actuator(Device):
    """An output device (force, LED, vibration motor, projector, speaker, thermal display):
    commands arrive from any thread (``queue(item)``), are taken at the next tick of its
    timer and acted on in the world thread by ``act(sim_time, commands)``. No error models,
    no faults; its state topics go through ``emit`` like a sensor's (subscriber gating, on
    change)."""

    def __init__(self, spec, model, world):
        Device.__init__(self, spec, model, world)
        self._cmd_lock = threading.Lock()
        self._commands = []

    def queue(self, item):
        """Queue a command (any thread) for the next tick."""
        with self._cmd_lock:
            self._commands.append(item)

    def update(self, sim_time):
        with self._cmd_lock:
            commands, self._commands = self._commands, []
        self.act(sim_time, commands)

    def act(self, sim_time, commands):
        """Apply ``commands`` (queued since the last tick, oldest first) at ``sim_time``."""
        raise NotImplementedError

