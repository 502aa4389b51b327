"""A controller manager in the manner of ros_control's (issue 48 part 4), pure Python: no ROS,
no world. It holds controllers loaded from ros_controllers-style parameters and updates the
running ones every physics step, in sim time, against a hardware interface (``RobotHW``:
``interfaces`` {joint: set of 'position'/'velocity'/'effort'}, ``state(joint)`` -> (position,
velocity, effort), ``command(joint, kind, value)``, ``limits(joint)`` -> (lower, upper,
effort); ``sim_world.control.robot_hw.RobotHWSim`` is the simulator's).

Parameters of a controller (the dict under ``<ctrl>`` on the parameter server):

- ``type``: ``joint_state_controller/JointStateController`` (``publish_rate`` Hz, required),
  ``position_controllers/JointPositionController`` (PositionJointInterface, forwards the
  command), ``velocity_controllers/JointVelocityController`` (VelocityJointInterface),
  ``effort_controllers/JointEffortController`` (EffortJointInterface),
  ``effort_controllers/JointPositionController`` (EffortJointInterface, ``pid: {p, i, d,
  i_clamp}``; ``i_clamp_min``/``i_clamp_max`` also read), ``effort_controllers/
  JointVelocityController`` (EffortJointInterface, PID on the velocity error);
- ``joint`` (one joint) or ``joints`` (a list; JointStateController: every joint when absent).

A wrong or missing parameter is one ``ControllerError`` naming it (``<ctrl>/pid/p``...);
the manager logs it as one line and the running controllers keep running.
"""
import logging
import math

__all__ = ['ControllerError', 'Pid', 'ControllerManager', 'CONTROLLER_TYPES', 'controller_types']


class ControllerError(Exception):
    """A controller's parameters, or a switch, refused: the message names what was wrong."""


def _num(params, key, where, default=None, check=None, why=''):
    v = params.get(key, default) if isinstance(params, dict) else default
    if v is None:
        raise ControllerError('%s/%s is missing' % (where, key))
    if isinstance(v, bool):
        raise ControllerError('%s/%s must be a number, got %r' % (where, key, v))
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ControllerError('%s/%s must be a number, got %r' % (where, key, v))
    if not math.isfinite(f) or (check is not None and not check(f)):
        raise ControllerError('%s/%s %s, got %r' % (where, key, why or 'must be finite', v))
    return f


class Pid(object):
    """control_toolbox::Pid: command = p e + clamp(i integral(e), i_clamp) + d e_dot."""

    def __init__(self, p, i=0.0, d=0.0, i_clamp_min=0.0, i_clamp_max=0.0):
        self.p, self.i, self.d = p, i, d
        self.i_clamp_min, self.i_clamp_max = i_clamp_min, i_clamp_max
        self.reset()

    @classmethod
    def from_params(cls, params, where):
        if not isinstance(params, dict):
            raise ControllerError('%s is missing (a dict with p, i, d, i_clamp)' % where)
        p = _num(params, 'p', where)
        i = _num(params, 'i', where, 0.0)
        d = _num(params, 'd', where, 0.0)
        ic = _num(params, 'i_clamp', where, 0.0, lambda x: x >= 0, 'must be >= 0')
        lo = _num(params, 'i_clamp_min', where, -ic)
        hi = _num(params, 'i_clamp_max', where, ic)
        if lo > hi:
            raise ControllerError('%s/i_clamp_min %g is above i_clamp_max %g' % (where, lo, hi))
        return cls(p, i, d, lo, hi)

    def reset(self):
        self.i_term = 0.0

    def compute(self, error, error_dot, dt):
        if dt <= 0 or not (math.isfinite(error) and math.isfinite(error_dot)):
            return 0.0
        self.i_term = min(self.i_clamp_max, max(self.i_clamp_min,
                                                self.i_term + self.i * error * dt))
        return self.p * error + self.i_term + self.d * error_dot


