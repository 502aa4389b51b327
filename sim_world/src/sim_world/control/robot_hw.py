"""The simulator's hardware for ros_control (gazebo_ros_control's DefaultRobotHWSim, issue 48
part 4): the joints named by the URDF's ``<transmission>`` elements with their
``hardwareInterface`` (Position/Velocity/EffortJointInterface; ``mechanicalReduction`` is
ignored, as DefaultRobotHWSim does), read and commanded through the world's physics.

- effort: the command clamped to the joint's ``<limit effort>`` (when > 0), applied for the
  next step (the physics then truncates it as Gazebo's CheckAndTruncateForce);
- position: kinematic, as DefaultRobotHWSim without PID gains: the joint is set to the
  command every write and held there through the step by its velocity-0 motor (its friction
  raised to ``KINEMATIC_HOLD`` and its damping 0 while the interface is claimed, both put
  back on release), so gravity does not make it sag or swing between commands (it is set
  again when it is more than ``KINEMATIC_TOLERANCE`` off: a forward-kinematics pass of the
  model, which ODE reuses while the command stays the same); the other joints keep their
  velocities. Its
  velocity reads the commanded motion (the change of command over the time between
  writes), zero when held;
- velocity: the joint's velocity set to the command every step;
- position or velocity with PID gains (``<ns>/gazebo_ros_control/pid_gains/<joint>``: ``p``,
  ``i``, ``d``, ``i_clamp``, as DefaultRobotHWSim's POSITION_PID and VELOCITY_PID): the
  joint is driven by an effort, control_toolbox's PID of the position error (the shortest
  angle for a continuous joint) or the velocity error over the time since the last write,
  clamped to the effort limit; it is then a dynamic joint (gravity, contacts and its own
  damping and friction act on it), not a kinematic one;
- the e-stop (``eStopTopic``, ``e_stop = True``): as DefaultRobotHWSim's, position-commanded
  joints hold where they were when it came, velocity commands are 0 (with PID: the joint's
  velocity is braked to 0) and efforts are 0, whatever the controllers command.

Not a plugin module: the world seam has no joint commands, so this adapter (like joint_api)
talks to ``world.physics``; the plugin (control/ros_control.py) reaches it only through it.
"""
import math
import xml.etree.ElementTree as ET

from .controllers import ControllerError, Pid, _angle_diff

__all__ = ['Transmission', 'parse_transmissions', 'RobotHWSim', 'TransmissionError']

KINDS = {'PositionJointInterface': 'position', 'VelocityJointInterface': 'velocity',
         'EffortJointInterface': 'effort'}
KEY = 'gazebo_ros_control'
KINEMATIC_HOLD = 1e4      # N m or N: the motor that holds a position-commanded joint
KINEMATIC_TOLERANCE = 1e-6   # rad or m: how far it may be off its command before it is set
MOVABLE = ('revolute', 'continuous', 'prismatic')


class TransmissionError(ValueError):
    pass


class Transmission(object):
    def __init__(self, name, joint, interfaces):
        self.name, self.joint, self.interfaces = name, joint, interfaces

    def __repr__(self):
        return '<Transmission %s: %s %s>' % (self.name, self.joint, self.interfaces)


def _iface(text, where):
    short = (text or '').strip().split('/')[-1]
    if short not in KINDS:
        raise TransmissionError('%s: hardwareInterface %r is not one of %s'
                                % (where, (text or '').strip(),
                                   ', '.join('hardware_interface/' + k for k in KINDS)))
    return KINDS[short]


def parse_transmissions(xml_text):
    """The ``<transmission>`` elements of a URDF (both the joint-level hardwareInterface of
    ros_control and the older actuator-level one). TransmissionError naming a bad one."""
    if not xml_text:
        return []
    root = ET.fromstring(xml_text)
    out = []
    for t in root.iter('transmission'):
        name = t.get('name') or '?'
        where = 'transmission %r' % name
        j = t.find('joint')
        if j is None or not j.get('name'):
            raise TransmissionError('%s has no <joint name="...">' % where)
        hw = [e.text for e in j.findall('hardwareInterface')]
        if not hw:
            hw = [e.text for a in t.findall('actuator') for e in a.findall('hardwareInterface')]
        if not hw:
            raise TransmissionError('%s: joint %r has no <hardwareInterface>'
                                    % (where, j.get('name')))
        out.append(Transmission(name, j.get('name'), [_iface(h, where) for h in hw]))
    return out


