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
- velocity: the joint's velocity set to the command every step.

Not a plugin module: the world seam has no joint commands, so this adapter (like joint_api)
talks to ``world.physics``; the plugin (control/ros_control.py) reaches it only through it.
"""
import xml.etree.ElementTree as ET

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

    def all_joints(self):
        if self._movable is None:      # the model's joints do not change while it lives
            self._movable = [j for j in self.physics.joint_names(self.model)
                             if self.physics.joint(self.model, j).type in MOVABLE]
        return list(self._movable)

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

    def command(self, joint, kind, value):
        self._pending[joint] = (kind, float(value))

    def release(self, joint):
        self._pending.pop(joint, None)
        self.efforts.pop(joint, None)
        self._kin.pop(joint, None)
        if joint in self._held and self.physics.has_model(self.model):
            damping, friction = self._held.pop(joint)
            self.physics.set_joint_dynamics(self.model, joint, damping=damping,
                                            friction=friction)
        self.physics.clear_joint_efforts(self.model, joint, key=KEY)

    def _now_at(self, joint, seen, now):
        """The joint's position now: as a controller read it in this update, else read."""
        s = seen.get(joint)
        return s[1] if s is not None and s[0] == now else \
            self.physics.joint_state(self.model, joint)[0]

    def write(self):
        seen, self._seen = self._seen, {}
        if not self._pending:
            return
        ph, m = self.physics, self.model
        positions = {}
        for joint, (kind, v) in self._pending.items():
            if kind == 'effort':
                lim = self.physics.joint(m, joint).effort
                e = max(-lim, min(lim, v)) if lim > 0 else v
                self.efforts[joint] = e
                ph.apply_joint_effort(m, joint, e, steps=1, key=KEY)
            elif kind == 'position':
                positions[joint] = v
            elif kind == 'velocity':
                ph.set_joint_velocity(m, joint, v)
        if positions:
            now = self.world.sim_time
            for j, q in positions.items():
                if j not in self._held:
                    jj = self.physics.joint(m, j)
                    self._held[j] = (jj.damping, jj.friction)
                    # no damping while held: the hold motor's force does not need it, and
                    # the model then costs no per-step motor update
                    ph.set_joint_dynamics(m, j, damping=0.0, friction=KINEMATIC_HOLD)
                k = self._kin.get(j)
                v = (q - k[1]) / (now - k[0]) if k is not None and now > k[0] else 0.0
                self._kin[j] = (now, q, v)
            # teleport only when a joint is off its command by more than
            # KINEMATIC_TOLERANCE (a kinematic move costs a forward kinematics pass of the
            # whole model; Bullet's motor holds a joint within 1e-6 rad for several steps,
            # ODE's for none), and then every kinematic joint to its command: the same
            # joint values every step of a hold (ODE reuses the pass for them)
            if not any(abs(self._now_at(j, seen, now) - q) > KINEMATIC_TOLERANCE
                       for j, q in positions.items()):
                positions = {}
        if positions:
            keep = dict((j, ph.joint_state(m, j)[1]) for j in self.all_joints()
                        if j not in positions) if len(positions) < len(self.all_joints()) \
                else {}
            ph.set_joint_positions(m, positions)
            for j, v in keep.items():
                if v:
                    ph.set_joint_velocity(m, j, v)
        self._pending.clear()