def _angle_diff(a, b):
    """Shortest angle from b to a (angles::shortest_angular_distance(b, a))."""
    return math.atan2(math.sin(a - b), math.cos(a - b))


class Controller(object):
    TYPE = ''
    INTERFACE = None          # the joint interface it claims (None: reads only)
    GROUP = False             # its command is a Float64MultiArray (one value per joint)
    MULTI = False             # it takes ``joints`` (a list), not ``joint``
    #: controller_manager's state: 'initialized' (loaded), 'running', 'stopped'
    state = 'initialized'

    def __init__(self, name, params, hw):
        self.name = name
        self.hw = hw
        self.running = False
        where = name
        if self.MULTI:
            self.joints = self.joints_param(params)
        elif self.INTERFACE is not None:
            joint = params.get('joint')
            if joint is None or not isinstance(joint, str) or not joint:
                raise ControllerError('%s/joint is missing (the joint to control)' % where)
            self.check_joint(joint, '%s/joint' % where)
            self.joints = [joint]
        self.load(params)

    def check_joint(self, joint, where):
        have = self.hw.interfaces
        if joint not in have:
            raise ControllerError('%s: %r has no transmission (joints with one: %s)'
                                  % (where, joint, ', '.join(sorted(have)) or 'none'))
        if self.INTERFACE not in have[joint]:
            raise ControllerError('%s: joint %r has no %s interface (it has: %s)'
                                  % (where, joint, _IFACE_NAMES[self.INTERFACE],
                                     ', '.join(_IFACE_NAMES[k] for k in sorted(have[joint]))))

    def joints_param(self, params):
        """``joints``: a non-empty list of distinct joints with this controller's interface."""
        joints = params.get('joints')
        if not isinstance(joints, (list, tuple)) or not joints or \
                not all(isinstance(j, str) and j for j in joints):
            raise ControllerError('%s/joints is missing (a list of joint names)' % self.name)
        if len(set(joints)) != len(joints):
            raise ControllerError('%s/joints names a joint twice: %s' % (self.name, list(joints)))
        for j in joints:
            self.check_joint(j, '%s/joints' % self.name)
        return list(joints)

    @property
    def joint(self):
        return self.joints[0]

    def load(self, params):
        pass

    def starting(self, t):
        pass

    def update(self, t, dt):
        pass

    def stopping(self):
        pass

    def claimed(self):
        return list(self.joints) if self.INTERFACE is not None else []

    def read_states(self):
        """[hw.state(joint)] of this controller's joints: one read of them all when the
        hardware has ``states`` (RobotHWSim: one physics call)."""
        many = getattr(self.hw, 'states', None)
        if many is not None:
            return many(self.joints)
        return [self.hw.state(j) for j in self.joints]


class JointStateController(Controller):
    TYPE = 'joint_state_controller/JointStateController'

    def load(self, params):
        self.publish_rate = _num(params, 'publish_rate', self.name, None, lambda x: x > 0,
                                 'must be > 0 Hz')
        joints = params.get('joints')
        if joints is None:
            self.joints = sorted(self.hw.all_joints())
        else:
            if not isinstance(joints, (list, tuple)) or \
                    not all(isinstance(j, str) for j in joints):
                raise ControllerError('%s/joints must be a list of joint names' % self.name)
            for j in joints:
                if j not in self.hw.all_joints():
                    raise ControllerError('%s/joints: %r is not a joint of the robot'
                                          % (self.name, j))
            self.joints = list(joints)
        self.last = None          # (t, names, positions, velocities, efforts)
        self.samples = 0
        self.publish = None       # callable(sample) set by the ROS side

    def starting(self, t):
        self.next_time = t

    def update(self, t, dt):
        if t + 1e-9 < self.next_time:
            return
        self.next_time += 1.0 / self.publish_rate
        if self.next_time <= t:
            self.next_time = t + 1.0 / self.publish_rate
        st = self.read_states()
        self.last = (t, list(self.joints), [s[0] for s in st], [s[1] for s in st],
                     [s[2] for s in st])
        self.samples += 1
        if self.publish is not None:
            self.publish(self.last)


