"""Articulated models: links grouped into rigid bodies joined by joints (both engines).

``build_articulation(model)`` reads a validated ``sim_world.model.Model`` as Gazebo's URDF
converter does:

* links joined by ``fixed`` joints are lumped into one body (a *group*), unless the joint
  has ``<preserveFixedJoint>``; every revolute, continuous or prismatic joint (and every
  preserved fixed joint) starts a new group;
* a group without mass (no link with an ``<inertial>``) below a movable joint is not
  simulated, with its subtree (sdformat: "link has no inertia, not modeled"): one warning
  names the link, and its links move rigidly with the parent group for drawing;
* a root link named ``world`` welds the model to the world (``Articulation.welded``); the
  root group may then be massless (an anchor).

Returns None for a model that stays one rigid body (no movable joint left, not welded):
the single-body path of the engines is unchanged for it.

Joint semantics shared by the backends (``JointState``), Gazebo's: an applied effort is
truncated by ``CheckAndTruncateForce`` (no push beyond the velocity limit, then clamped to
the effort limit), viscous damping ``-damping * velocity`` is added each step, Coulomb
friction is a velocity-0 joint motor with ``friction`` as its maximum force, position
limits are joint stops. Continuous joints do not wrap.
"""
import logging
import math

import numpy as np

from ..model import ModelError
from ..transforms import Pose, _quat_multiply
from .base import BodySpec, lump_links

__all__ = ['Group', 'JointState', 'Articulation', 'BodyPoses', 'build_articulation',
           'truncate_effort']

log = logging.getLogger('sim_world.physics')


def truncate_effort(effort, velocity, effort_limit, velocity_limit):
    """Gazebo's Joint::CheckAndTruncateForce: no push beyond the velocity limit, then the
    effort clamped to the effort limit (negative limits: none)."""
    if velocity_limit >= 0:
        if velocity > velocity_limit and effort > 0:
            effort = 0.0
        elif velocity < -velocity_limit and effort < 0:
            effort = 0.0
    if effort_limit >= 0:
        effort = min(max(effort, -effort_limit), effort_limit)
    return effort


class Group(object):
    """One rigid body of an articulated model.

    name: its root link; spec: the BodySpec (link_offsets relative to the root link);
    parent: index of the parent group (None for the root group); joint: the Joint to the
    parent (None for the root); origin: this group's root-link frame in the parent group's
    root-link frame at joint position zero; frame: the joint frame in this group's root
    link frame (identity for URDF); anchor: a massless welded root (a dummy body in ODE, a
    fixed base in Bullet); native: engine handles."""

    def __init__(self, name, spec, parent=None, joint=None, origin=None, anchor=False):
        self.name = name
        self.spec = spec
        self.parent = parent
        self.joint = joint
        self.origin = origin or Pose()
        self.frame = joint.frame if joint is not None else Pose()
        self.anchor = anchor
        self.com_inv = spec.com.inverse()
        self.native = None


class JointState(object):
    """A simulated joint: its Joint, its group (the child body), what acts on it."""

    def __init__(self, joint, group_index):
        self.joint = joint
        self.name = joint.name
        self.group = group_index
        self.efforts = {}        # key -> [effort, steps left or None, steps before start]
        self.turns = 0           # ODE hinges: whole turns of an unwrapped angle
        self.last_raw = 0.0
        self.native = None
        self.damping = joint.damping
        self.friction = joint.friction
        self.movable = joint.movable     # a joint's type does not change while it lives

    def applied(self):
        """Sum of the applied efforts for the coming step; advances their step counts."""
        total = 0.0
        for key in list(self.efforts):
            e = self.efforts[key]
            if len(e) > 2 and e[2] > 0:     # starts later
                e[2] -= 1
                continue
            total += e[0]
            if e[1] is not None:
                e[1] -= 1
                if e[1] <= 0:
                    del self.efforts[key]
        return total


