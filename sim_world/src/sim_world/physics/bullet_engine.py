"""Bullet backend (pybullet from PyPI), chosen with ``~physics_engine:=bullet``.

Each engine owns one pybullet DIRECT client (no GUI, no shared state between engines).
Moving bodies are single rigid bodies (``useMaximalCoordinates``) whose base frame is the
centre of mass with principal axes, mass and principal inertia set explicitly, pybullet's
default linear/angular damping set to zero, sleeping disabled (ODE and Gazebo do not put
bodies to sleep either), friction 1, restitution 0. Their shapes form one compound
(``createCollisionShapeArray``; a mesh there goes through a temporary .obj file holding
its convex hull). Static models get one fixed body per collision shape; static meshes are
exact concave triangle meshes. pybullet has one gravity for all bodies, so per-body
gravity is a force at the centre of mass applied before every step to the smaller group:
-m*g on floating bodies (gravity off), or, when most moving bodies float (the default
world: phone and flycam), zero world gravity and +m*g on the others.

``in_contact`` runs ``performCollisionDetection`` on the current state once per step
(only when asked) and counts contact points with ``contactDistance <= 0``: Bullet also
reports points that are merely close (up to its contact threshold).
"""
import os
import shutil
import tempfile

import numpy as np
import pybullet as p

from .articulation import forward
from .base import FRICTION, Contact, PhysicsEngine
from ..model import ModelError
from ..transforms import Pose

__all__ = ['BulletEngine']


def _gravity(rec):
    if rec.art is None:
        return rec.spec.gravity
    return any(g.spec.gravity for g in rec.art.groups if not g.anchor)


def _xyzw(q):
    return [float(q[0]), float(q[1]), float(q[2]), float(q[3])]