class _CommandController(Controller):
    """A controller with one Float64 command (``<ctrl>/command``)."""

    def set_command(self, value):
        v = float(value)
        if not math.isfinite(v):
            raise ControllerError('%s/command must be finite, got %r' % (self.name, value))
        self.command = v

    def starting(self, t):
        self.command = 0.0


class ForwardPositionController(_CommandController):
    TYPE = 'position_controllers/JointPositionController'
    INTERFACE = 'position'

    def starting(self, t):
        self.command = self.hw.state(self.joint)[0]

    def update(self, t, dt):
        self.hw.command(self.joint, 'position', self.command)


class ForwardVelocityController(_CommandController):
    TYPE = 'velocity_controllers/JointVelocityController'
    INTERFACE = 'velocity'

    def update(self, t, dt):
        self.hw.command(self.joint, 'velocity', self.command)


class ForwardEffortController(_CommandController):
    TYPE = 'effort_controllers/JointEffortController'
    INTERFACE = 'effort'

    def update(self, t, dt):
        self.hw.command(self.joint, 'effort', self.command)


class EffortPositionController(_CommandController):
    """effort_controllers/JointPositionController: the command (clamped to the joint's
    limits; continuous joints by the shortest angle) reached by a PID on the effort."""
    TYPE = 'effort_controllers/JointPositionController'
    INTERFACE = 'effort'

    def load(self, params):
        self.pid = Pid.from_params(params.get('pid'), '%s/pid' % self.name)
        lo, hi, _ = self.hw.limits(self.joint)
        self.lower, self.upper = lo, hi
        self.continuous = self.hw.joint_type(self.joint) == 'continuous'

    def starting(self, t):
        self.command = self.hw.state(self.joint)[0]
        self.pid.reset()

    def update(self, t, dt):
        q, v, _ = self.hw.state(self.joint)
        sp = self.command
        if self.continuous:
            err = _angle_diff(sp, q)
        else:
            if self.lower is not None and self.upper is not None:
                sp = min(self.upper, max(self.lower, sp))
            err = sp - q
        self.hw.command(self.joint, 'effort', self.pid.compute(err, -v, dt))


class EffortVelocityController(_CommandController):
    TYPE = 'effort_controllers/JointVelocityController'
    INTERFACE = 'effort'

    def load(self, params):
        self.pid = Pid.from_params(params.get('pid'), '%s/pid' % self.name)
        self.last_err = None

    def starting(self, t):
        self.command = 0.0
        self.pid.reset()
        self.last_err = None

    def update(self, t, dt):
        err = self.command - self.hw.state(self.joint)[1]
        de = 0.0 if self.last_err is None or dt <= 0 else (err - self.last_err) / dt
        self.last_err = err
        self.hw.command(self.joint, 'effort', self.pid.compute(err, de, dt))


class _GroupController(Controller):
    """A controller of several joints (``joints``) with one Float64MultiArray command."""
    GROUP = True
    MULTI = True

    def set_command(self, values):
        vals = [float(v) for v in values]
        if len(vals) != len(self.joints):
            raise ControllerError('%s/command: dimension of command (%d) does not match '
                                  'number of joints (%d); not executing' % (
                                      self.name, len(vals), len(self.joints)))
        if not all(math.isfinite(v) for v in vals):
            raise ControllerError('%s/command must be finite, got %r' % (self.name, vals))
        self.commands = vals

    def starting(self, t):
        self.commands = [0.0] * len(self.joints)

    def update(self, t, dt):
        for j, v in zip(self.joints, self.commands):
            self.hw.command(j, self.INTERFACE, v)


