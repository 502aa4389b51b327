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
from ..transforms import Pose
from .base import BodySpec, lump_links

__all__ = ['Group', 'JointState', 'Articulation', 'build_articulation', 'truncate_effort']

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

    @property
    def movable(self):
        return self.joint.movable

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
    for jn, v in dict(positions).items():
        js = art.joints.get(jn)
        if js is None or not js.movable:
            raise KeyError('model %r has no movable joint %r' % (name, jn))
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ValueError('joint %r of model %r: position %r is not a number' % (jn, name, v))
        if not math.isfinite(v) or abs(v) > 1e6:
            raise ValueError('joint %r of model %r: position %r is not finite' % (jn, name, v))
        out[jn] = v
    return out

