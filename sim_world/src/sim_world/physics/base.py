"""The one interface every physics backend implements, and what the backends share.

Interface (``PhysicsEngine``; ``sim_world.world.World`` uses nothing else)::

    engine = make_engine('ode' | 'bullet', step_size=0.001, gravity=(0, 0, -9.81))
    engine.name                      # 'ode' or 'bullet'
    engine.step_size                 # seconds, fixed for the engine's life
    engine.add_model(model)          # sim_world.model.Model; model.pose = world pose of its
                                     # root link; model.static -> immovable shapes only
    engine.remove_model(name)        # KeyError if unknown
    engine.has_model(name)
    engine.model_names()             # names in the order they were added
    engine.model_pose(name)          # Pose: world pose of the root link
    engine.set_model_pose(name, pose)    # teleport; the twist is kept
    engine.model_twist(name)         # (lin, ang) numpy arrays, world frame, of the root
                                     # link origin (not of the centre of mass)
    engine.set_model_twist(name, lin, ang)
    engine.link_poses(name)          # {link name: Pose in the world}
    engine.in_contact(name)          # True if the model touches something in its current
                                     # state (penetration depth >= 0), i.e. in the contact
                                     # pass that follows the last step
    engine.contacts(name, link=None) # [Contact] of the model's (or one link's) collision
                                     # shapes with anything else, in the current state:
                                     # .model .link (of name), .other_model .other_link,
                                     # .position (3,) world, .normal (3,) world, pointing
                                     # from the other body into this one (moving this one
                                     # along it separates them), .depth (m, >= 0)
    engine.apply_wrench(name, force, torque=None, steps=1, key=None)
                                     # world-frame force (N, at the centre of mass) and
                                     # torque (N m) during the next ``steps`` steps (None:
                                     # every step until replaced); (n, 3) rows: one per
                                     # coming step; a call with the same key replaces the
                                     # last one, different keys add up
    engine.clear_wrench(name, key=None)  # drop a model's wrenches (of one key)
    engine.step(n=1)                 # n fixed steps of step_size
    engine.set_gravity(g)
    engine.close()                   # frees the native world (Bullet's client)

Bad input raises a ``ValueError`` subclass whose message names the model and the problem:
``sim_world.model.ModelError`` (zero/negative/NaN mass, inertia that is not positive
definite, a plane on a moving model, an unreadable mesh, a duplicate name, no links ...)
or ``sim_world.transforms.InvalidPose`` (NaN/inf position, quaternion that cannot be
normalised). Nothing is added to the engine when ``add_model`` raises.

Rigid bodies. Every link of a model becomes part of ONE rigid body, as Gazebo does when it
converts a URDF with fixed joints: the masses add up, the centre of mass is the
mass-weighted mean, the inertia tensors are rotated into one frame and moved to the common
centre of mass with the parallel-axis theorem, and every collision shape is attached with
its offset. Joints other than ``fixed`` are lumped too (at their zero position); each
such joint is named in one warning, because articulated joints are not simulated yet.
The body's native frame is the centre of mass with principal inertia axes (ODE requires
the COM at the body origin, Bullet a diagonal inertia); the engine keeps the link-frame to
COM offset, so the interface always speaks link-frame poses and link-origin twists.
A model with no mass (no link has an ``<inertial>``) must be static.

Gravity. A body floats (no gravity) when every one of its links has ``gravity`` False
(``<turnGravityOff>true</turnGravityOff>``); if only some links have it, gravity stays on
and one warning says so. ODE: ``Body.setGravityMode(False)``; Bullet: a force opposing
gravity is applied at the centre of mass before each step.

Collisions: box, sphere, cylinder (axis z), plane (infinite, static models only) and mesh
(read by sim_world.mesh, the loader the renderer uses: Collada units and up axis applied, so
a mesh collides where it is drawn). Bullet: static meshes are exact concave triangle meshes, meshes of
moving models their convex hulls. ODE: Debian's python3-pyode is built without trimesh
support, so a mesh becomes a set of boxes from a voxelisation (``mesh_boxes``, 24 voxels
along its longest extent, exact for box-shaped meshes, within one voxel otherwise).
Contacts have Coulomb friction ``mu`` (1.0, Gazebo's default) and no bounce.
"""
import logging
import math
import os

import numpy as np

from .. import mesh as _mesh
from ..model import MAX_POSITION, Model, ModelError
from ..transforms import InvalidPose, Pose, matrix_to_quat

__all__ = ['PhysicsEngine', 'BodySpec', 'Contact', 'lump_model', 'load_mesh', 'mesh_boxes',
           'check_pose', 'check_vector']

log = logging.getLogger('sim_world.physics')

#: Coulomb friction coefficient of every contact (Gazebo's default surface mu)
FRICTION = 1.0

def check_pose(pose, what):
    """Raise InvalidPose unless ``pose`` has a finite position and a normalisable
    quaternion; returns a Pose with a unit quaternion."""
    if not isinstance(pose, Pose):
        raise InvalidPose('%s: expected a sim_world.transforms.Pose, got %r' % (what, pose))
    p = np.asarray(pose.p, dtype=float)
    q = np.asarray(pose.q, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise InvalidPose('%s: position %s is not three finite numbers' % (what, list(p)))
    if np.any(np.abs(p) > MAX_POSITION):
        raise InvalidPose('%s: position %s is farther than %g m from the origin (the '
                          'physics engines lose all precision there)'
                          % (what, [float('%g' % v) for v in p], MAX_POSITION))
    if q.shape != (4,) or not np.all(np.isfinite(q)):
        raise InvalidPose('%s: quaternion %s is not four finite numbers' % (what, list(q)))
    n = float(np.linalg.norm(q))
    if n < 1e-6:
        raise InvalidPose('%s: quaternion %s cannot be normalised (norm %.3g)'
                          % (what, list(q), n))
    return Pose(p.copy(), q / n, normalize=False)


def check_vector(v, what):
    try:
        a = np.asarray(v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError('%s: %r is not three numbers' % (what, v))
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError('%s: %s is not three finite numbers' % (what, list(a)))
    return a


def load_mesh(path, scale=(1.0, 1.0, 1.0)):
    """(vertices Nx3 float64, faces Mx3 int32) of a mesh file in the model frame, scaled,
    vertices merged by position; read by ``sim_world.mesh.load``, the loader the renderer uses
    too (Collada units and up axis, winding repair, cache per file and scale), so a mesh
    collides where it is drawn. Raises ModelError naming the file when it cannot be read."""
    try:
        lm = _mesh.load(path, scale)
        return lm.vertices, lm.faces
    except _mesh.MeshLoadError as e:
        raise ModelError(str(e))


def mesh_boxes(verts, faces, cells=24):
    """Boxes [(centre (3,), size (3,))] in the mesh frame that cover a triangle mesh:
    the mesh is voxelised (``cells`` voxels along its longest extent; filled inside when
    it is watertight), runs of voxels are merged greedily into boxes, and each box is
    clipped to the mesh's bounding box (so a box-shaped mesh becomes exactly one box).
    Used by the ODE backend because Debian's python3-pyode is built without trimesh
    support; surfaces that are not axis-aligned are approximated to one voxel."""
    import trimesh
    verts = np.asarray(verts, dtype=float)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    ext = hi - lo
    pad = np.maximum(0.0, (1e-3 - ext) / 2)      # flat meshes get 1 mm of thickness
    lo, hi = lo - pad, hi + pad
    pitch = max(float(ext.max()) / cells, 1e-6)
    # surface voxels: every vertex of the mesh subdivided to edges shorter than half a voxel
    # (trimesh's own voxeliser needs scipy, which the project does not otherwise use)
    from trimesh.remesh import subdivide_to_size
    points, _ = subdivide_to_size(verts, faces, max_edge=pitch / 2.0, max_iter=20)
    idx = np.floor((np.asarray(points) - lo) / pitch).astype(int)
    shape = np.maximum(idx.max(axis=0) + 1, 1)
    free = np.zeros(shape, dtype=bool)
    free[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    if trimesh.Trimesh(vertices=verts, faces=faces).is_watertight:
        free = _fill_inside(free)
    tf = np.eye(4)
    tf[:3, :3] *= pitch
    tf[:3, 3] = lo + pitch / 2.0
    nx, ny, nz = free.shape
    boxes = []
    for i, j, k in np.argwhere(free):
        if not free[i, j, k]:
            continue
        k1 = k
        while k1 + 1 < nz and free[i, j, k1 + 1]:
            k1 += 1
        j1 = j
        while j1 + 1 < ny and free[i, j1 + 1, k:k1 + 1].all():
            j1 += 1
        i1 = i
        while i1 + 1 < nx and free[i1 + 1, j:j1 + 1, k:k1 + 1].all():
            i1 += 1
        free[i:i1 + 1, j:j1 + 1, k:k1 + 1] = False
        a = tf[:3, :3].dot([i, j, k]) + tf[:3, 3]
        b = tf[:3, :3].dot([i1, j1, k1]) + tf[:3, 3]
        low = np.maximum(np.minimum(a, b) - pitch / 2, lo)
        high = np.minimum(np.maximum(a, b) + pitch / 2, hi)
        if np.all(high - low > 1e-9):
            boxes.append(((low + high) / 2, high - low))
    if not boxes:   # degenerate voxelisation: fall back to the bounding box
        boxes.append(((lo + hi) / 2, hi - lo))
    return boxes


def _fill_inside(shell):
    """Voxels enclosed by a closed shell of voxels: everything that a 6-connected flood
    from outside the grid cannot reach (trimesh's own fill needs scipy)."""
    pad = np.pad(shell, 1)
    outside = np.zeros_like(pad)
    outside[0, :, :] = outside[-1, :, :] = True
    outside[:, 0, :] = outside[:, -1, :] = True
    outside[:, :, 0] = outside[:, :, -1] = True
    outside &= ~pad
    while True:
        grown = outside.copy()
        grown[1:, :, :] |= outside[:-1, :, :]
        grown[:-1, :, :] |= outside[1:, :, :]
        grown[:, 1:, :] |= outside[:, :-1, :]
        grown[:, :-1, :] |= outside[:, 1:, :]
        grown[:, :, 1:] |= outside[:, :, :-1]
        grown[:, :, :-1] |= outside[:, :, 1:]
        grown &= ~pad
        if np.array_equal(grown, outside):
            break
        outside = grown
    return ~outside[1:-1, 1:-1, 1:-1]


class Contact(object):
    """One contact point of ``model``/``link`` with ``other_model``/``other_link`` (see
    ``PhysicsEngine.contacts``)."""
    __slots__ = ('model', 'link', 'other_model', 'other_link', 'position', 'normal', 'depth')

    def __init__(self, model, link, other_model, other_link, position, normal, depth):
        self.model, self.link = model, link
        self.other_model, self.other_link = other_model, other_link
        self.position = np.asarray(position, float)
        self.normal = np.asarray(normal, float)
        self.depth = float(depth)

    def __repr__(self):
        return '<Contact %s::%s - %s::%s at %s depth %.2g>' % (
            self.model, self.link, self.other_model, self.other_link,
            np.round(self.position, 4).tolist(), self.depth)


class Shape(object):
    """One collision shape of a body: geometry, pose in the model's root-link frame, and
    the loaded mesh (vertices, faces) for meshes."""
    __slots__ = ('geometry', 'pose', 'mesh', 'link', 'name')

    def __init__(self, geometry, pose, mesh=None, link='', name=''):
        self.geometry = geometry
        self.pose = pose
        self.mesh = mesh
        self.link = link
        self.name = name


class BodySpec(object):
    """A model reduced to what a physics engine needs.

    static: immovable; mass (kg), com: Pose of the principal inertia frame at the centre
    of mass in the root-link frame, inertia: principal moments (3,), gravity: False when
    the body floats, shapes: [Shape], link_offsets: {link: Pose in the root-link frame}.
    """

    def __init__(self, name, static, mass, com, inertia, gravity, shapes, link_offsets):
        self.name = name
        self.static = static
        self.mass = mass
        self.com = com
        self.inertia = inertia
        self.gravity = gravity
        self.shapes = shapes
        self.link_offsets = link_offsets


def _principal_frame(tensor):
    """Rotation matrix (columns = principal axes, det +1) and principal moments."""
    moments, axes = np.linalg.eigh(0.5 * (tensor + tensor.T))
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return axes, moments


def lump_model(model):
    """Validate ``model`` and merge all its links into one BodySpec (see module doc)."""
    if not isinstance(model, Model):
        raise ModelError('expected a sim_world.model.Model, got %r' % (model,))
    if not isinstance(model.name, str) or not model.name:
        raise ModelError('a model needs a non-empty name, got %r' % (model.name,))
    what = 'model %r' % model.name
    model.validate()
    check_pose(model.pose, what + ' pose')
    for j in model.joints:
        if j.type != 'fixed' and not model.static:
            log.warning('%s: joint %r (%s) is simulated as fixed: every link of a model is '
                        'lumped into one rigid body', what, j.name, j.type)
    return lump_links(model, model.link_poses(), model.static)


def lump_links(model, offsets, static, require_mass=True, name=None):
    """One BodySpec of the links in ``offsets`` ({link name: pose in the body's reference
    frame}); ``require_mass`` False returns None for links without any mass."""
    what = 'model %r' % model.name
    shapes = []
    masses, centres, tensors = [], [], []
    gravity_flags = []
    missing = []
    for lname in offsets:
        link = model.links[lname]
        lpose = offsets[lname]
        gravity_flags.append(bool(link.gravity))
        for c in link.collisions:
            g = c.geometry
            g._check()
            cpose = lpose * check_pose(c.origin, '%s link %r collision origin' % (what, lname))
            mesh = None
            if g.kind == 'plane':
                if not static:
                    raise ModelError('%s: link %r has a plane collision, which only a static '
                                     'model may have' % (what, lname))
                n = np.asarray(g.normal, dtype=float)
                if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-9:
                    raise ModelError('%s: link %r plane normal %s is not a direction'
                                     % (what, lname, list(n)))
            elif g.kind == 'mesh':
                path = model.resolve_path(g.filename)
                if not os.path.isfile(path):
                    # issue 48: a URI that does not resolve is one warning, and the model
                    # spawns without that collision (pybullet_data ships xarm6 and panda
                    # without their collision meshes); a static model left with nothing
                    # is refused below
                    missing.append(path)
                    log.warning('%s link %r: collision mesh %s not found: the link has no '
                                'collision shape for it', what, lname, g.filename)
                    continue
                try:
                    mesh = load_mesh(path, g.scale)
                except ModelError as e:
                    raise ModelError('%s link %r: %s' % (what, lname, e))
            shapes.append(Shape(g, cpose, mesh, lname, c.name))
        if static or link.inertial is None:
            continue
        ine = link.inertial
        m = float(ine.mass)
        if not (math.isfinite(m) and m > 0):
            raise ModelError('%s: link %r mass must be a positive number, got %r'
                             % (what, lname, ine.mass))
        t = np.asarray(ine.inertia, dtype=float)
        if t.shape != (3, 3) or not np.all(np.isfinite(t)):
            raise ModelError('%s: link %r inertia is not a finite 3x3 tensor' % (what, lname))
        if np.min(np.linalg.eigvalsh(0.5 * (t + t.T))) < -1e-12:
            raise ModelError('%s: link %r inertia has a negative principal moment'
                             % (what, lname))
        ipose = lpose * check_pose(ine.origin, '%s link %r inertial origin' % (what, lname))
        r = ipose.matrix()[:3, :3]
        masses.append(m)
        centres.append(ipose.p)
        tensors.append(r.dot(t).dot(r.T))
    name = name or model.name
    if static and missing and not shapes:
        raise ModelError('%s: mesh file %s not found, and the static model has no other '
                         'collision' % (what, missing[0]))
    if static:
        return BodySpec(name, True, 0.0, Pose(), np.zeros(3), True, shapes, offsets)
    if not masses:
        if not require_mass:
            return None
        raise ModelError('%s is not static but none of its links has an <inertial> with a '
                         'positive mass' % what)
    total = float(sum(masses))
    com = sum(m * c for m, c in zip(masses, centres)) / total
    tensor = np.zeros((3, 3))
    for m, c, t in zip(masses, centres, tensors):
        d = c - com
        tensor += t + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    axes, moments = _principal_frame(tensor)
    if not np.all(moments > 1e-12 * max(1.0, float(np.max(np.abs(moments))))):
        raise ModelError('%s: inertia is not positive definite (principal moments %s kg m^2); '
                         'give its links non-zero ixx, iyy, izz'
                         % (what, [float('%.3g' % x) for x in moments]))
    gravity = any(gravity_flags)
    if gravity and not all(gravity_flags):
        log.warning('%s: only some links turn gravity off; the lumped body keeps gravity',
                    what)
    return BodySpec(name, False, total, Pose(com, matrix_to_quat(axes)), moments,
                    gravity, shapes, offsets)


class Record(object):
    """What an engine keeps per model."""

    def __init__(self, spec, pose):
        self.spec = spec
        self.name = spec.name
        self.static = spec.static
        self.pose = pose                    # static models: world pose of the root link
        self.com_inv = spec.com.inverse()   # body (COM) frame -> root link frame
        self.native = None                  # engine-specific handles
        self.art = None                     # articulation.Articulation or None


class PhysicsEngine(object):
    """Base class of the backends; see the module docstring for the contract."""

    name = None

    def __init__(self, step_size=0.001, gravity=(0.0, 0.0, -9.81)):
        step_size = float(step_size)
        if not (math.isfinite(step_size) and step_size > 0):
            raise ValueError('physics step size must be a positive number of seconds, got %r'
                             % step_size)
        self.step_size = step_size
        self.gravity = check_vector(gravity, 'gravity')
        self._models = {}
        self.pose_version = 0
        self._wrenches = {}          # model name -> {key: [force, torque, next row, steps left]}
        self._wrench_seq = 0
        from .attachments import Attachments
        self._attached = Attachments(self)   # the link attacher's fixed joints

    # ---- model bookkeeping -------------------------------------------------------------
    def add_model(self, model):
        if not isinstance(model, Model):
            raise ModelError('expected a sim_world.model.Model, got %r' % (model,))
        if model.name in self._models:
            raise ModelError('a model named %r already exists' % model.name)
        art = None
        if not model.static:
            if not isinstance(model.name, str) or not model.name:
                raise ModelError('a model needs a non-empty name, got %r' % (model.name,))
            model.validate()
            from .articulation import build_articulation
            art = build_articulation(model)
        spec = lump_model(model) if art is None else art.groups[0].spec
        pose = check_pose(model.pose, 'model %r pose' % model.name)
        rec = Record(spec, pose)
        rec.name = model.name
        rec.art = art
        if art is not None:
            from .articulation import check_positions
            init = check_positions(art, model.name, dict(
                (j.name, j.initial) for j in model.joints if j.name in art.joints
                and j.movable and j.initial))
            self._add_articulated(rec, pose)
            self._models[model.name] = rec
            if init:
                self.set_joint_positions(model.name, init)
            rec.initial_positions = init
        else:
            self._add(rec, pose)
            self._models[model.name] = rec
        return rec

    def remove_model(self, name):
        rec = self._get(name)
        self._attached.drop_model(name)
        self._remove(rec)
        del self._models[name]
        self._wrenches.pop(name, None)

    # ---- external wrenches (gazebo_ros_force, the vibration motor) ----------------------------
    def apply_wrench(self, name, force, torque=None, steps=1, key=None):
        """Apply a world-frame ``force`` (N, at the centre of mass) and ``torque`` (N m) to
        model ``name`` during each of the next ``steps`` physics steps (None: every step
        until replaced or cleared, as gazebo_ros_force does with its last message). Either
        may be an (n, 3) array: row k acts during the k-th coming step (steps = n). A call
        with the same ``key`` replaces what that key still had queued; wrenches of
        different keys (and every call without a key) add up. Static models: nothing.
        Raises KeyError for an unknown model, ValueError for a non-finite value."""
        rec = self._get(name)
        f = np.zeros(3) if force is None else np.asarray(force, float)
        t = np.zeros(3) if torque is None else np.asarray(torque, float)
        rows = max(len(f) if f.ndim == 2 else 1, len(t) if t.ndim == 2 else 1)
        for what, v in (('force', f), ('torque', t)):
            if v.shape not in ((3,), (rows, 3)) or not np.all(np.isfinite(v)):
                raise ValueError('%s on model %r must be finite 3-vectors (or n x 3 rows), '
                                 'got %r' % (what, name, v.tolist()))
        if f.ndim == 2 or t.ndim == 2:
            steps = rows
        elif steps is not None:
            steps = int(steps)
            if steps < 1:
                raise ValueError('steps of a wrench on model %r must be >= 1, got %r'
                                 % (name, steps))
        if rec.static:
            return
        if key is None:
            self._wrench_seq += 1
            key = ('_once', self._wrench_seq)
        self._wrenches.setdefault(name, {})[key] = [f, t, 0, steps]

    def clear_wrench(self, name, key=None):
        """Drop the wrenches of model ``name`` (only the one of ``key`` when given)."""
        if key is None:
            self._wrenches.pop(name, None)
        else:
            self._wrenches.get(name, {}).pop(key, None)

    def _take_wrenches(self):
        """[(record, force, torque)] summed per model for the step about to run; advances
        the queues (called by a backend once per step, only while there are any)."""
        out = []
        for name in list(self._wrenches):
            queue = self._wrenches[name]
            f_sum, t_sum = np.zeros(3), np.zeros(3)
            for key in list(queue):
                e = queue[key]
                f, t, i, left = e
                f_sum += f[i] if f.ndim == 2 else f
                t_sum += t[i] if t.ndim == 2 else t
                if left is not None:
                    e[2], e[3] = i + 1, left - 1
                    if left <= 1:
                        del queue[key]
            if not queue:
                del self._wrenches[name]
            out.append((self._models[name], f_sum, t_sum))
        return out

    def has_model(self, name):
        return name in self._models

    def model_names(self):
        return list(self._models)

    def _get(self, name):
        try:
            return self._models[name]
        except KeyError:
            raise KeyError('no model named %r in the physics engine' % (name,))

    # ---- state -------------------------------------------------------------------------
    def model_pose(self, name):
        rec = self._get(name)
        if rec.static:
            return rec.pose.copy()
        return self._body_pose(rec) * rec.com_inv

    def set_model_pose(self, name, pose):
        rec = self._get(name)
        pose = check_pose(pose, 'new pose of model %r' % name)
        self.pose_version += 1      # teleports since the last step (sim_world.raycast cache)
        if rec.static:
            rec.pose = pose
            self._place_static(rec, pose)
        else:
            self._set_body_pose(rec, pose * rec.spec.com)
        if self._attached.items:
            self._attached.moved(name)

    def model_twist(self, name):
        return self.model_state(name)[1:]

    def model_state(self, name):
        """(pose, linear, angular) of the model's origin, the body read once (the same
        values as model_pose and model_twist)."""
        rec = self._get(name)
        if rec.static:
            return rec.pose.copy(), np.zeros(3), np.zeros(3)
        v_com, w = self._body_twist(rec)
        body = self._body_pose(rec)
        root = body * rec.com_inv
        origin = root.p
        # v_com + w x (origin - com), in plain floats (np.cross costs ~20 us on 3-vectors)
        a0, a1, a2 = np.asarray(w, float).tolist()
        o0, o1, o2 = origin.tolist()
        c0, c1, c2 = body.p.tolist()
        b0, b1, b2 = o0 - c0, o1 - c1, o2 - c2
        v0, v1, v2 = np.asarray(v_com, float).tolist()
        return root, np.array((v0 + (a1 * b2 - a2 * b1), v1 + (a2 * b0 - a0 * b2),
                               v2 + (a0 * b1 - a1 * b0))), w

    def set_model_twist(self, name, lin, ang):
        rec = self._get(name)
        lin = check_vector(lin, 'linear velocity of model %r' % name)
        ang = check_vector(ang, 'angular velocity of model %r' % name)
        if rec.static:
            if np.any(lin) or np.any(ang):
                log.warning('model %r is static: its twist stays zero', name)
            return
        body = self._body_pose(rec)
        origin = (body * rec.com_inv).p
        self._set_body_twist(rec, lin + np.cross(ang, body.p - origin), ang)

    def link_poses(self, name):
        rec = self._get(name)
        if rec.art is not None:
            frames = [self._group_pose(rec, gi) * g.com_inv
                      for gi, g in enumerate(rec.art.groups)]
            return dict((ln, frames[gi] * off)
                        for ln, (gi, off) in rec.art.link_group.items())
        root = self.model_pose(name)
        return dict((ln, root * off) for ln, off in rec.spec.link_offsets.items())

    def link_pose(self, name, link):
        """World pose of one link (cheaper than link_poses when one is needed)."""
        rec = self._get(name)
        if rec.art is not None:
            entry = rec.art.link_group.get(link)
            if entry is None:
                raise KeyError('model %r has no link %r' % (name, link))
            gi, off = entry
            return self._group_pose(rec, gi) * rec.art.groups[gi].com_inv * off
        off = rec.spec.link_offsets.get(link)
        if off is None:
            raise KeyError('model %r has no link %r' % (name, link))
        return self.model_pose(name) * off

    def link_state(self, name, link):
        """(world pose, linear velocity of the link origin, angular velocity) of one link
        (a link on a moving joint moves with its own body)."""
        rec = self._check_link(name, link)
        if link is None:
            raise KeyError('model %r: no link given' % name)
        if rec.art is None:
            root, lin, ang = self.model_state(name)
            pose = root * rec.spec.link_offsets[link]
            return pose, lin + np.cross(ang, pose.p - root.p), ang
        gi, off = rec.art.link_group[link]
        body = self._group_pose(rec, gi)
        pose = body * rec.art.groups[gi].com_inv * off
        v_com, w = self._group_twist(rec, gi)
        w = np.asarray(w, float)
        return pose, np.asarray(v_com, float) + np.cross(w, pose.p - body.p), w

    # ---- joints (articulated models; sim_world.physics.articulation) -----------------------
    def _art(self, name):
        rec = self._get(name)
        if rec.art is None:
            raise KeyError('model %r has no joints' % (name,))
        return rec

    def _joint_of(self, name, joint):
        rec = self._get(name)
        js = rec.art.joints.get(joint) if rec.art is not None else None
        if js is None:
            raise KeyError('model %r has no joint %r' % (name, joint))
        return rec, js

    def joint_names(self, name):
        """Names of the model's simulated joints (movable and preserved fixed), in the
        model's order; [] for a one-body model."""
        rec = self._get(name)
        return [] if rec.art is None else list(rec.art.order)

    def joint(self, name, joint):
        """The sim_world.model.Joint of a simulated joint (KeyError naming it)."""
        return self._joint_of(name, joint)[1].joint

    def joint_state(self, name, joint):
        """(position, velocity) of a joint: rad, rad/s (m, m/s for prismatic); fixed: 0."""
        rec, js = self._joint_of(name, joint)
        if not js.movable:
            return 0.0, 0.0
        return self._joint_pos_vel(rec, js)

    def joint_states_of(self, name, joints):
        """[(position, velocity)] of the named joints, in that order: joint_state of each,
        the model looked up once and, in Bullet, one call for all (a controller reads its
        joints every step). KeyError naming an unknown joint."""
        rec = self._get(name)
        table = rec.art.joints if rec.art is not None else {}
        jss = []
        for jn in joints:
            js = table.get(jn)
            if js is None:
                raise KeyError('model %r has no joint %r' % (name, jn))
            jss.append(js)
        return self._joint_pos_vels(rec, jss)

    def _joint_pos_vels(self, rec, jss):
        pv = self._joint_pos_vel
        return [pv(rec, js) if js.movable else (0.0, 0.0) for js in jss]

    def joint_states(self, name):
        """{joint: (position, velocity)} of every simulated joint."""
        return dict((jn, self.joint_state(name, jn)) for jn in self.joint_names(name))

    def set_joint_positions(self, name, positions):
        """Move joints to ``positions`` ({joint: value}; the others keep theirs), every
        joint velocity and the links' twists zero (Gazebo's set_model_configuration; the
        root link stays where it is). KeyError / ValueError naming a bad joint or value."""
        rec = self._art(name)
        full = check_positions(rec.art, name, positions)
        if len(full) < len(rec.art.moving):
            for js in rec.art.moving:
                if js.name not in full:
                    full[js.name] = self._joint_pos_vel(rec, js)[0]
        self.pose_version += 1
        self._set_joint_positions(rec, full)
        if self._attached.items:
            self._attached.moved(name)

    def set_joint_velocity(self, name, joint, velocity):
        """Give a movable joint a velocity (rad/s or m/s) relative to its parent, its
        position and the other joints' velocities unchanged."""
        rec, js = self._joint_of(name, joint)
        v = float(velocity)
        if not js.movable or not math.isfinite(v):
            raise ValueError('joint %r of model %r: cannot set velocity %r'
                             % (joint, name, velocity))
        self._set_joint_velocity(rec, js, v - self._joint_pos_vel(rec, js)[1])

    def apply_joint_effort(self, name, joint, effort, steps=None, key=None, delay=0):
        """An effort (N m or N) on a movable joint during the next ``steps`` steps (None:
        until cleared); the same ``key`` replaces, different keys add up. Each step the sum
        goes through Gazebo's CheckAndTruncateForce (velocity and effort limits); it starts
        after ``delay`` steps."""
        rec, js = self._joint_of(name, joint)
        if not js.movable:
            raise KeyError('joint %r of model %r is fixed' % (joint, name))
        e = float(effort)
        if not math.isfinite(e):
            raise ValueError('effort on joint %r of model %r is not finite: %r'
                             % (joint, name, effort))
        if steps is not None:
            steps = int(steps)
            if steps < 1:
                return
        if key is None:
            self._wrench_seq += 1
            key = ('_once', self._wrench_seq)
        js.efforts[key] = [e, steps, max(0, int(delay))]
        rec.art.refresh()

    def clear_joint_efforts(self, name, joint=None, key=None):
        rec = self._get(name)
        if rec.art is None:
            return
        for jn, js in rec.art.joints.items():
            if joint is None or jn == joint:
                if key is None:
                    js.efforts.clear()
                else:
                    js.efforts.pop(key, None)
        rec.art.refresh()

    def set_joint_dynamics(self, name, joint, damping=None, friction=None):
        """Change a joint's viscous damping and Coulomb friction (>= 0, finite)."""
        rec, js = self._joint_of(name, joint)
        for what, v in (('damping', damping), ('friction', friction)):
            if v is not None and not (math.isfinite(float(v)) and 0 <= float(v) <= 1e6):
                raise ValueError('%s of joint %r of model %r must be in [0, 1e6], got %r'
                                 % (what, joint, name, v))
        if damping is not None:
            js.damping = float(damping)
        if friction is not None:
            js.friction = float(friction)
        self._apply_friction(rec, js)
        rec.art.refresh()

    def _joint_step(self):
        """Before a step: applied efforts (truncated as Gazebo does) and viscous damping."""
        for rec in self._models.values():
            art = rec.art
            if art is None or not art.needs_step:
                continue
            for js in art.moving:
                if not (js.efforts or js.damping > 0):
                    continue
                v = self._joint_vel(rec, js)
                j = js.joint
                e = truncate_effort(js.applied(), v, j.effort, j.velocity) if js.efforts \
                    else 0.0
                if e:
                    self._joint_force(rec, js, e)
                if js.damping > 0:
                    # viscous damping through the joint's velocity-0 motor (with the
                    # friction): it gives -damping * v, but never more than stops the joint
                    # in one step, so a stiff damping (1e6 on a light link) cannot blow up
                    self._set_motor(rec, js, js.friction + js.damping * abs(v))
            art.refresh()

    def _reset_joints(self, rec):
        """Joints back to their spawn positions with zero velocity (reset_world)."""
        init = dict((jn, 0.0) for jn, js in rec.art.joints.items() if js.movable)
        init.update(getattr(rec, 'initial_positions', {}) or {})
        self.clear_joint_efforts(rec.name)
        self._set_joint_positions(rec, init)

    def reset_joints(self, name):
        rec = self._get(name)
        if rec.art is not None:
            self.pose_version += 1
            self._reset_joints(rec)
            if self._attached.items:
                self._attached.moved(name)

    # ---- the link attacher (sim_world.physics.attachments) ----------------------------------
    def attach(self, model1, link1, model2, link2):
        """Fix link2 of model2 to link1 of model1 where they are now (model1 holds).
        False if exactly this attachment exists already; KeyError / ValueError naming a bad
        model or link, the same link twice, two links of one model, two static models."""
        return self._attached.attach(model1, link1, model2, link2)

    def detach(self, model1, link1, model2, link2):
        """Remove that attachment; False if there was none."""
        return self._attached.detach(model1, link1, model2, link2)

    def detach_all(self):
        self._attached.clear()

    def attachments(self):
        """[(model1, link1, model2, link2)] of the attachments, in the order made."""
        return [a.key for a in self._attached.items]

    def set_gravity(self, g):
        self.gravity = check_vector(g, 'gravity')
        self._set_gravity(self.gravity)

    def solver_config(self):
        """The solver settings gazebo_msgs/ODEPhysics names, as a dict of its fields, for an
        engine that has them (ODE); None otherwise."""
        return None

    def set_solver_config(self, **fields):
        """Sets the ODEPhysics fields an engine can change now (ValueError naming a field
        it cannot take)."""
        raise ValueError('ode_config applies to the ode engine; this world runs %s'
                         % self.name)

    def close(self):
        pass

    def __repr__(self):
        return '<%s engine, step %g s, %d models>' % (self.name, self.step_size,
                                                       len(self._models))

    # ---- what a backend implements --------------------------------------------------------
    def _add(self, rec, pose):
        raise NotImplementedError

    def _remove(self, rec):
        raise NotImplementedError

    def _place_static(self, rec, pose):
        raise NotImplementedError

    def _body_pose(self, rec):
        raise NotImplementedError

    def _set_body_pose(self, rec, pose):
        raise NotImplementedError

    def _body_twist(self, rec):
        raise NotImplementedError

    def _set_body_twist(self, rec, lin, ang):
        raise NotImplementedError

    def _set_gravity(self, g):
        raise NotImplementedError

    def in_contact(self, name):
        raise NotImplementedError

    def contacts(self, name, link=None):
        raise NotImplementedError

    def _check_link(self, name, link):
        rec = self._get(name)
        if rec.art is not None:
            if link is not None and link not in rec.art.link_group:
                raise KeyError('model %r has no link %r' % (name, link))
            return rec
        if link is not None and link not in rec.spec.link_offsets:
            raise KeyError('model %r has no link %r' % (name, link))
        return rec

    def step(self, n=1):
        raise NotImplementedError


# (articulation imports this module: its names are bound once both exist; the package's
# __init__ always imports this module first)
from .articulation import check_positions, truncate_effort  # noqa: E402