class GroupPositionController(_GroupController):
    TYPE = 'position_controllers/JointGroupPositionController'
    INTERFACE = 'position'

    def starting(self, t):
        self.commands = [self.hw.state(j)[0] for j in self.joints]


class GroupVelocityController(_GroupController):
    TYPE = 'velocity_controllers/JointGroupVelocityController'
    INTERFACE = 'velocity'


class GroupEffortController(_GroupController):
    TYPE = 'effort_controllers/JointGroupEffortController'
    INTERFACE = 'effort'


class GroupEffortPositionController(_GroupController):
    """effort_controllers/JointGroupPositionController: a PID per joint (``<joint>/pid``)."""
    TYPE = 'effort_controllers/JointGroupPositionController'
    INTERFACE = 'effort'

    def load(self, params):
        self.pids = []
        for j in self.joints:
            jp = params.get(j)
            self.pids.append(Pid.from_params(jp.get('pid') if isinstance(jp, dict) else None,
                                             '%s/%s/pid' % (self.name, j)))

    def starting(self, t):
        self.commands = [self.hw.state(j)[0] for j in self.joints]
        for p in self.pids:
            p.reset()

    def update(self, t, dt):
        for j, sp, pid in zip(self.joints, self.commands, self.pids):
            q, v, _ = self.hw.state(j)
            lo, hi, _ = self.hw.limits(j)
            if self.hw.joint_type(j) == 'continuous':
                err = _angle_diff(sp, q)
            else:
                if lo is not None and hi is not None:
                    sp = min(hi, max(lo, sp))
                err = sp - q
            self.hw.command(j, 'effort', pid.compute(err, -v, dt))


_IFACE_NAMES = {'position': 'PositionJointInterface', 'velocity': 'VelocityJointInterface',
                'effort': 'EffortJointInterface'}

CONTROLLER_TYPES = dict((c.TYPE, c) for c in (
    JointStateController, ForwardPositionController, ForwardVelocityController,
    ForwardEffortController, EffortPositionController, EffortVelocityController,
    GroupPositionController, GroupVelocityController, GroupEffortController,
    GroupEffortPositionController))


def controller_types():
    """{type name: class} of every controller type, the trajectory controllers included
    (sim_world.control.trajectory builds on this module, so it is imported here late)."""
    if 'position_controllers/JointTrajectoryController' not in CONTROLLER_TYPES:
        from .trajectory import (EffortJointTrajectoryController,
                                 PositionJointTrajectoryController,
                                 VelocityJointTrajectoryController)
        for c in (PositionJointTrajectoryController, EffortJointTrajectoryController,
                  VelocityJointTrajectoryController):
            CONTROLLER_TYPES[c.TYPE] = c
    return CONTROLLER_TYPES

#: the base class each type reports in list_controller_types
BASE_CLASS = 'controller_interface::ControllerBase'