class Articulation(object):
    def __init__(self, groups, joints, link_group, welded):
        self.groups = groups          # [Group], parents before children, root first
        self.joints = joints          # {name: JointState} (movable and preserved fixed)
        self.order = list(joints)     # joint names in the model's order
        self.link_group = link_group  # {link name: (group index, pose in the group frame)}
        self.welded = welded
        self.needs_step = False       # efforts or damping to apply before a step
        self.moving = [js for js in joints.values() if js.movable]
        self.movable_names = frozenset(js.name for js in self.moving)

    def refresh(self):
        self.needs_step = any(js.efforts or js.damping > 0 for js in self.joints.values())


def build_articulation(model):
    """An Articulation of a validated, non-static model, or None (one rigid body)."""
    what = 'model %r' % model.name
    root = model.root_link
    welded = root == 'world'
    by_parent = {}
    for j in model.joints:
        by_parent.setdefault(j.parent, []).append(j)
    # group membership: BFS from the root, fixed joints stay in their parent's group
    members = [[(root, Pose())]]
    parents, joints, origins = [None], [None], [None]
    where = {root: (0, Pose())}
    queue = [root]
    while queue:
        lname = queue.pop(0)
        gi, off = where[lname]
        for j in by_parent.get(lname, []):
            if j.type == 'fixed' and not j.preserve:
                where[j.child] = (gi, off * j.origin)
                members[gi].append((j.child, where[j.child][1]))
            else:
                members.append([(j.child, Pose())])
                parents.append(gi)
                joints.append(j)
                origins.append(off * j.origin)
                where[j.child] = (len(members) - 1, Pose())
            queue.append(j.child)
    if len(members) == 1 and not welded:
        return None
    groups = []
    keep = {}                     # old group index -> new index
    link_group = {}
    dropped_into = {}             # old index -> (new parent index, pose of its root in it)
    for gi, links in enumerate(members):
        offsets = dict(links)
        parent = parents[gi]
        if parent is not None and parent not in keep:
            # below a dropped group: drawn rigidly with it
            pidx, ppose = dropped_into[parent]
            dropped_into[gi] = (pidx, ppose * origins[gi])
            for ln, off in offsets.items():
                link_group[ln] = (pidx, ppose * origins[gi] * off)
            continue
        spec = lump_links(model, offsets, False, require_mass=False,
                          name='%s::%s' % (model.name, links[0][0]))
        if spec is None and gi > 0:
            log.warning('%s: link %r has no inertia (no <inertial> or mass 0) and hangs on '
                        '%s joint %r: it is not simulated, with the links below it, as '
                        "Gazebo's URDF converter does (drawn fixed to its parent)",
                        what, links[0][0], joints[gi].type, joints[gi].name)
            pidx = keep[parent]
            dropped_into[gi] = (pidx, _group_offset(groups, pidx, origins[gi], parent,
                                                    members, keep))
            for ln, off in offsets.items():
                link_group[ln] = (pidx, dropped_into[gi][1] * off)
            continue
        anchor = False
        if spec is None:
            if not welded:
                raise ModelError('%s is not static but its root link %r (with the links '
                                 'fixed to it) has no <inertial> with a positive mass (a '
                                 'fixed-base robot: add <link name="world"/> and a fixed '
                                 'joint from it to %r, as Gazebo wants)' % (what, root, root))
            anchor = True
            spec = BodySpec('%s::%s' % (model.name, root), False, 0.0, Pose(), np.zeros(3),
                            False, [], offsets)
        for s in spec.shapes:
            if s.geometry.kind == 'plane':
                raise ModelError('%s: a plane collision on a moving link' % what)
        new = len(groups)
        keep[gi] = new
        j = joints[gi]
        groups.append(Group(links[0][0], spec, None if parent is None else keep[parent], j,
                            origins[gi], anchor))
        groups[-1].self_collide = any(model.links[ln].self_collide for ln in offsets)
        for ln, off in offsets.items():
            link_group[ln] = (new, off)
    states = {}
    for gi, g in enumerate(groups):
        if g.joint is not None:
            states[g.joint.name] = JointState(g.joint, gi)
    art = Articulation(groups, states, link_group, welded)
    art.refresh()
    return art


