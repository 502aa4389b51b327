"""ODE backend (Debian's python3-pyode), the default engine.

Layout: one ``ode.World``; the geoms of moving bodies live in ``_dyn_space``, the finite
static geoms in ``_static_space`` and infinite planes in a plain list. Each step runs
``quickStep`` and then one contact pass for the new state:

* ``ode.collide2(dyn_space, static_space)``: ODE itself prunes pairs by bounding box, so a
  body that touches nothing (the floating phone) costs no Python callback;
* ``dyn_space.collide``: moving bodies among themselves (same-body pairs are skipped by
  ODE);
* planes: their bounding box is infinite, so each plane is first tested in Python against
  the bounding box of all moving geoms (a few float operations) and collided only when
  something reaches it.

Meshes: Debian's pyode is built without trimesh support (``ode.TriMeshData`` raises), so
a mesh collision becomes the boxes of ``base.mesh_boxes`` (a voxelisation, exact for
box-shaped meshes, within one voxel of 1/24 of the mesh's size otherwise).

Contacts found in that pass become contact joints for the next ``quickStep`` (the usual
collide-then-step loop, shifted so that ``in_contact`` describes the current state).
Contacts: Coulomb friction (``dContactApprox1``, mu 1), no bounce; world ERP 0.2, CFM
1e-10, contact surface layer 0.1 mm, max correcting velocity 100 m/s (Gazebo's defaults,
with a thinner surface layer so resting bodies sink at most 0.1 mm), 20 quickStep
iterations (ODE's default; Gazebo uses 50, which costs 2.5x more per resting contact and
changes nothing measurable for the office's single bodies on boxes).
"""
import ctypes
import ctypes.util
import logging
import math

import numpy as np
import ode

from .articulation import BodyPoses, forward
from .base import FRICTION, Contact, PhysicsEngine, mesh_boxes
from ..transforms import Pose

log = logging.getLogger('sim_world.physics')
TWO_PI = 2.0 * math.pi
#: dParamFMax of the libode Debian 12 ships (0.16): since ODE 0.13 dParamLoVel and
#: dParamHiVel come before it, so pyode's ode.ParamFMax (3) is really dParamLoVel and
#: setting it does nothing to the motor (found by test_joints' friction test)
PARAM_FMAX = 5

__all__ = ['OdeEngine']

MAX_CONTACTS = 16
#: m or quaternion component: a root body this close to where it was at the last
#: set_joint_positions with the same joint values gets the same body poses (a welded arm's
#: root moves ~1e-15 per step, a kinematic hold sets the same pose every step)
FK_CACHE_TOLERANCE = 1e-9


def _ode_rand():
    """libode's dRandGetSeed/dRandSetSeed: quickStep reorders constraints at random from
    ONE process-wide generator, so two worlds in one process (or one world after another)
    would not repeat. Each engine keeps its own state and swaps it in around its steps."""
    try:
        lib = ctypes.CDLL(ctypes.util.find_library('ode') or 'libode.so.8')
        get, put = lib.dRandGetSeed, lib.dRandSetSeed
        get.restype, get.argtypes = ctypes.c_ulong, []
        put.restype, put.argtypes = None, [ctypes.c_ulong]
        return get, put
    except (OSError, AttributeError):
        return None, None


_RAND_GET, _RAND_SET = _ode_rand()


def _wxyz(q):
    return (float(q[3]), float(q[0]), float(q[1]), float(q[2]))