class ControllerManager(object):
    """Controllers by name; ``update(t, dt)`` once per physics step runs the running ones
    and writes the hardware (``hw.write()``)."""

    def __init__(self, hw, log=None):
        self.hw = hw
        self.log = log or logging.getLogger('sim_world.control')
        self.controllers = {}     # name -> Controller (loaded; .running)

    def load_controller(self, name, params):
        """Load ``name`` from its parameter dict (stopped). Returns (ok, message); a refusal
        is one error line naming the parameter."""
        try:
            if not isinstance(name, str) or not name.strip('/'):
                raise ControllerError('controller name %r is empty' % (name,))
            if name in self.controllers:
                raise ControllerError('controller %r is already loaded' % name)
            if not isinstance(params, dict):
                raise ControllerError('%s: no parameters (is %s/type set?)' % (name, name))
            ctype = params.get('type')
            if ctype is None:
                raise ControllerError('%s/type is missing' % name)
            types = controller_types()
            cls = types.get(ctype) if isinstance(ctype, str) else None
            if cls is None:
                raise ControllerError('%s/type %r is not a known controller type (known: %s)'
                                      % (name, ctype, ', '.join(sorted(types))))
            self.controllers[name] = cls(name, params, self.hw)
        except ControllerError as e:
            self.log.error('controller_manager: %s', e)
            return False, str(e)
        return True, 'loaded %s' % name

    def unload_controller(self, name):
        c = self.controllers.get(name)
        if c is None:
            return self._refuse('cannot unload %r: not loaded' % (name,))
        if c.running:
            return self._refuse('cannot unload %r: it is running (stop it first)' % name)
        del self.controllers[name]
        return True, 'unloaded %s' % name

    def switch_controller(self, start=(), stop=(), t=0.0, strict=True):
        """Stop ``stop``, then start ``start`` (ros_control's switch). Strict: any unknown
        name or a joint claimed twice refuses the whole switch; best effort skips them."""
        start, stop = list(start), list(stop)
        bad = [n for n in start + stop if n not in self.controllers]
        if bad and strict:
            return self._refuse('switch refused: not loaded: %s' % ', '.join(bad))
        start = [n for n in start if n in self.controllers]
        stop = [n for n in stop if n in self.controllers]
        claimed = {}
        for n, c in self.controllers.items():
            if (c.running and n not in stop) or n in start:
                for j in c.claimed():
                    if j in claimed and claimed[j] != n:
                        msg = 'switch refused: %s and %s both claim joint %r' % (claimed[j], n, j)
                        if strict:
                            return self._refuse(msg)
                        self.log.error('controller_manager: %s', msg)
                        if n in start:
                            start.remove(n)
                        break
                    claimed[j] = n
        for n in stop:
            c = self.controllers[n]
            if c.running:
                c.stopping()
                c.state = 'stopped'
            c.running = False
            for j in c.claimed():
                self.hw.release(j)
        for n in start:
            c = self.controllers[n]
            if not c.running:
                c.running = True
                c.starting(t)
                c.state = 'running'
        return True, 'started %s, stopped %s' % (start, stop)

    def spawn(self, name, params, t=0.0):
        """Load and start (controller_manager's spawner)."""
        ok, msg = self.load_controller(name, params)
        if not ok:
            return ok, msg
        return self.switch_controller(start=[name], t=t)

    def set_command(self, name, value):
        c = self.controllers.get(name)
        if c is None or not hasattr(c, 'set_command'):
            return self._refuse('%r is not a loaded controller with a command' % (name,))
        try:
            c.set_command(value)
        except (ControllerError, TypeError, ValueError) as e:
            return self._refuse(str(e))
        return True, ''

    def list_controllers(self):
        """[(name, type, 'running'/'stopped', [joints])]"""
        return [(n, c.TYPE, 'running' if c.running else 'stopped', list(c.claimed()))
                for n, c in sorted(self.controllers.items())]

    def stop_all(self, t=0.0):
        """Stop every running controller (the plugin's end)."""
        self.switch_controller(stop=[n for n, c in self.controllers.items() if c.running],
                               t=t, strict=False)

    def update(self, t, dt, reset=False):
        """One control period. ``reset`` (controller_manager's ``reset_controllers``, which
        gazebo_ros_control sets on the update after an e-stop is released): every running
        controller is stopped and started again first, so it holds where it is now."""
        for n, c in list(self.controllers.items()):
            if not c.running:
                continue
            try:
                if reset:
                    c.stopping()
                    c.starting(t)
                c.update(t, dt)
            except Exception as e:  # noqa: BLE001 - one failing controller stops, not all
                self.log.error('controller_manager: controller %s failed at t=%.3f (%s: %s); '
                               'stopped', n, t, type(e).__name__, e)
                c.running = False
                c.state = 'stopped'
                for j in c.claimed():
                    self.hw.release(j)
        self.hw.write()

    def _refuse(self, msg):
        self.log.error('controller_manager: %s', msg)
        return False, msg