def _rot(q, v):
    """Unit quaternion q (x, y, z, w) applied to v, in plain floats."""
    x, y, z, w = q
    vx, vy, vz = v
    return ((1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - z * w) * vy + 2 * (x * z + y * w) * vz,
            2 * (x * y + z * w) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - x * w) * vz,
            2 * (x * z - y * w) * vx + 2 * (y * z + x * w) * vy + (1 - 2 * (x * x + y * y)) * vz)


class BodyPoses(object):
    """The world poses of every group's body (its centre-of-mass frame, ``spec.com`` in its
    root-link frame) from the root body's pose and joint positions: ``forward(art, root_body
    * com_inv, positions)[i] * spec.com`` (the kinematic joint set of the ODE engine runs it
    every step while a position interface moves an arm), computed in plain floats with one
    pose product per group.

    Each group's pose in its parent's body frame, ``L(q) = com_inv(parent) * origin *
    motion(q) * com``, is folded into constants when the model is built: a revolute or
    continuous joint about the unit axis a gives ``L.q = cos(q/2) A + sin(q/2) B`` (A = K.q
    com.q, B = K.q (a, 0) com.q with K = com_inv(parent) * origin) and ``L.p = D + cos(q) E +
    sin(q) F`` (Rodrigues' formula on com.p: D = K.p + K.q (a.com.p) a, E = K.q of com.p's
    part across a, F = K.q (a x com.p)); a prismatic one ``L.q = A``, ``L.p = D + q E``; a
    preserved fixed joint a constant; a joint with its own frame (SDF ``<pose>``) goes
    through ``sim_world.model.joint_motion``. Then body = parent body * L(q). The results
    equal the straightforward composition to float rounding (test_articulation_fk)."""

    ROT, SLIDE, FIXED, GENERAL = 0, 1, 2, 3

    def __init__(self, art):
        self.groups = art.groups
        consts = []
        zero = (0.0, 0.0, 0.0)
        for g in art.groups:
            if g.parent is None:
                consts.append(None)
                continue
            par = art.groups[g.parent]
            k = par.com_inv * g.origin
            com = g.spec.com
            j = g.joint
            kq = tuple(k.q.tolist())
            kp = tuple(k.p.tolist())
            cq = tuple(com.q.tolist())
            cp = tuple(com.p.tolist())
            if j is None or not j.movable:
                c = k * com
                consts.append((g.parent, self.FIXED, '', None) + tuple(c.q.tolist())
                              + (0.0,) * 4 + tuple(c.p.tolist()) + zero + zero)
                continue
            f = j.frame
            if np.any(f.p) or f.q[3] != 1.0:
                consts.append((g.parent, self.GENERAL, j.name, (k, com, j)) + (0.0,) * 17)
                continue
            a = j.axis / max(np.linalg.norm(j.axis), 1e-12)
            ax, ay, az = (float(v) for v in a)
            A = _quat_multiply(kq, cq)
            if j.type == 'prismatic':
                axis = tuple(float(v) for v in j.axis)
                consts.append((g.parent, self.SLIDE, j.name, None) + A + (0.0,) * 4
                              + _add(kp, _rot(kq, cp)) + _rot(kq, axis) + zero)
                continue
            B = _quat_multiply(_quat_multiply(kq, (ax, ay, az, 0.0)), cq)
            along = ax * cp[0] + ay * cp[1] + az * cp[2]
            par_part = (ax * along, ay * along, az * along)
            across = (cp[0] - par_part[0], cp[1] - par_part[1], cp[2] - par_part[2])
            cross = (ay * cp[2] - az * cp[1], az * cp[0] - ax * cp[2], ax * cp[1] - ay * cp[0])
            consts.append((g.parent, self.ROT, j.name, None) + A + B
                          + _add(kp, _rot(kq, par_part)) + _rot(kq, across) + _rot(kq, cross))
        self.consts = consts
        #: per group (parent, kind, joint, poses, A (4), B (4), D (3), E (3), F (3))

    def __call__(self, root_p, root_q, positions):
        """[(position, wxyz quaternion)] of every group's body (ODE's order), the root body
        at (root_p, root_q xyzw); ``positions``: {joint name: value}, missing: 0."""
        ROT, SLIDE, FIXED = self.ROT, self.SLIDE, self.FIXED
        sin, cos, sqrt = math.sin, math.cos, math.sqrt
        get = positions.get
        bodies = []
        out = []
        for c in self.consts:
            if c is None:
                px, py, pz = root_p
                x, y, z, w = root_q
                n = sqrt(x * x + y * y + z * z + w * w)
                x, y, z, w = x / n, y / n, z / n, w / n
                bodies.append((px, py, pz, x, y, z, w))
                out.append(((px, py, pz), (w, x, y, z)))
                continue
            (parent, kind, jname, poses, a0, a1, a2, a3, b0, b1, b2, b3, vx, vy, vz,
             e0, e1, e2, f0, f1, f2) = c
            if kind == ROT:
                h = 0.5 * get(jname, 0.0)
                ch, sh = cos(h), sin(h)
                cq, sq = ch * ch - sh * sh, 2.0 * sh * ch          # cos q, sin q
                bx, by, bz, bw = (ch * a0 + sh * b0, ch * a1 + sh * b1, ch * a2 + sh * b2,
                                  ch * a3 + sh * b3)
                vx, vy, vz = vx + cq * e0 + sq * f0, vy + cq * e1 + sq * f1, \
                    vz + cq * e2 + sq * f2
            elif kind == SLIDE:
                q = get(jname, 0.0)
                bx, by, bz, bw = a0, a1, a2, a3
                vx, vy, vz = vx + q * e0, vy + q * e1, vz + q * e2
            elif kind == FIXED:                  # a preserved fixed joint
                bx, by, bz, bw = a0, a1, a2, a3
            else:
                from ..model import joint_motion
                k, com, j = poses
                m = k * joint_motion(j, get(jname, 0.0)) * com
                bx, by, bz, bw = m.q.tolist()
                vx, vy, vz = m.p.tolist()
            px, py, pz, x, y, z, w = bodies[parent]
            qx = w * bx + x * bw + y * bz - z * by
            qy = w * by - x * bz + y * bw + z * bx
            qz = w * bz + x * by - y * bx + z * bw
            qw = w * bw - x * bx - y * by - z * bz
            # (products of unit quaternions: unit to rounding, ~1e-16 per body; ODE
            # normalises what it is given)
            p = (px + (1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - z * w) * vy
                 + 2 * (x * z + y * w) * vz,
                 py + 2 * (x * y + z * w) * vx + (1 - 2 * (x * x + z * z)) * vy
                 + 2 * (y * z - x * w) * vz,
                 pz + 2 * (x * z - y * w) * vx + 2 * (y * z + x * w) * vy
                 + (1 - 2 * (x * x + y * y)) * vz)
            bodies.append(p + (qx, qy, qz, qw))
            out.append((p, (qw, qx, qy, qz)))
        return out


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _group_offset(groups, pidx, origin, parent_old, members, keep):
    """Pose of a dropped group's root in its kept parent's frame (the parent is kept)."""
    return origin


def forward(art, root_world, positions):
    """World pose of every group's root-link frame with the root at ``root_world`` and
    joints at ``positions`` ({name: value}, missing: 0)."""
    from ..model import joint_motion
    out = []
    for g in art.groups:
        if g.parent is None:
            out.append(root_world)
        else:
            q = positions.get(g.joint.name, 0.0)
            out.append(out[g.parent] * g.origin * joint_motion(g.joint, q))
    return out


def check_positions(art, name, positions):
    """{joint: float} checked: known movable joints, finite values; ValueError naming the
    joint otherwise."""
    out = {}
    movable = art.movable_names
    if not isinstance(positions, dict):
        positions = dict(positions)
    for jn, v in positions.items():
        if jn not in movable:
            raise KeyError('model %r has no movable joint %r' % (name, jn))
        if type(v) is not float:
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ValueError('joint %r of model %r: position %r is not a number'
                                 % (jn, name, v))
        if not abs(v) <= 1e6:           # NaN and inf too
            raise ValueError('joint %r of model %r: position %r is not finite' % (jn, name, v))
        out[jn] = v
    return out