class OdeEngine(PhysicsEngine):
    name = 'ode'

    def __init__(self, step_size=0.001, gravity=(0.0, 0.0, -9.81)):
        PhysicsEngine.__init__(self, step_size, gravity)
        w = ode.World()
        w.setGravity(tuple(float(x) for x in self.gravity))
        w.setERP(0.2)
        w.setCFM(1e-10)
        w.setContactSurfaceLayer(1e-4)
        w.setContactMaxCorrectingVel(100.0)
        w.setQuickStepNumIterations(20)
        self._world = w
        self._dyn_space = ode.HashSpace()
        self._static_space = ode.HashSpace()
        self._planes = []            # [(geom, normal np(3), dist)]
        self._contacts = ode.JointGroup()
        self._n_contacts = 0
        self._geom_model = {}        # geom -> model name
        self._geom_seq = {}          # geom -> creation number (a stable order of pairs)
        self._pending = []           # colliding pairs of one pass, joined in a stable order
        self._seq_next = 0
        self._touching = set()
        self._dirty = True           # contacts must be recomputed before the next step
        self._contact_mode = ode.ContactApprox1
        self._mesh_boxes = {}        # id(mesh arrays) -> (mesh arrays, [(centre, size)])
        self._rand_state = 0         # this world's libode random state (see _ode_rand)
        self._n_art = 0              # articulated models (joint efforts, damping, unwrapping)
        self._geom_group = {}        # geom of an articulated model -> self-collide flag
        self._hinges = []            # [JointState] of hinges whose angle is unwrapped
        self._n_attached = 0         # fixed joints of the link attacher (attachments.py)

    # ---- articulated models (sim_world.physics.articulation) -------------------------------
    def _add_articulated(self, rec, pose):
        art = rec.art
        frames = forward(art, pose, {})
        geoms, bodies, weld = [], [], None
        world = self._world
        for gi, g in enumerate(art.groups):
            spec = g.spec
            body = ode.Body(world)
            m = ode.Mass()
            if g.anchor:
                total = max(1.0, sum(x.spec.mass for x in art.groups))
                m.setParameters(total, 0.0, 0.0, 0.0, total * 0.1, total * 0.1, total * 0.1,
                                0.0, 0.0, 0.0)
                body.setGravityMode(False)
            else:
                i = spec.inertia
                m.setParameters(spec.mass, 0.0, 0.0, 0.0, float(i[0]), float(i[1]),
                                float(i[2]), 0.0, 0.0, 0.0)
                body.setGravityMode(bool(spec.gravity))
            body.setMass(m)
            bpose = frames[gi] * spec.com
            body.setPosition(tuple(bpose.p))
            body.setQuaternion(_wxyz(bpose.q))
            for geom, _shape, _sub in self._attach_geoms(body, spec.shapes, g.com_inv, geoms):
                self._geom_group[geom] = g.self_collide
            g.native = body
            bodies.append(body)
        joints = []
        for gi, g in enumerate(art.groups):
            body = g.native
            if g.parent is None:
                if art.welded:
                    weld = ode.FixedJoint(world)
                    weld.attach(body, None)
                    weld.setFixed()
                    joints.append(weld)
                continue
            j, parent = g.joint, art.groups[g.parent].native
            jf = frames[gi] * g.frame
            js = art.joints[j.name]
            if j.type in ('revolute', 'continuous'):
                oj = ode.HingeJoint(world)
                oj.attach(body, parent)
                oj.setAnchor(tuple(float(x) for x in jf.p))
                oj.setAxis(tuple(float(x) for x in jf.rotate(j.axis)))
                if j.lower is not None and j.upper is not None:
                    if -math.pi <= j.lower and j.upper <= math.pi:
                        oj.setParam(ode.ParamLoStop, j.lower)
                        oj.setParam(ode.ParamHiStop, j.upper)
                    else:
                        log.warning('model %r joint %r: limits [%g, %g] reach beyond +-pi, '
                                    'where ODE hinge stops do not work: not enforced in ODE',
                                    rec.name, j.name, j.lower, j.upper)
                self._hinges.append(js)
            elif j.type == 'prismatic':
                oj = ode.SliderJoint(world)
                oj.attach(body, parent)
                oj.setAxis(tuple(float(x) for x in jf.rotate(j.axis)))
                if j.lower is not None and j.upper is not None:
                    oj.setParam(ode.ParamLoStop, j.lower)
                    oj.setParam(ode.ParamHiStop, j.upper)
            else:
                oj = ode.FixedJoint(world)
                oj.attach(body, parent)
                oj.setFixed()
            js.native = oj
            joints.append(oj)
            if js.movable:
                self._apply_friction(rec, js)
        rec.native = {'body': bodies[0], 'bodies': bodies, 'geoms': geoms, 'joints': joints,
                      'weld': weld, 'weld_at': None}
        if weld is not None:       # where the weld holds the root body (see _root_at)
            rec.native['weld_at'] = bodies[0].getPosition() + bodies[0].getQuaternion()
        for geom, _, _ in geoms:
            self._geom_model[geom] = rec.name
            self._seq_next += 1
            self._geom_seq[geom] = self._seq_next
        self._n_art += 1
        self._dirty = True

    def _apply_friction(self, rec, js):
        js.native.setParam(ode.ParamVel, 0.0)
        self._set_motor(rec, js, js.friction)

    def _set_motor(self, rec, js, fmax):
        js.native.setParam(PARAM_FMAX, float(fmax))

    def _group_pose(self, rec, gi):
        b = rec.art.groups[gi].native
        w, x, y, z = b.getQuaternion()
        return Pose(b.getPosition(), (x, y, z, w), normalize=False)

    def _group_twist(self, rec, gi):
        b = rec.art.groups[gi].native
        return np.array(b.getLinearVel()), np.array(b.getAngularVel())

    @staticmethod
    def _unwrap(js, raw):
        d = raw - js.last_raw
        if d > math.pi:
            js.turns -= 1
        elif d < -math.pi:
            js.turns += 1
        js.last_raw = raw
        return raw + TWO_PI * js.turns

    def _joint_pos_vel(self, rec, js):
        oj = js.native
        if js.joint.type == 'prismatic':
            return oj.getPosition(), oj.getPositionRate()
        return self._unwrap(js, oj.getAngle()), oj.getAngleRate()

    def _joint_pos_vels(self, rec, jss):
        unwrap = self._unwrap
        out = []
        for js in jss:
            oj = js.native
            if not js.movable:
                out.append((0.0, 0.0))
            elif js.joint.type == 'prismatic':
                out.append((oj.getPosition(), oj.getPositionRate()))
            else:
                out.append((unwrap(js, oj.getAngle()), oj.getAngleRate()))
        return out

    def _set_joint_velocity(self, rec, js, dv):
        """Add ``dv`` to a joint's velocity: the child group and its subtree get the
        rigid velocity field of that joint motion."""
        art = rec.art
        g = art.groups[js.group]
        frame = self._group_pose(rec, js.group) * g.com_inv * g.frame
        axis = frame.rotate(js.joint.axis)
        anchor = frame.p
        sub = {js.group}
        for gi, grp in enumerate(art.groups):
            if grp.parent in sub:
                sub.add(gi)
        for gi in sorted(sub):
            b = art.groups[gi].native
            lin, ang = np.array(b.getLinearVel()), np.array(b.getAngularVel())
            if js.joint.type == 'prismatic':
                lin = lin + axis * dv
            else:
                w = axis * dv
                ang = ang + w
                lin = lin + np.cross(w, np.array(b.getPosition()) - anchor)
            b.setLinearVel(tuple(float(x) for x in lin))
            b.setAngularVel(tuple(float(x) for x in ang))
            b.enable()

    def _joint_vel(self, rec, js):
        if js.joint.type == 'prismatic':
            return js.native.getPositionRate()
        return js.native.getAngleRate()

    def _joint_force(self, rec, js, effort):
        if js.joint.type == 'prismatic':
            js.native.addForce(float(effort))
        else:
            js.native.addTorque(float(effort))

    def _set_joint_positions(self, rec, positions):
        art = rec.art
        native = rec.native
        fk = native.get('fk_of')
        if fk is None:            # per model: its body-pose constants and its hinges
            fk = native['fk_of'] = (BodyPoses(art), [
                (js.name, js) for js in art.moving if js.joint.type != 'prismatic'])
        body_poses, hinges = fk
        b0 = art.groups[0].native
        # a welded root goes back where it was welded (quickStep's weld is soft: it wanders
        # ~1e-6 m per step under a moving arm, and setting it where it is would keep that)
        root = native['weld_at'] or b0.getPosition() + b0.getQuaternion()
        get = positions.get
        q = tuple([get(jn, 0.0) for jn in art.order])
        cache = native.get('fk')
        if cache is not None and cache[1] == q and (cache[0] is root or max(
                abs(a - b) for a, b in zip(cache[0], root)) < FK_CACHE_TOLERANCE):
            poses = cache[2]          # a held pose: the same command as the last set
        else:
            w, x, y, z = root[3:]
            poses = body_poses(root[:3], (x, y, z, w), positions)
            native['fk'] = (root, q, poses)
        zero = (0.0, 0.0, 0.0)
        for g, (bp, bq) in zip(art.groups, poses):
            # (no enable(): a live model's bodies are never disabled, auto-disable is off)
            b = g.native
            b.setPosition(bp)
            b.setQuaternion(bq)
            b.setLinearVel(zero)
            b.setAngularVel(zero)
        if native['weld'] is not None:
            native['weld'].setFixed()
        for jn, js in hinges:
            raw = js.native.getAngle()
            js.turns = round((get(jn, raw) - raw) / TWO_PI)
            js.last_raw = raw
        if native['geoms']:
            self._dirty = True    # new contacts (a model without collisions changes none)

    # ---- the link attacher (sim_world.physics.attachments) -----------------------------------
    @staticmethod
    def _link_body(rec, link):
        """The ODE body a link moves with (None: a static model, i.e. the world)."""
        if rec.static:
            return None
        if rec.art is None:
            return rec.native['body']
        return rec.art.groups[rec.art.link_group[link][0]].native

    def _fix(self, att, rec1, rec2):
        b1, b2 = self._link_body(rec1, att.link1), self._link_body(rec2, att.link2)
        j = ode.FixedJoint(self._world)
        if b1 is None or b2 is None:
            j.attach(b1 or b2, None)
        else:
            j.attach(b1, b2)
        j.setFixed()
        for b in (b1, b2):
            if b is not None:
                b.enable()
        att.native = j
        self._n_attached += 1
        self._dirty = True

    def _unfix(self, att):
        if att.native is not None:
            att.native.attach(None, None)
            att.native = None
            self._n_attached -= 1
        self._dirty = True

    # ---- building ----------------------------------------------------------------------
    def _attach_geoms(self, body, shapes, com_inv, geoms):
        """Makes each shape's geoms on body, offset from the body's centre of mass (com_inv:
        the inverse of the com pose in the body's link frame); appends (geom, shape, sub) to
        geoms and returns the ones made here."""
        made = []
        for shape in shapes:
            for geom, sub in self._make_geoms(shape, self._dyn_space):
                geom.setBody(body)
                off = com_inv * shape.pose
                if sub is not None:
                    off = off * sub
                geom.setOffsetPosition(tuple(off.p))
                geom.setOffsetQuaternion(_wxyz(off.q))
                made.append((geom, shape, sub))
        geoms.extend(made)
        return made

    def _make_geoms(self, shape, space):
        """[(geom, offset Pose in the shape's frame)] for one collision shape."""
        g = shape.geometry
        if g.kind == 'box':
            return [(ode.GeomBox(space, tuple(float(x) for x in g.size)), None)]
        if g.kind == 'sphere':
            return [(ode.GeomSphere(space, g.radius), None)]
        if g.kind == 'cylinder':
            return [(ode.GeomCylinder(space, g.radius, g.length), None)]
        if g.kind == 'mesh':
            # Debian's pyode has no trimesh support: boxes from a voxelisation
            verts, faces = shape.mesh
            key = id(shape.mesh)
            if key not in self._mesh_boxes:
                self._mesh_boxes[key] = (shape.mesh, mesh_boxes(verts, faces))
            return [(ode.GeomBox(space, tuple(float(x) for x in size)), Pose(centre))
                    for centre, size in self._mesh_boxes[key][1]]
        raise AssertionError(g.kind)

    def _add(self, rec, pose):
        spec = rec.spec
        geoms = []
        if spec.static:
            for shape in spec.shapes:
                if shape.geometry.kind == 'plane':
                    geom = ode.GeomPlane(None, (0.0, 0.0, 1.0), 0.0)
                    self._planes.append([geom, None, 0.0])
                    geoms.append((geom, shape, None))
                else:
                    for geom, off in self._make_geoms(shape, self._static_space):
                        geoms.append((geom, shape, off))
            rec.native = {'geoms': geoms}
            self._place_static(rec, pose)
        else:
            body = ode.Body(self._world)
            m = ode.Mass()
            i = spec.inertia
            m.setParameters(spec.mass, 0.0, 0.0, 0.0, float(i[0]), float(i[1]), float(i[2]),
                            0.0, 0.0, 0.0)
            body.setMass(m)
            body.setGravityMode(bool(spec.gravity))
            bpose = pose * spec.com
            body.setPosition(tuple(bpose.p))
            body.setQuaternion(_wxyz(bpose.q))
            self._attach_geoms(body, spec.shapes, rec.com_inv, geoms)
            rec.native = {'body': body, 'geoms': geoms}
        for geom, _, _ in geoms:
            self._geom_model[geom] = rec.name
            self._seq_next += 1
            self._geom_seq[geom] = self._seq_next
        self._dirty = True

    def _remove(self, rec):
        self._clear_contacts()
        for geom, shape, _ in rec.native['geoms']:
            self._geom_model.pop(geom, None)
            self._geom_seq.pop(geom, None)
            if shape.geometry.kind == 'plane':
                self._planes = [p for p in self._planes if p[0] is not geom]
            else:
                space = geom.getSpace()
                if space is not None:
                    space.remove(geom)
            if not rec.static:
                geom.setBody(None)
        for j in rec.native.get('joints', ()):
            j.attach(None, None)
        if rec.art is not None:
            self._n_art -= 1
            self._hinges = [js for js in self._hinges if js not in rec.art.joints.values()]
            for geom, _, _ in rec.native['geoms']:
                self._geom_group.pop(geom, None)
        for body in rec.native.get('bodies', [rec.native.get('body')]):
            if body is not None:
                body.disable()
        rec.native = None
        self._touching.discard(rec.name)
        self._dirty = True

    def _place_static(self, rec, pose):
        for geom, shape, sub in rec.native['geoms']:
            wp = pose * shape.pose
            if sub is not None:
                wp = wp * sub
            if shape.geometry.kind == 'plane':
                n = wp.rotate(shape.geometry.normal / np.linalg.norm(shape.geometry.normal))
                d = float(np.dot(n, wp.p))
                geom.setParams(tuple(float(x) for x in n), d)
                for entry in self._planes:
                    if entry[0] is geom:
                        entry[1], entry[2] = n, d
            else:
                geom.setPosition(tuple(wp.p))
                geom.setQuaternion(_wxyz(wp.q))
        self._dirty = True

    # ---- state -------------------------------------------------------------------------
    def _body_pose(self, rec):
        b = rec.native['body']
        w, x, y, z = b.getQuaternion()
        return Pose(b.getPosition(), (x, y, z, w), normalize=False)

    def _set_body_pose(self, rec, pose):
        if rec.art is not None:
            delta = pose * self._body_pose(rec).inverse()
            for b in rec.native['bodies']:
                w, x, y, z = b.getQuaternion()
                bp = delta * Pose(b.getPosition(), (x, y, z, w), normalize=False)
                b.setPosition(tuple(bp.p))
                b.setQuaternion(_wxyz(bp.q))
                b.enable()
            if rec.native['weld'] is not None:
                rec.native['weld'].setFixed()
                b0 = rec.native['body']
                rec.native['weld_at'] = b0.getPosition() + b0.getQuaternion()
            self._dirty = True
            return
        b = rec.native['body']
        b.setPosition(tuple(pose.p))
        b.setQuaternion(_wxyz(pose.q))
        b.enable()
        self._dirty = True

    def _body_twist(self, rec):
        b = rec.native['body']
        return np.array(b.getLinearVel()), np.array(b.getAngularVel())

    def _set_body_twist(self, rec, lin, ang):
        if rec.art is not None:
            c0 = np.array(rec.native['body'].getPosition())
            for b in rec.native['bodies']:
                r = np.array(b.getPosition()) - c0
                b.setLinearVel(tuple(float(x) for x in lin + np.cross(ang, r)))
                b.setAngularVel(tuple(float(x) for x in ang))
                b.enable()
            return
        b = rec.native['body']
        b.setLinearVel(tuple(float(x) for x in lin))
        b.setAngularVel(tuple(float(x) for x in ang))
        b.enable()

    def _set_gravity(self, g):
        self._world.setGravity(tuple(float(x) for x in g))

    #: ODEPhysics fields the world sets once and keeps (their values, as the solver runs)
    FIXED_SOLVER = {'auto_disable_bodies': False, 'sor_pgs_precon_iters': 0,
                    'sor_pgs_w': 1.0, 'sor_pgs_rms_error_tol': 0.0,
                    'max_contacts': MAX_CONTACTS}
    #: the ones /gazebo/set_physics_properties may change: (setter, check, what it must be)
    SETTABLE_SOLVER = {
        'sor_pgs_iters': ('setQuickStepNumIterations', lambda v: v >= 1, 'an integer >= 1'),
        'erp': ('setERP', lambda v: 0.0 <= v <= 1.0, 'in [0, 1]'),
        'cfm': ('setCFM', lambda v: v >= 0.0, '>= 0'),
        'contact_surface_layer': ('setContactSurfaceLayer', lambda v: v >= 0.0, '>= 0 m'),
        'contact_max_correcting_vel': ('setContactMaxCorrectingVel', lambda v: v >= 0.0,
                                       '>= 0 m/s'),
    }

    def solver_config(self):
        w = self._world
        out = dict(self.FIXED_SOLVER)
        out.update(sor_pgs_iters=int(w.getQuickStepNumIterations()), erp=float(w.getERP()),
                   cfm=float(w.getCFM()),
                   contact_surface_layer=float(w.getContactSurfaceLayer()),
                   contact_max_correcting_vel=float(w.getContactMaxCorrectingVel()))
        return out

    def set_solver_config(self, **fields):
        import math
        for k, v in fields.items():            # every field checked before any is set
            if k in self.FIXED_SOLVER:
                if v != self.FIXED_SOLVER[k]:
                    raise ValueError('ode_config.%s is fixed at %r in this world, got %r'
                                     % (k, self.FIXED_SOLVER[k], v))
            elif k in self.SETTABLE_SOLVER:
                _setter, ok, must = self.SETTABLE_SOLVER[k]
                if not (math.isfinite(v) and ok(v)):
                    raise ValueError('ode_config.%s must be %s, got %r' % (k, must, v))
            else:
                raise ValueError('ode_config has no field %r' % k)
        for k, v in fields.items():
            if k in self.SETTABLE_SOLVER:
                getattr(self._world, self.SETTABLE_SOLVER[k][0])(
                    int(v) if k == 'sor_pgs_iters' else float(v))

    # ---- contacts and stepping -------------------------------------------------------------
    def _near(self, _arg, g1, g2):
        # ODE's hash space reports pairs in an order that depends on memory addresses:
        # collect them and make the contact joints in creation order (see _join), so the
        # same world gives the same solver input, bit for bit, in every run
        seq = self._geom_seq
        if g1 in self._geom_group and g2 in self._geom_group:
            gm = self._geom_model
            if gm.get(g1) == gm.get(g2):
                # links of one model: only when both groups self-collide, never across a joint
                if not (self._geom_group[g1] and self._geom_group[g2]):
                    return
                b1, b2 = g1.getBody(), g2.getBody()
                if b1 is b2 or ode.areConnected(b1, b2):
                    return
        if self._n_attached:
            # bodies held together by the link attacher do not collide
            b1, b2 = g1.getBody(), g2.getBody()
            if b1 is not None and b2 is not None and ode.areConnected(b1, b2):
                return
        if seq.get(g1, 0) > seq.get(g2, 0):
            g1, g2 = g2, g1
        contacts = ode.collide(g1, g2)
        if contacts:
            self._pending.append((seq.get(g1, 0), seq.get(g2, 0), g1, g2, contacts))

    def _join(self):
        world, group, mode = self._world, self._contacts, self._contact_mode
        gm = self._geom_model
        self._pending.sort(key=lambda e: (e[0], e[1]))
        for _, _, g1, g2, contacts in self._pending:
            b1, b2 = g1.getBody(), g2.getBody()
            for c in contacts[:MAX_CONTACTS]:
                c.setMode(mode)
                c.setMu(FRICTION)
                j = ode.ContactJoint(world, group, c)
                j.attach(b1, b2)
            self._n_contacts += 1
            self._touching.add(gm.get(g1))
            self._touching.add(gm.get(g2))
        self._pending = []

    def _clear_contacts(self):
        if self._n_contacts:
            self._contacts.empty()
            self._n_contacts = 0

    def _collide(self):
        self._clear_contacts()
        if self._touching:
            self._touching.clear()
        dyn = self._dyn_space
        if dyn.getNumGeoms():
            ode.collide2(dyn, self._static_space, None, self._near)
            if dyn.getNumGeoms() > 1:
                dyn.collide(None, self._near)
            if self._planes:
                x0, x1, y0, y1, z0, z1 = dyn.getAABB()
                for geom, n, d in self._planes:
                    # lowest corner of the moving geoms' bounding box along the normal
                    low = ((x0 if n[0] > 0 else x1) * n[0] + (y0 if n[1] > 0 else y1) * n[1]
                           + (z0 if n[2] > 0 else z1) * n[2])
                    if low <= d:
                        ode.collide2(dyn, geom, None, self._near)
            self._join()
        self._dirty = False

    def step(self, n=1):
        world, dt = self._world, self.step_size
        if _RAND_SET is not None:
            _RAND_SET(self._rand_state)
        for _ in range(int(n)):
            if self._dirty:
                self._collide()
            if self._wrenches:
                for rec, f, t in self._take_wrenches():
                    b = rec.native['body']
                    b.addForce(tuple(float(x) for x in f))
                    b.addTorque(tuple(float(x) for x in t))
                    b.enable()
            if self._n_art:
                self._joint_step()
            world.quickStep(dt)
            if self._hinges:
                unwrap = self._unwrap
                for js in self._hinges:
                    unwrap(js, js.native.getAngle())
            self._collide()
        if _RAND_GET is not None:
            self._rand_state = _RAND_GET()

    def in_contact(self, name):
        self._get(name)
        if self._dirty:
            self._collide()
        return name in self._touching

    def contacts(self, name, link=None):
        """Contact points of the model's (or one link's) geoms with every other model's,
        from ``ode.collide`` on the current state (see the base class)."""
        rec = self._check_link(name, link)
        if self._dirty:            # a teleport since the last pass: fresh bounding boxes
            self._collide()
        gm = self._geom_model
        links = dict((g, shape.link) for g, shape, _ in rec.native['geoms'])
        others = {}
        for r in self._models.values():
            if r.name != name and r.native is not None:
                for g, shape, _ in r.native['geoms']:
                    others[g] = shape.link
        out = []

        def near(_arg, g1, g2):
            mine, other = (g1, g2) if g1 in links else (g2, g1)
            if other not in others or mine not in links:
                return
            for c in ode.collide(mine, other)[:MAX_CONTACTS]:
                pos, normal, depth, cg1, _ = c.getContactGeomParams()
                n = np.asarray(normal, float)
                if cg1 is not mine:      # ODE: the normal points into the first geom
                    n = -n
                out.append(Contact(name, links[mine], gm.get(other), others[other], pos, n,
                                   max(0.0, depth)))

        for g, shape, _ in rec.native['geoms']:
            if link is not None and shape.link != link:
                continue
            if shape.geometry.kind == 'plane':
                ode.collide2(g, self._dyn_space, None, near)
                continue
            ode.collide2(g, self._dyn_space, None, near)
            ode.collide2(g, self._static_space, None, near)
            for plane, _, _ in self._planes:
                near(None, g, plane)
        return out

    def close(self):
        for name in list(self._models):
            self.remove_model(name)