class RobotHWSim(object):
    """``interfaces``, ``state``, ``command``, ``limits``, ``write`` of one model."""

    def __init__(self, world, model_name, transmissions):
        self.world = world
        self.model = model_name
        self.physics = world.physics
        names = self.physics.joint_names(model_name)
        self.interfaces = {}
        for tr in transmissions:
            if tr.joint not in names:
                raise TransmissionError('transmission %r: joint %r is not a simulated joint '
                                        'of model %r (joints: %s)' % (tr.name, tr.joint, model_name,
                                                                     ', '.join(names) or 'none'))
            if self.physics.joint(model_name, tr.joint).type not in MOVABLE:
                raise TransmissionError('transmission %r: joint %r is not movable'
                                        % (tr.name, tr.joint))
            # DefaultRobotHWSim uses the first interface of a joint and warns for more
            self.interfaces.setdefault(tr.joint, set()).update(tr.interfaces)
        self.efforts = {}         # joint -> last effort sent (after the clamp)
        self._pending = {}        # joint -> (kind, value) of this step
        self._held = {}           # joint -> its own (damping, friction), while kinematic
        self._kin = {}            # joint -> (sim time, position commanded, velocity read)
        self._seen = {}           # joint -> (sim time, position) a controller read
        self._movable = None      # all_joints()
        self.pids = {}            # joint -> _JointPid (gazebo_ros_control/pid_gains)
        self.e_stop = False       # set by the plugin before each write
        self._e_hold = None       # joint -> position where the e-stop found it
        self._last_write = None   # sim time of the last write (the PID's period)

    def set_pid_gains(self, gains, where='gazebo_ros_control/pid_gains', log=None):
        """PID gains per joint (a dict ``joint -> {p, i, d, i_clamp...}``, as the parameters
        under ``<ns>/gazebo_ros_control/pid_gains``): a position- or velocity-interface joint
        with gains is then driven by an effort. A joint without a position or velocity
        interface, or gains without ``p`` or with a bad value, is one error line naming the
        parameter, and the joint stays as it was (DefaultRobotHWSim too keeps the joint
        without PID when control_toolbox refuses its gains). Returns the joints with gains."""
        if not isinstance(gains, dict):
            if gains is not None and log is not None:
                log.error('%s must be a dict of joint names, got %r', where, gains)
            return sorted(self.pids)
        for joint, params in sorted(gains.items()):
            at = '%s/%s' % (where, joint)
            kinds = self.interfaces.get(joint, set()) & {'position', 'velocity'}
            if not kinds:
                if log is not None:
                    log.error('%s: joint %r has no position or velocity interface in model '
                              '%r: gains ignored', at, joint, self.model)
                continue
            try:
                pid = Pid.from_params(params, at)
            except ControllerError as e:
                if log is not None:
                    log.error('%s: joint %r keeps no PID', e, joint)
                continue
            self.pids[joint] = _JointPid(pid)
        return sorted(self.pids)

    def all_joints(self):
        return list(self.all_joints_view())

    def all_joints_view(self):
        """all_joints() without the copy (not to be changed)."""
        if self._movable is None:      # the model's joints do not change while it lives
            self._movable = [j for j in self.physics.joint_names(self.model)
                             if self.physics.joint(self.model, j).type in MOVABLE]
        return self._movable

    def joint_type(self, joint):
        return self.physics.joint(self.model, joint).type

    def limits(self, joint):
        j = self.physics.joint(self.model, joint)
        lo, hi = j.lower, j.upper
        if j.type == 'continuous':
            lo = hi = None
        return lo, hi, j.effort

    def state(self, joint):
        q, v = self.physics.joint_state(self.model, joint)
        self._seen[joint] = (self.world.sim_time, q)   # nothing moves it until the write
        k = self._kin.get(joint)
        if k is not None:
            v = k[2]
        return q, v, self.efforts.get(joint, 0.0)

    def states(self, joints):
        """[state(joint) for joint in joints], the joints read from the physics in one call."""
        now = self.world.sim_time
        seen, kin, efforts = self._seen, self._kin, self.efforts
        out = []
        for j, (q, v) in zip(joints, self.physics.joint_states_of(self.model, joints)):
            seen[j] = (now, q)                 # nothing moves it until the write
            k = kin.get(j)
            if k is not None:
                v = k[2]
            out.append((q, v, efforts.get(j, 0.0)))
        return out

    def command(self, joint, kind, value):
        self._pending[joint] = (kind, float(value))

    def commands(self, joints, kind, values):
        """command(joint, kind, value) of each joint with its value."""
        pending = self._pending
        for j, v in zip(joints, values):
            pending[j] = (kind, float(v))

    def release(self, joint):
        self._pending.pop(joint, None)
        self.efforts.pop(joint, None)
        self._kin.pop(joint, None)
        if joint in self.pids:
            self.pids[joint].reset()
        if joint in self._held and self.physics.has_model(self.model):
            damping, friction = self._held.pop(joint)
            self.physics.set_joint_dynamics(self.model, joint, damping=damping,
                                            friction=friction)
        self.physics.clear_joint_efforts(self.model, joint, key=KEY)

    def _effort(self, joint, e):
        lim = self.physics.joint(self.model, joint).effort
        e = max(-lim, min(lim, e)) if lim > 0 else e
        self.efforts[joint] = e
        self.physics.apply_joint_effort(self.model, joint, e, steps=1, key=KEY)

    def _pid_effort(self, joint, kind, v, dt):
        """DefaultRobotHWSim's POSITION_PID / VELOCITY_PID: the effort from the error."""
        q, qd = self.physics.joint_state(self.model, joint)
        if kind == 'position':
            err = _angle_diff(v, q) if self.joint_type(joint) == 'continuous' else v - q
        else:
            err = v - qd
        self._effort(joint, self.pids[joint].compute(err, dt))

    def write(self):
        seen, self._seen = self._seen, {}
        now = self.world.sim_time
        dt = now - self._last_write if self._last_write is not None else \
            self.world.step_size
        self._last_write = now
        if self.e_stop and self._e_hold is None:
            self._e_hold = dict((j, self.physics.joint_state(self.model, j)[0])
                                for j in self.all_joints())
        elif not self.e_stop:
            self._e_hold = None
        if not self._pending:
            return
        ph, m = self.physics, self.model
        positions = {}
        for joint, (kind, v) in self._pending.items():
            if self._e_hold is not None:         # the e-stop: hold, stand still, no effort
                v = self._e_hold.get(joint, v) if kind == 'position' else 0.0
            if kind == 'effort':
                self._effort(joint, v)
            elif joint in self.pids and kind in ('position', 'velocity'):
                self._pid_effort(joint, kind, v, dt)
            elif kind == 'position':
                positions[joint] = v
            elif kind == 'velocity':
                ph.set_joint_velocity(m, joint, v)
        if positions:
            held, kin = self._held, self._kin
            off = False             # a joint more than KINEMATIC_TOLERANCE off its command
            for j, q in positions.items():
                if j not in held:
                    jj = self.physics.joint(m, j)
                    held[j] = (jj.damping, jj.friction)
                    # no damping while held: the hold motor's force does not need it, and
                    # the model then costs no per-step motor update
                    ph.set_joint_dynamics(m, j, damping=0.0, friction=KINEMATIC_HOLD)
                k = kin.get(j)
                v = (q - k[1]) / (now - k[0]) if k is not None and now > k[0] else 0.0
                kin[j] = (now, q, v)
                if not off:
                    s = seen.get(j)
                    at = s[1] if s is not None and s[0] == now else ph.joint_state(m, j)[0]
                    off = abs(at - q) > KINEMATIC_TOLERANCE
            # teleport only when a joint is off its command by more than
            # KINEMATIC_TOLERANCE (a kinematic move costs a forward kinematics pass of the
            # whole model; Bullet's motor holds a joint within 1e-6 rad for several steps,
            # ODE's for none), and then every kinematic joint to its command: the same
            # joint values every step of a hold (ODE reuses the pass for them)
            if not off:
                positions = {}
        if positions:
            every = self.all_joints_view()
            keep = dict((j, ph.joint_state(m, j)[1]) for j in every
                        if j not in positions) if len(positions) < len(every) else {}
            ph.set_joint_positions(m, positions)
            for j, v in keep.items():
                if v:
                    ph.set_joint_velocity(m, j, v)
        self._pending.clear()


class _JointPid(object):
    """control_toolbox's Pid as computeCommand(error, dt) uses it: the error's derivative is
    its change since the last call (from 0 at the first call, so the first step kicks by
    ``d`` times the error over dt, as in Gazebo), and a reset clears both."""

    def __init__(self, pid):
        self.pid = pid
        self.last_error = 0.0

    def compute(self, error, dt):
        if dt <= 0 or not math.isfinite(error):
            return 0.0
        d = (error - self.last_error) / dt
        self.last_error = error
        return self.pid.compute(error, d, dt)

    def reset(self):
        self.pid.reset()
        self.last_error = 0.0