class BulletEngine(PhysicsEngine):
    name = 'bullet'

    def __init__(self, step_size=0.001, gravity=(0.0, 0.0, -9.81)):
        PhysicsEngine.__init__(self, step_size, gravity)
        self._c = p.connect(p.DIRECT)
        if self._c < 0:
            raise RuntimeError('pybullet: cannot create a DIRECT physics client')
        c = self._c
        p.setGravity(*[float(x) for x in self.gravity], physicsClientId=c)
        p.setTimeStep(self.step_size, physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.step_size, numSubSteps=0,
                                    deterministicOverlappingPairs=1, physicsClientId=c)
        self._forced = []            # [(body id, [fx, fy, fz])] applied before each step
        self._contacts_valid = False
        self._tmpdir = None
        self._n_art = 0

    # ---- building ----------------------------------------------------------------------
    def _hull_obj(self, verts):
        """Path of a temporary .obj holding the convex hull of ``verts``."""
        import trimesh
        if self._tmpdir is None:
            self._tmpdir = tempfile.mkdtemp(prefix='simvid_bullet_')
        hull = trimesh.Trimesh(vertices=verts).convex_hull
        path = os.path.join(self._tmpdir, 'hull%d.obj' % len(os.listdir(self._tmpdir)))
        hull.export(path)
        return path

    def _single_shape(self, shape, pose, static):
        g, c = shape.geometry, self._c
        kw = dict(collisionFramePosition=[float(x) for x in pose.p],
                  collisionFrameOrientation=_xyzw(pose.q), physicsClientId=c)
        if g.kind == 'box':
            return p.createCollisionShape(p.GEOM_BOX, halfExtents=[float(x) / 2 for x in g.size],
                                          **kw)
        if g.kind == 'sphere':
            return p.createCollisionShape(p.GEOM_SPHERE, radius=g.radius, **kw)
        if g.kind == 'cylinder':
            return p.createCollisionShape(p.GEOM_CYLINDER, radius=g.radius, height=g.length,
                                          **kw)
        if g.kind == 'plane':
            n = g.normal / np.linalg.norm(g.normal)
            return p.createCollisionShape(p.GEOM_PLANE, planeNormal=[float(x) for x in n], **kw)
        verts, faces = shape.mesh
        if static:
            return p.createCollisionShape(p.GEOM_MESH, vertices=verts.tolist(),
                                          indices=[int(i) for i in faces.reshape(-1)], **kw)
        return p.createCollisionShape(p.GEOM_MESH, vertices=verts.tolist(), **kw)

    def _compound(self, shapes, poses):
        types, radii, halves, lengths, files, pos, orn = [], [], [], [], [], [], []
        for shape, pose in zip(shapes, poses):
            g = shape.geometry
            radius, half, length, fname = 0.0, [0.0, 0.0, 0.0], 0.0, ''
            if g.kind == 'box':
                types.append(p.GEOM_BOX)
                half = [float(x) / 2 for x in g.size]
            elif g.kind == 'sphere':
                types.append(p.GEOM_SPHERE)
                radius = g.radius
            elif g.kind == 'cylinder':
                types.append(p.GEOM_CYLINDER)
                radius, length = g.radius, g.length
            else:
                types.append(p.GEOM_MESH)
                fname = self._hull_obj(shape.mesh[0])
            radii.append(radius)
            halves.append(half)
            lengths.append(length)
            files.append(fname)
            pos.append([float(x) for x in pose.p])
            orn.append(_xyzw(pose.q))
        return p.createCollisionShapeArray(
            shapeTypes=types, radii=radii, halfExtents=halves, lengths=lengths,
            fileNames=files, meshScales=[[1.0, 1.0, 1.0]] * len(types),
            collisionFramePositions=pos, collisionFrameOrientations=orn,
            physicsClientId=self._c)

    def _dynamics(self, bid, **kw):
        p.changeDynamics(bid, -1, lateralFriction=FRICTION, restitution=0.0,
                         spinningFriction=0.0, rollingFriction=0.0,
                         physicsClientId=self._c, **kw)

    def _add(self, rec, pose):
        spec, c = rec.spec, self._c
        bodies = []
        try:
            if spec.static:
                for shape in spec.shapes:
                    sid = self._single_shape(shape, Pose(), True)
                    if sid < 0:
                        raise ModelError('model %r: Bullet refused collision %r of link %r'
                                         % (rec.name, shape.name, shape.link))
                    bid = p.createMultiBody(0.0, sid, useMaximalCoordinates=True,
                                            physicsClientId=c)
                    self._dynamics(bid)
                    bodies.append((bid, shape))
                rec.native = {'bodies': bodies}
                self._place_static(rec, pose)
            else:
                offs = [rec.com_inv * s.pose for s in spec.shapes]
                if not spec.shapes:
                    sid = -1
                elif len(spec.shapes) == 1:
                    sid = self._single_shape(spec.shapes[0], offs[0], False)
                else:
                    sid = self._compound(spec.shapes, offs)
                if spec.shapes and sid < 0:
                    raise ModelError('model %r: Bullet refused its collision shapes' % rec.name)
                bpose = pose * spec.com
                bid = p.createMultiBody(spec.mass, sid, -1, [float(x) for x in bpose.p],
                                        _xyzw(bpose.q), useMaximalCoordinates=True,
                                        physicsClientId=c)
                self._dynamics(bid, mass=spec.mass,
                               localInertiaDiagonal=[float(x) for x in spec.inertia],
                               linearDamping=0.0, angularDamping=0.0,
                               activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING)
                bodies.append((bid, None))
                rec.native = {'bodies': bodies, 'body': bid}
        except Exception:
            for bid, _ in bodies:
                p.removeBody(bid, physicsClientId=c)
            raise
        self._contacts_valid = False
        self._balance_gravity(extra=rec)

    # ---- articulated models: one multibody (Featherstone), sim_world.physics.articulation ----
    def _shape_of(self, shapes, poses):
        if not shapes:
            return -1
        if len(shapes) == 1:
            return self._single_shape(shapes[0], poses[0], False)
        return self._compound(shapes, poses)

    def _add_articulated(self, rec, pose):
        art, c = rec.art, self._c
        g0 = art.groups[0]
        base_sid = self._shape_of(g0.spec.shapes, [g0.com_inv * sh.pose for sh in g0.spec.shapes])
        fixed = art.welded
        masses, sids, poss, orns, ipos, iorn, parents, types, axes = ([] for _ in range(9))
        for gi, g in enumerate(art.groups[1:], 1):
            spec = g.spec
            parent = art.groups[g.parent]
            pframe = parent.spec.com if g.parent == 0 else parent.frame
            rel = pframe.inverse() * g.origin * g.frame
            inertial = g.frame.inverse() * spec.com
            masses.append(float(spec.mass))
            sids.append(self._shape_of(spec.shapes, [g.frame.inverse() * sh.pose
                                                     for sh in spec.shapes]))
            poss.append([float(x) for x in rel.p])
            orns.append(_xyzw(rel.q))
            ipos.append([float(x) for x in inertial.p])
            iorn.append(_xyzw(inertial.q))
            parents.append(g.parent)
            jt = g.joint.type
            types.append(p.JOINT_PRISMATIC if jt == 'prismatic' else
                         p.JOINT_FIXED if jt == 'fixed' else p.JOINT_REVOLUTE)
            axes.append([float(x) for x in g.joint.axis])
        flags = p.URDF_USE_SELF_COLLISION if sum(
            1 for g in art.groups if getattr(g, 'self_collide', False)) >= 2 else 0
        bpose = pose * g0.spec.com
        bid = p.createMultiBody(
            0.0 if fixed else float(g0.spec.mass), base_sid, -1, [float(x) for x in bpose.p],
            _xyzw(bpose.q), linkMasses=masses, linkCollisionShapeIndices=sids,
            linkVisualShapeIndices=[-1] * len(masses), linkPositions=poss,
            linkOrientations=orns, linkInertialFramePositions=ipos,
            linkInertialFrameOrientations=iorn, linkParentIndices=parents,
            linkJointTypes=types, linkJointAxis=axes, useMaximalCoordinates=False,
            flags=flags, physicsClientId=c)
        if bid < 0:
            raise ModelError('model %r: Bullet refused the articulated body' % rec.name)
        if not fixed:
            self._dynamics(bid, mass=float(g0.spec.mass),
                           localInertiaDiagonal=[float(x) for x in g0.spec.inertia],
                           linearDamping=0.0, angularDamping=0.0,
                           activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING)
        else:
            self._dynamics(bid, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING)
        for gi, g in enumerate(art.groups[1:], 1):
            li = gi - 1
            j = g.joint
            kw = {}
            if j.movable and j.lower is not None and j.upper is not None:
                kw = dict(jointLowerLimit=j.lower, jointUpperLimit=j.upper,
                          jointLimitForce=1e12)
            p.changeDynamics(bid, li, mass=float(g.spec.mass),
                             localInertiaDiagonal=[float(x) for x in g.spec.inertia],
                             linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                             lateralFriction=FRICTION, restitution=0.0, spinningFriction=0.0,
                             rollingFriction=0.0, physicsClientId=c, **kw)
            g.native = li
        g0.native = -1
        rec.native = {'bodies': [(bid, None)], 'body': bid}
        for js in art.joints.values():
            if js.movable:
                self._apply_friction(rec, js)
        self._n_art += 1
        self._contacts_valid = False
        self._balance_gravity(extra=rec)

    # ---- the link attacher (sim_world.physics.attachments) -----------------------------------
    def _link_handle(self, rec, link):
        """(body id, link index, world pose of its centre-of-mass frame) of the body a link
        of a moving model moves with."""
        if rec.art is None:
            return rec.native['body'], -1, self._body_pose(rec)
        gi = rec.art.link_group[link][0]
        return rec.native['body'], rec.art.groups[gi].native, self._group_pose(rec, gi)

    def _fix(self, att, rec1, rec2):
        """A link of an articulated model (a multibody) and a one-body model: a JOINT_FIXED
        constraint. Held by a static model: the held body's base gets mass 0 (pybullet's
        static body) until detached. Two one-body models or two articulated ones: refused
        (pybullet's fixed constraint between two free rigid bodies ignores the frames'
        orientations: it would turn the held body)."""
        c = self._c
        if rec1.static or rec2.static:
            rec, link = (rec2, att.link2) if rec1.static else (rec1, att.link1)
            if rec.art is not None and rec.art.link_group[link][0] != 0:
                raise ValueError('Bullet: link %r of model %r is not in its root body: only '
                                 'a root body can be held by a static model' % (link, rec.name))
            bid = rec.native['body']
            p.changeDynamics(bid, -1, mass=0.0, physicsClientId=c)
            p.resetBaseVelocity(bid, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=c)
            att.native = ('frozen', rec)
            self._contacts_valid = False
            return
        if (rec1.art is None) == (rec2.art is None):
            raise ValueError('Bullet holds a link of an articulated model and a one-body model '
                             'together (or either with a static model), not models %r and %r '
                             '(both %s): use the ode engine for that'
                             % (rec1.name, rec2.name, 'one body' if rec1.art is None
                                else 'articulated'))
        h1, h2 = self._link_handle(rec1, att.link1), self._link_handle(rec2, att.link2)
        if rec1.art is None:
            h1, h2 = h2, h1            # pybullet's parent: the multibody's link
        bid, li, frame = h1
        cb, cl, cpose = h2
        # the joint frame is the child's centre-of-mass frame (a parent-side frame with an
        # orientation was turned the wrong way by pybullet's multibody-rigid fixed constraint)
        par = frame.inverse() * cpose
        cid = p.createConstraint(bid, li, cb, cl, p.JOINT_FIXED, [0.0, 0.0, 0.0],
                                 [float(x) for x in par.p], [0.0, 0.0, 0.0], _xyzw(par.q),
                                 [0.0, 0.0, 0.0, 1.0], physicsClientId=c)
        p.changeConstraint(cid, maxForce=1e9, physicsClientId=c)
        pair = (bid, cb, li, cl)
        p.setCollisionFilterPair(bid, cb, li, cl, 0, physicsClientId=c)
        att.native = (cid, pair)
        self._contacts_valid = False

    def _unfix(self, att):
        if att.native is None:
            return
        c = self._c
        if att.native[0] == 'frozen':
            rec = att.native[1]
            if rec.native is not None:
                spec = rec.spec if rec.art is None else rec.art.groups[0].spec
                if not (rec.art is not None and rec.art.welded):
                    p.changeDynamics(rec.native['body'], -1, mass=float(spec.mass),
                                     localInertiaDiagonal=[float(x) for x in spec.inertia],
                                     physicsClientId=c)
        else:
            cid, pair = att.native
            p.removeConstraint(cid, physicsClientId=c)
            p.setCollisionFilterPair(pair[0], pair[1], pair[2], pair[3], 1, physicsClientId=c)
        att.native = None
        self._contacts_valid = False

    def _apply_friction(self, rec, js):
        # the default velocity motor of every joint, with the joint's friction as its force:
        # zero friction switches it off
        self._set_motor(rec, js, js.friction)

    def _set_motor(self, rec, js, fmax):
        p.setJointMotorControl2(rec.native['body'], rec.art.groups[js.group].native,
                                p.VELOCITY_CONTROL, targetVelocity=0.0,
                                force=float(fmax), physicsClientId=self._c)

    def _group_pose(self, rec, gi):
        if gi == 0:
            return self._body_pose(rec)
        # computeForwardKinematics: the cached link transforms lag one step behind the
        # joint positions
        st = p.getLinkState(rec.native['body'], gi - 1, computeForwardKinematics=1,
                            physicsClientId=self._c)
        return Pose(st[0], st[1], normalize=False)

    def _group_twist(self, rec, gi):
        if gi == 0:
            return self._body_twist(rec)
        st = p.getLinkState(rec.native['body'], gi - 1, computeLinkVelocity=1,
                            computeForwardKinematics=1, physicsClientId=self._c)
        return np.array(st[6]), np.array(st[7])

    def _joint_pos_vel(self, rec, js):
        st = p.getJointState(rec.native['body'], rec.art.groups[js.group].native,
                             physicsClientId=self._c)
        return st[0], st[1]

    def _joint_pos_vels(self, rec, jss):
        groups = rec.art.groups
        states = p.getJointStates(rec.native['body'], [groups[js.group].native for js in jss],
                                  physicsClientId=self._c)
        return [(st[0], st[1]) if js.movable else (0.0, 0.0) for js, st in zip(jss, states)]

    def _set_joint_velocity(self, rec, js, dv):
        bid, li = rec.native['body'], rec.art.groups[js.group].native
        q, v = p.getJointState(bid, li, physicsClientId=self._c)[:2]
        p.resetJointState(bid, li, q, v + dv, physicsClientId=self._c)

    def _joint_vel(self, rec, js):
        return p.getJointState(rec.native['body'], rec.art.groups[js.group].native,
                               physicsClientId=self._c)[1]

    def _joint_force(self, rec, js, effort):
        p.setJointMotorControl2(rec.native['body'], rec.art.groups[js.group].native,
                                p.TORQUE_CONTROL, force=float(effort), physicsClientId=self._c)

    def _set_joint_positions(self, rec, positions):
        bid, c = rec.native['body'], self._c
        art = rec.art
        index = rec.native.get('moving_index')
        if index is None:         # the multibody's link index of each movable joint
            index = rec.native['moving_index'] = [art.groups[js.group].native
                                                  for js in art.moving]
            rec.native['zero_velocities'] = [[0.0]] * len(index)
        get = positions.get
        # one reset for all (the same joint values as one resetJointState each, with one
        # forward kinematics pass of the multibody instead of one per joint)
        if index:
            p.resetJointStatesMultiDof(bid, index, [[float(get(js.name, 0.0))]
                                                    for js in art.moving],
                                       rec.native['zero_velocities'], physicsClientId=c)
        p.resetBaseVelocity(bid, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=c)
        self._contacts_valid = False

    def _remove(self, rec):
        if rec.art is not None:
            self._n_art -= 1
        for bid, _ in rec.native['bodies']:
            p.removeBody(bid, physicsClientId=self._c)
        rec.native = None
        self._contacts_valid = False
        self._balance_gravity(skip=rec)

    def _place_static(self, rec, pose):
        for bid, shape in rec.native['bodies']:
            wp = pose * shape.pose
            p.resetBasePositionAndOrientation(bid, [float(x) for x in wp.p], _xyzw(wp.q),
                                              physicsClientId=self._c)
        self._contacts_valid = False

    # ---- state -------------------------------------------------------------------------
    def _body_pose(self, rec):
        pos, orn = p.getBasePositionAndOrientation(rec.native['body'], physicsClientId=self._c)
        return Pose(pos, orn, normalize=False)

    def _set_body_pose(self, rec, pose):
        bid, c = rec.native['body'], self._c
        lin, ang = p.getBaseVelocity(bid, physicsClientId=c)
        p.resetBasePositionAndOrientation(bid, [float(x) for x in pose.p], _xyzw(pose.q),
                                          physicsClientId=c)
        p.resetBaseVelocity(bid, lin, ang, physicsClientId=c)
        self._contacts_valid = False

    def _body_twist(self, rec):
        lin, ang = p.getBaseVelocity(rec.native['body'], physicsClientId=self._c)
        return np.array(lin), np.array(ang)

    def _set_body_twist(self, rec, lin, ang):
        p.resetBaseVelocity(rec.native['body'], [float(x) for x in lin],
                            [float(x) for x in ang], physicsClientId=self._c)

    def _set_gravity(self, g):
        self._balance_gravity()

    def _balance_gravity(self, extra=None, skip=None):
        """pybullet has one gravity for all bodies. Whichever group of moving bodies is
        smaller gets a per-step force: floating bodies get -m*g while the world has gravity,
        or, when most moving bodies float (the default world: phone and flycam), the world
        gravity is zero and the bodies with gravity get +m*g."""
        recs = [r for r in self._models.values() if r is not skip]
        if extra is not None and extra not in recs:
            recs.append(extra)
        moving = [r for r in recs if not r.static and r.native is not None]
        floating = [r for r in moving if not _gravity(r)]
        falling = [r for r in moving if _gravity(r)]
        g = [float(x) for x in self.gravity]
        if len(floating) > len(falling):
            world_g, forced, sign = [0.0, 0.0, 0.0], falling, 1.0
        else:
            world_g, forced, sign = g, floating, -1.0
        p.setGravity(*world_g, physicsClientId=self._c)
        out = []
        for r in forced:
            if r.art is None:
                out.append((r.native['body'], -1, [sign * r.spec.mass * x for x in g]))
                continue
            for gi, grp in enumerate(r.art.groups):
                if grp.anchor or (gi == 0 and r.art.welded):
                    continue
                out.append((r.native['body'], gi - 1, [sign * grp.spec.mass * x for x in g]))
        self._forced = out

    # ---- stepping ------------------------------------------------------------------------
    def step(self, n=1):
        c = self._c
        step = p.stepSimulation
        forces = self._forced
        if forces or self._wrenches:
            # (joint efforts and damping of articulated models: _joint_step before each step)
            getpose, force, frame = p.getBasePositionAndOrientation, p.applyExternalForce, \
                p.WORLD_FRAME
            for _ in range(int(n)):
                for bid, li, f in forces:
                    force(bid, li, f, getpose(bid, physicsClientId=c)[0] if li < 0 else
                          p.getLinkState(bid, li, physicsClientId=c)[0], frame,
                          physicsClientId=c)
                if self._n_art:
                    self._joint_step()
                if self._wrenches:
                    for rec, f, t in self._take_wrenches():
                        bid = rec.native['body']    # native frame = centre of mass
                        force(bid, -1, [float(x) for x in f],
                              getpose(bid, physicsClientId=c)[0], frame, physicsClientId=c)
                        if np.any(t):
                            p.applyExternalTorque(bid, -1, [float(x) for x in t], frame,
                                                  physicsClientId=c)
                step(physicsClientId=c)
        elif self._n_art:
            for _ in range(int(n)):
                self._joint_step()
                step(physicsClientId=c)
        else:
            for _ in range(int(n)):
                step(physicsClientId=c)
        self._contacts_valid = False

    def in_contact(self, name):
        rec = self._get(name)
        c = self._c
        if not self._contacts_valid:
            p.performCollisionDetection(physicsClientId=c)
            self._contacts_valid = True
        for bid, _ in rec.native['bodies']:
            for pt in p.getContactPoints(bodyA=bid, physicsClientId=c):
                if pt[8] <= 0.0:
                    return True
        return False

    def contacts(self, name, link=None):
        """Contact points (contactDistance <= 0) of the model with every other body, from
        ``getContactPoints`` after one collision detection pass on the current state. A
        moving model is one compound body and pybullet does not say which child shape a
        point belongs to, so each point goes to the link whose shape surface is nearest to
        it (exact for touching boxes: a display box on a phone body)."""
        rec = self._check_link(name, link)
        c = self._c
        if not self._contacts_valid:
            p.performCollisionDetection(physicsClientId=c)
            self._contacts_valid = True
        owner = {}
        for r in self._models.values():
            if r.native is not None:
                for bid, shape in r.native['bodies']:
                    owner[bid] = (r, shape)
        out = []
        for bid, shape in rec.native['bodies']:
            for pt in p.getContactPoints(bodyA=bid, physicsClientId=c):
                if pt[8] > 0.0 or pt[2] not in owner:
                    continue
                other, oshape = owner[pt[2]]
                if other is rec:
                    continue
                mine = shape.link if shape is not None else self._nearest_link(rec, pt[5])
                if link is not None and mine != link:
                    continue
                olink = oshape.link if oshape is not None else self._nearest_link(other, pt[6])
                out.append(Contact(name, mine, other.name, olink, pt[5], pt[7], -pt[8]))
        return out

    def _nearest_link(self, rec, point):
        """The link of ``rec`` whose collision shape surface is nearest to a world point."""
        local = self.model_pose(rec.name).inverse() * np.asarray(point, float) \
            if not rec.static else rec.pose.inverse() * np.asarray(point, float)
        best, best_d = None, np.inf
        for shape in rec.spec.shapes:
            q = shape.pose.inverse() * local
            g = shape.geometry
            if g.kind == 'box':
                d = np.abs(q) - np.asarray(g.size, float) / 2
                dist = abs(np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0))
            elif g.kind == 'sphere':
                dist = abs(np.linalg.norm(q) - g.radius)
            elif g.kind == 'cylinder':
                d = np.array([np.hypot(q[0], q[1]) - g.radius, abs(q[2]) - g.length / 2])
                dist = abs(np.linalg.norm(np.maximum(d, 0)) + min(d.max(), 0.0))
            else:
                dist = 0.0 if g.kind == 'plane' else float(np.linalg.norm(q)) * 1e-3
            if dist < best_d:
                best, best_d = shape.link, dist
        return best

    def close(self):
        if self._c is not None and self._c >= 0:
            try:
                p.disconnect(physicsClientId=self._c)
            except p.error:
                pass
            self._c = None
        if self._tmpdir:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass
