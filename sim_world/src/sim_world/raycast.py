"""Ray casting over the world's collision shapes at their current poses.

``raycast(world, origin, direction, max_dist, ignore=())`` -> the first surface hit along a
ray (``Hit``: distance, model, link, point, normal, material) or None;
``segment_intervals(world, a, b, ignore=())`` -> ``[(enter, exit, model, link, material)]``,
the parts of the segment a->b (distances from a, sorted by enter) that lie inside solid
collision shapes. Both are also ``World.raycast`` / ``World.segment_intervals``.

An articulated model's shapes move with their links (each link group's body).

Shapes: boxes, spheres and cylinders analytically; planes as the solid half-space below the
plane (behind its normal: the ground is solid); meshes by Moeller-Trumbore over all their
triangles at once (a closed mesh's inside is between consecutive crossings along the line).
Everything is numpy-vectorised across the shapes of each kind. The shapes come from the
physics engine's lumped model records (``sim_world.physics.base.lump_model``: every collision
of every link with its pose in the root-link frame); world transforms are cached per model
and recomputed only when that model's pose changed (static models: when they are moved;
dynamic models: read from the engine after each world step or teleport, so a teleport is
seen at once).

``ignore``: model names (the whole model) or ``'model::link'`` (one link).

A ray that starts inside a box, sphere, cylinder or the ground does not hit that shape (it
reports the first surface it *enters*); ``segment_intervals`` reports the inside part from 0.

Materials: a collision may name its material for the radio (``<collision><material>drywall
</material>`` in SDF, ``<collision><material name="drywall"/>`` in URDF), else None.
"""
import numpy as np

from .transforms import quat_to_matrix

__all__ = ['Hit', 'RayCaster', 'raycast', 'segment_intervals', 'caster']

_EPS = 1e-12


class Hit(object):
    """The first surface a ray enters."""
    __slots__ = ('distance', 'model', 'link', 'point', 'normal', 'material')

    def __init__(self, distance, model, link, point, normal, material=None):
        self.distance = float(distance)
        self.model, self.link, self.material = model, link, material
        self.point = np.asarray(point, float)
        self.normal = np.asarray(normal, float)

    def __repr__(self):
        return '<Hit %s::%s at %.4g m>' % (self.model, self.link, self.distance)


class _Kind(object):
    """Arrays of one shape kind: per-shape world rotation R (n,3,3), translation t (n,3),
    and the owner index (into RayCaster.owners)."""

    def __init__(self):
        self.R = np.zeros((0, 3, 3))
        self.t = np.zeros((0, 3))
        self.owner = np.zeros(0, int)
        self.params = np.zeros((0, 3))


def _thickness(kind, par, shape):
    """Smallest extent (m) of a collision shape: a box's thinnest side, a sphere's
    diameter, a cylinder's smaller of diameter and length, a mesh's thinnest bounding-box
    side; None for a plane (a half-space)."""
    if kind == 'box':
        return float(2.0 * np.min(par))
    if kind == 'sphere':
        return float(2.0 * par[0])
    if kind == 'cylinder':
        return float(2.0 * min(par[0], par[1]))
    if kind == 'mesh':
        verts = np.asarray(shape.mesh[0], float)
        return float(np.min(verts.max(axis=0) - verts.min(axis=0))) if len(verts) else None
    return None


class RayCaster(object):
    """Per-world cache of the collision shapes' world transforms (see module doc)."""

    def __init__(self, world):
        self.world = world
        self._key = None
        self._stamp = None
        self._poses = {}
        self._ignore_cache = {}

    # ---- building -------------------------------------------------------------------------
    def _materials(self, model):
        mats = {}
        for link in model.links.values():
            for c in link.collisions:
                mats[id(c.geometry)] = getattr(c, 'material', None)
        return mats

    def _build(self):
        phys = self.world.physics
        recs = phys._models
        self.owners = []          # (model, link, material)
        self.owner_thickness = []  # m, the shape's smallest extent (None: a half-space)
        self.shape_local = []     # (kind, index, local Pose, model name)
        lists = dict(box=[], sphere=[], cylinder=[], plane=[], mesh=[])
        self.model_shapes = {}
        for name, rec in recs.items():
            model = self.world.models.get(name)
            mats = self._materials(model) if model is not None else {}
            # an articulated model: the shapes of every link group (body), each placed by
            # its group's frame (group index gi; None: the model's root frame)
            if getattr(rec, 'art', None) is not None:
                shapes = [(gi, s) for gi, grp in enumerate(rec.art.groups)
                          for s in grp.spec.shapes]
            else:
                shapes = [(None, s) for s in rec.spec.shapes]
            for gi, s in shapes:
                g = s.geometry
                k = g.kind
                if k not in lists:
                    continue
                oi = len(self.owners)
                self.owners.append((name, s.link, mats.get(id(g))))
                if k == 'box':
                    par = np.asarray(g.size, float) / 2.0
                elif k == 'sphere':
                    par = np.array([g.radius, 0.0, 0.0])
                elif k == 'cylinder':
                    par = np.array([g.radius, g.length / 2.0, 0.0])
                elif k == 'plane':
                    n = np.asarray(g.normal, float)
                    par = n / np.linalg.norm(n)
                else:
                    par = None
                lists[k].append((oi, s, par, gi))
                self.owner_thickness.append(_thickness(k, par, s))
                self.model_shapes.setdefault(name, []).append((k, len(lists[k]) - 1, gi))
        self.kinds = {}
        for k in ('box', 'sphere', 'cylinder', 'plane'):
            kd = _Kind()
            n = len(lists[k])
            kd.R = np.tile(np.eye(3), (n, 1, 1))
            kd.t = np.zeros((n, 3))
            kd.owner = np.array([e[0] for e in lists[k]], int)
            kd.params = np.array([e[2] for e in lists[k]], float).reshape(n, 3)
            kd.local = [e[1].pose for e in lists[k]]
            kd.group = [e[3] for e in lists[k]]
            self.kinds[k] = kd
        # meshes: one triangle soup; tri_shape = index of the mesh in self.meshes
        self.meshes = []
        v0, tri_shape = [], []
        start = 0
        for i, (oi, s, _, gi) in enumerate(lists['mesh']):
            verts, faces = s.mesh
            verts = np.asarray(verts, float)
            faces = np.asarray(faces, int)
            tris = verts[faces]                      # (m,3,3) local
            self.meshes.append(dict(owner=oi, local=s.pose, tris=tris, group=gi,
                                    sl=slice(start, start + len(tris))))
            start += len(tris)
            tri_shape.append(np.full(len(tris), i, int))
        self.tri_shape = np.concatenate(tri_shape) if tri_shape else np.zeros(0, int)
        self.tri_owner = (np.array([m['owner'] for m in self.meshes], int)[self.tri_shape]
                          if self.meshes else np.zeros(0, int))
        self.v0 = np.zeros((start, 3))
        self.e1 = np.zeros((start, 3))
        self.e2 = np.zeros((start, 3))
        self.mesh_index = {}
        for i, m in enumerate(self.meshes):
            self.mesh_index.setdefault(self.owners[m['owner']][0], []).append(i)
        self.owner_model = np.array([o[0] for o in self.owners], object)
        self.owner_key = np.array(['%s::%s' % (o[0], o[1]) for o in self.owners], object)
        self._poses = {}
        self._ignore_cache = {}

    def _place(self, name, root, frames=None):
        """Shapes of model ``name`` at its root pose (``frames``: the group frames of an
        articulated model)."""
        for k, i, gi in self.model_shapes.get(name, ()):
            if k == 'mesh':
                continue
            kd = self.kinds[k]
            w = (root if gi is None else frames[gi]) * kd.local[i]
            kd.R[i] = quat_to_matrix(w.q)
            kd.t[i] = w.p
        for i in self.mesh_index.get(name, ()):
            m = self.meshes[i]
            w = (root if m['group'] is None else frames[m['group']]) * m['local']
            R = quat_to_matrix(w.q)
            tw = m['tris'].dot(R.T) + w.p
            sl = m['sl']
            self.v0[sl] = tw[:, 0]
            self.e1[sl] = tw[:, 1] - tw[:, 0]
            self.e2[sl] = tw[:, 2] - tw[:, 0]

    def sync(self):
        phys = self.world.physics
        recs = phys._models
        key = tuple((n, id(r)) for n, r in recs.items())
        if key != self._key:
            self._build()
            self._key = key
            self._stamp = None
        # poses change only by a world step or a teleport (engine.set_model_pose)
        stamp = (self.world.steps, getattr(phys, 'pose_version', None))
        if stamp == self._stamp and stamp[1] is not None:
            return
        self._stamp = stamp
        for name, rec in recs.items():
            if name not in self.model_shapes:
                continue
            if rec.static:
                pose = rec.pose
                old = self._poses.get(name)
                if old is pose:
                    continue
                self._poses[name] = pose
                self._place(name, pose)
            elif getattr(rec, 'art', None) is not None:
                frames = [phys.link_pose(name, g.name) for g in rec.art.groups]
                key = np.concatenate([np.concatenate([f.p, f.q]) for f in frames])
                old = self._poses.get(name)
                if old is not None and np.array_equal(old, key):
                    continue
                self._poses[name] = key
                self._place(name, None, frames)
            else:
                pose = phys.model_pose(name)
                old = self._poses.get(name)
                if old is not None and np.array_equal(old.p, pose.p) and \
                        np.array_equal(old.q, pose.q):
                    continue
                self._poses[name] = pose
                self._place(name, pose)

    def _keep(self, ignore):
        """Boolean mask over owners (True: considered)."""
        ignore = tuple(ignore or ())
        m = self._ignore_cache.get(ignore)
        if m is None:
            m = np.ones(len(self.owners), bool)
            for ig in ignore:
                if '::' in ig:
                    m &= self.owner_key != ig
                else:
                    m &= self.owner_model != ig
            if len(self._ignore_cache) > 64:
                self._ignore_cache.clear()
            self._ignore_cache[ignore] = m
        return m

    # ---- the line against every shape ---------------------------------------------------------
    def _line(self, o, d, keep):
        """For the line o + t d (d unit): per analytic shape (owner, tin, tout, normal at tin)
        as arrays, and mesh crossings (owner, t, normal)."""
        owners, tins, touts, normals = [], [], [], []
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            kd = self.kinds['box']
            if len(kd.owner):
                sel = keep[kd.owner]
                R, t, h = kd.R[sel], kd.t[sel], kd.params[sel]
                ol = np.einsum('nji,nj->ni', R, o - t)
                dl = np.einsum('nji,j->ni', R, d)
                par = np.abs(dl) < _EPS
                inv = 1.0 / np.where(par, 1.0, dl)
                t1 = (-h - ol) * inv
                t2 = (h - ol) * inv
                lo = np.minimum(t1, t2)
                hi = np.maximum(t1, t2)
                inside = np.abs(ol) <= h
                lo = np.where(par, np.where(inside, -np.inf, np.inf), lo)
                hi = np.where(par, np.where(inside, np.inf, -np.inf), hi)
                ax = np.argmax(lo, axis=1)
                tin = lo[np.arange(len(lo)), ax]
                tout = hi.min(axis=1)
                sgn = -np.sign(dl[np.arange(len(dl)), ax])
                nrm = R[np.arange(len(R)), :, ax] * sgn[:, None]
                owners.append(kd.owner[sel]); tins.append(tin); touts.append(tout)
                normals.append(nrm)
            kd = self.kinds['sphere']
            if len(kd.owner):
                sel = keep[kd.owner]
                c, r = kd.t[sel], kd.params[sel, 0]
                oc = o - c
                b = oc.dot(d)
                cc = np.einsum('ni,ni->n', oc, oc) - r * r
                disc = b * b - cc
                sq = np.sqrt(np.maximum(disc, 0))
                tin = np.where(disc >= 0, -b - sq, np.inf)
                tout = np.where(disc >= 0, -b + sq, -np.inf)
                nrm = (o + np.outer(np.where(np.isfinite(tin), tin, 0), d) - c) / r[:, None]
                owners.append(kd.owner[sel]); tins.append(tin); touts.append(tout)
                normals.append(nrm)
            kd = self.kinds['cylinder']
            if len(kd.owner):
                sel = keep[kd.owner]
                R, t = kd.R[sel], kd.t[sel]
                r, hl = kd.params[sel, 0], kd.params[sel, 1]
                ol = np.einsum('nji,nj->ni', R, o - t)
                dl = np.einsum('nji,j->ni', R, d)
                a = dl[:, 0] ** 2 + dl[:, 1] ** 2
                b = ol[:, 0] * dl[:, 0] + ol[:, 1] * dl[:, 1]
                c = ol[:, 0] ** 2 + ol[:, 1] ** 2 - r * r
                disc = b * b - a * c
                sq = np.sqrt(np.maximum(disc, 0))
                axial = a < _EPS
                asafe = np.where(axial, 1.0, a)
                rin = np.where(axial, np.where(c <= 0, -np.inf, np.inf),
                               np.where(disc >= 0, (-b - sq) / asafe, np.inf))
                rout = np.where(axial, np.where(c <= 0, np.inf, -np.inf),
                                np.where(disc >= 0, (-b + sq) / asafe, -np.inf))
                dz = dl[:, 2]
                zpar = np.abs(dz) < _EPS
                izs = 1.0 / np.where(zpar, 1.0, dz)
                z1, z2 = (-hl - ol[:, 2]) * izs, (hl - ol[:, 2]) * izs
                zin_ok = np.abs(ol[:, 2]) <= hl
                zlo = np.where(zpar, np.where(zin_ok, -np.inf, np.inf), np.minimum(z1, z2))
                zhi = np.where(zpar, np.where(zin_ok, np.inf, -np.inf), np.maximum(z1, z2))
                tin = np.maximum(rin, zlo)
                tout = np.minimum(rout, zhi)
                radial = rin >= zlo
                tf = np.where(np.isfinite(tin), tin, 0)
                pl = ol + dl * tf[:, None]
                nl = np.where(radial[:, None],
                              np.stack([pl[:, 0], pl[:, 1], np.zeros(len(pl))], 1)
                              / r[:, None],
                              np.stack([np.zeros(len(pl)), np.zeros(len(pl)), -np.sign(dz)], 1))
                nrm = np.einsum('nij,nj->ni', R, nl)
                owners.append(kd.owner[sel]); tins.append(tin); touts.append(tout)
                normals.append(nrm)
            kd = self.kinds['plane']
            if len(kd.owner):
                sel = keep[kd.owner]
                R, t, nloc = kd.R[sel], kd.t[sel], kd.params[sel]
                n = np.einsum('nij,nj->ni', R, nloc)
                s0 = np.einsum('ni,ni->n', o - t, n)
                sd = n.dot(d)
                par = np.abs(sd) < _EPS
                t0 = -s0 / np.where(par, 1.0, sd)
                tin = np.where(par, np.where(s0 < 0, -np.inf, np.inf),
                               np.where(sd < 0, t0, -np.inf))
                tout = np.where(par, np.where(s0 < 0, np.inf, -np.inf),
                                np.where(sd < 0, np.inf, t0))
                owners.append(kd.owner[sel]); tins.append(tin); touts.append(tout)
                normals.append(n)
            # meshes
            mo, mt, mn = np.zeros(0, int), np.zeros(0), np.zeros((0, 3))
            mshape = np.zeros(0, int)
            if len(self.tri_owner):
                sel = keep[self.tri_owner]
                v0, e1, e2 = self.v0[sel], self.e1[sel], self.e2[sel]
                p = np.cross(d, e2)
                det = np.einsum('ni,ni->n', e1, p)
                ok = np.abs(det) > 1e-14
                inv = 1.0 / np.where(ok, det, 1.0)
                tv = o - v0
                u = np.einsum('ni,ni->n', tv, p) * inv
                q = np.cross(tv, e1)
                v = q.dot(d) * inv
                tt = np.einsum('ni,ni->n', e2, q) * inv
                hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
                mo = self.tri_owner[sel][hit]
                mshape = self.tri_shape[sel][hit]
                mt = tt[hit]
                nn = np.cross(e1[hit], e2[hit])
                nn /= np.maximum(np.linalg.norm(nn, axis=1), 1e-300)[:, None]
                nn *= -np.sign(nn.dot(d))[:, None]
                mn = nn
        if owners:
            owners = np.concatenate(owners)
            tins, touts = np.concatenate(tins), np.concatenate(touts)
            normals = np.concatenate(normals)
        else:
            owners, tins, touts = np.zeros(0, int), np.zeros(0), np.zeros(0)
            normals = np.zeros((0, 3))
        return owners, tins, touts, normals, (mo, mshape, mt, mn)

    # ---- public -------------------------------------------------------------------------------
    def raycast(self, origin, direction, max_dist, ignore=()):
        o = np.asarray(origin, float).reshape(3)
        d = np.asarray(direction, float).reshape(3)
        nd = np.linalg.norm(d)
        if not (nd > 0 and np.all(np.isfinite(o)) and np.all(np.isfinite(d))):
            raise ValueError('raycast: origin %s / direction %s is not a point and a non-zero '
                             'direction' % (list(o), list(d)))
        d = d / nd
        max_dist = float(max_dist)
        self.sync()
        keep = self._keep(ignore)
        owners, tin, tout, nrm, (mo, _, mt, mn) = self._line(o, d, keep)
        best, bi, bn = np.inf, -1, None
        if len(owners):
            ok = (tin >= 0) & (tin <= tout) & (tin <= max_dist)
            if ok.any():
                cand = np.where(ok, tin, np.inf)
                i = int(np.argmin(cand))
                best, bi, bn = cand[i], owners[i], nrm[i]
        if len(mt):
            ok = (mt >= 0) & (mt <= max_dist)
            if ok.any():
                cand = np.where(ok, mt, np.inf)
                i = int(np.argmin(cand))
                if cand[i] < best:
                    best, bi, bn = cand[i], mo[i], mn[i]
        if bi < 0:
            return None
        model, link, mat = self.owners[bi]
        return Hit(best, model, link, o + best * d, bn, mat)

    def segment_intervals(self, a, b, ignore=(), incidence=False):
        a = np.asarray(a, float).reshape(3)
        b = np.asarray(b, float).reshape(3)
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise ValueError('segment_intervals: %s -> %s is not two points'
                             % (list(a), list(b)))
        L = float(np.linalg.norm(b - a))
        if L <= 0:
            return []
        d = (b - a) / L
        self.sync()
        keep = self._keep(ignore)
        owners, tin, tout, _, (mo, mshape, mt, _) = self._line(a, d, keep)
        out = []
        if len(owners):
            lo = np.maximum(tin, 0.0)
            hi = np.minimum(tout, L)
            for i in np.nonzero(hi > lo)[0]:
                model, link, mat = self.owners[owners[i]]
                iv = (float(lo[i]), float(hi[i]), model, link, mat)
                if incidence:
                    iv += (self.owner_thickness[owners[i]],)
                out.append(iv)
        if len(mt):
            for s in np.unique(mshape):
                ts = np.sort(mt[mshape == s])
                if len(ts) > 1:     # crossings through a shared edge count once
                    ts = ts[np.concatenate([[True], np.diff(ts) > 1e-9])]
                oi = self.meshes[s]['owner']
                model, link, mat = self.owners[oi]
                for j in range(0, len(ts) - 1, 2):
                    lo, hi = max(ts[j], 0.0), min(ts[j + 1], L)
                    if hi > lo:
                        iv = (float(lo), float(hi), model, link, mat)
                        if incidence:
                            iv += (self.owner_thickness[oi],)
                        out.append(iv)
        out.sort(key=lambda x: x[0])
        return out


def caster(world):
    """The world's RayCaster (made on first use)."""
    c = getattr(world, '_raycaster', None)
    if c is None or c.world is not world:
        c = RayCaster(world)
        world._raycaster = c
    return c


def raycast(world, origin, direction, max_dist, ignore=()):
    """First surface entered along the ray within max_dist (m), or None (see module doc)."""
    with world.lock:
        return caster(world).raycast(origin, direction, max_dist, ignore)


def segment_intervals(world, a, b, ignore=(), incidence=False):
    """[(enter, exit, model, link, material)] inside solid shapes along a->b (m from a);
    with ``incidence`` each entry also holds the shape's thickness (its smallest extent, m;
    None for a half-space): (exit - enter) / thickness is 1 for a head-on crossing of a
    slab, 1/cos(angle) at a slant, and below 1 where a corner is clipped."""
    with world.lock:
        return caster(world).segment_intervals(a, b, ignore, incidence)
