"""One mesh loader for physics and rendering.

Physics (``sim_world.physics``: ODE voxel boxes, Bullet triangle meshes/hulls) and the renderer
(``sim_world.render.shapes``) read mesh files through :func:`load` only, so a mesh collides
exactly where it is drawn. Here, in one place:

- files are read with trimesh (OBJ, STL, DAE, PLY ...), the scene graph's node transforms
  applied;
- Collada's ``<unit meter="...">`` and ``<up_axis>`` (Y_UP, X_UP -> Gazebo's Z up) are applied
  (read with pycollada); the Nexus S export of the thesis is in centimetres with Y up, so
  without this it would be 100 times too large and lying on its side;
- the ``<mesh scale>`` of the model applies after the unit/up fix (in the model frame);
- winding repair: faces sharing an edge get consistent winding, closed parts face outward
  (CAD exports often scramble it; the thesis's "faulty back view", figure 3.3b);
- faces with non-finite vertices are dropped; a file without triangles is an error.

Results are cached per (file, modification time, scale): a world with many copies of a
model reads its meshes once, for the renderer and the physics engine together.
Errors raise :class:`MeshLoadError` (a ValueError) naming the file and the cause.
"""
import logging
import os
import threading
from collections import deque

import numpy as np

__all__ = ['MeshLoadError', 'MeshPart', 'LoadedMesh', 'load', 'collada_fix', 'fix_winding',
           'merge_ids', 'clear_cache']

log = logging.getLogger('sim_world.mesh')


class MeshLoadError(ValueError):
    """A mesh file that cannot be read; the message names the file and the cause."""


class MeshPart(object):
    """One geometry of a mesh file in the model frame (metres, Z up, scaled).

    vertices: (N, 3) float64; faces: (M, 3) int64 with repaired winding; closed: every
    edge shared by exactly two faces; uv: (N, 2) texture coordinates as in the file (v up)
    or None; visual: trimesh's visual of the geometry (colour, material) or None."""
    __slots__ = ('vertices', 'faces', 'closed', 'uv', 'visual')

    def __init__(self, vertices, faces, closed, uv=None, visual=None):
        self.vertices = vertices
        self.faces = faces
        self.closed = closed
        self.uv = uv
        self.visual = visual


class LoadedMesh(object):
    """All parts of a mesh file; ``vertices``/``faces`` are the parts merged by position
    (what a collision shape needs: shared vertices, no degenerate triangles)."""

    def __init__(self, path, scale, parts):
        self.path = path
        self.scale = scale
        self.parts = parts
        self._merged = None

    @property
    def closed(self):
        return all(p.closed for p in self.parts)

    def _merge(self):
        if self._merged is None:
            v = np.vstack([p.vertices for p in self.parts])
            offs = np.cumsum([0] + [len(p.vertices) for p in self.parts[:-1]])
            f = np.vstack([p.faces + o for p, o in zip(self.parts, offs)])
            vid, n = merge_ids(v)
            verts = np.zeros((n, 3))
            verts[vid] = v
            faces = vid[f]
            ok = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & \
                 (faces[:, 0] != faces[:, 2])
            faces = faces[ok].astype(np.int32)
            if len(faces) == 0:
                raise MeshLoadError('mesh %s has no triangles of non-zero size' % self.path)
            self._merged = (verts, faces)
        return self._merged

    @property
    def vertices(self):
        return self._merge()[0]

    @property
    def faces(self):
        return self._merge()[1]

    def bounds(self):
        v = np.vstack([p.vertices[p.faces.reshape(-1)] for p in self.parts])
        return v.min(axis=0), v.max(axis=0)


_cache = {}
_cache_lock = threading.Lock()


def clear_cache():
    with _cache_lock:
        _cache.clear()


def collada_fix(path):
    """(scale, 3x3 rotation) that Collada's <unit meter> and <up_axis> ask for."""
    try:
        import collada
        doc = collada.Collada(path, ignore=[collada.DaeUnsupportedError,
                                            collada.DaeBrokenRefError])
        unit = doc.assetInfo.unitmeter or 1.0
        up = str(doc.assetInfo.upaxis or 'Z_UP')
    except Exception as e:  # noqa: BLE001 - pycollada raises many kinds
        log.warning('cannot read Collada asset info of %s (%s); assuming metres, Z_UP', path, e)
        return 1.0, np.eye(3)
    if up.endswith('Y_UP'):
        rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])      # y up -> z up
    elif up.endswith('X_UP'):
        rot = np.array([[0, 0, -1.0], [0, 1, 0], [1, 0, 0]])      # x up -> z up
    else:
        rot = np.eye(3)
    return float(unit), rot


def merge_ids(v):
    """(id per vertex, number of distinct positions): vertices merged by position."""
    v = np.asarray(v, float)
    scale = max(float(np.abs(v).max()) if len(v) else 1.0, 1e-9)
    key = np.round(v / (scale * 1e-7)).astype(np.int64)
    uniq, vid = np.unique(key, axis=0, return_inverse=True)
    return vid.reshape(-1), len(uniq)


def fix_winding(v, f):
    """(faces with consistent winding, outward where a part is closed; all parts closed?).

    Vertices are merged by position for the analysis only (texture coordinates stay with
    their corners). Faces sharing an edge (exactly two per edge) must run the edge in
    opposite directions; a breadth-first walk flips the ones that do not. A closed part
    whose signed volume is negative is turned inside out.
    """
    f = np.asarray(f, np.int64)
    m = len(f)
    if m == 0:
        return f, False
    vid, _ = merge_ids(v)
    fm = vid[f]
    a = fm.reshape(-1)
    b = np.roll(fm, -1, axis=1).reshape(-1)            # directed edges a -> b per corner
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo * (int(fm.max()) + 1) + hi
    order = np.argsort(key, kind='stable')
    ks = key[order]
    starts = np.flatnonzero(np.r_[True, ks[1:] != ks[:-1]])
    counts = np.diff(np.r_[starts, len(ks)])
    degenerate = a == b
    edge_face = np.repeat(np.arange(m), 3)
    # neighbours across manifold edges (exactly two faces), with "same direction" flags
    two = starts[counts == 2]
    e1, e2 = order[two], order[two + 1]
    keep = ~(degenerate[e1] | degenerate[e2])
    e1, e2 = e1[keep], e2[keep]
    f1, f2 = edge_face[e1], edge_face[e2]
    same = a[e1] == a[e2]                              # same direction: winding disagrees
    adj = [[] for _ in range(m)]
    for x, y, sd in zip(f1.tolist(), f2.tolist(), same.tolist()):
        if x != y:
            adj[x].append((y, sd))
            adj[y].append((x, sd))
    open_edge = np.zeros(m, bool)
    bad = starts[counts != 2]
    for s0, c in zip(bad.tolist(), counts[counts != 2].tolist()):
        open_edge[edge_face[order[s0:s0 + c]]] = True
    flip = np.zeros(m, bool)
    seen = np.zeros(m, bool)
    tri = np.asarray(v, float)[f]
    all_closed = True
    for s0 in range(m):
        if seen[s0]:
            continue
        comp = [s0]
        seen[s0] = True
        q = deque([s0])
        while q:
            x = q.popleft()
            for y, sd in adj[x]:
                if not seen[y]:
                    seen[y] = True
                    flip[y] = flip[x] ^ sd
                    comp.append(y)
                    q.append(y)
        comp = np.array(comp)
        if open_edge[comp].any():
            all_closed = False
            continue
        t = tri[comp]
        vol = np.einsum('ij,ij->i', t[:, 0], np.cross(t[:, 1], t[:, 2]))
        vol = np.where(flip[comp], -vol, vol).sum()
        if vol < 0:
            flip[comp] = ~flip[comp]
    out = f.copy()
    out[flip] = out[flip][:, ::-1]
    return out, all_closed


def _read(path, scale):
    if not path or not os.path.isfile(path):
        raise MeshLoadError('mesh file %r not found' % path)
    try:
        import trimesh
    except ImportError as e:  # pragma: no cover - trimesh is in tools/requirements.txt
        raise MeshLoadError('trimesh is not installed: %s' % e)
    try:
        scene = trimesh.load(path, force='scene', process=False)
    except Exception as e:  # noqa: BLE001 - loaders raise many kinds
        raise MeshLoadError('cannot read mesh %s: %s' % (path, e))
    unit, rot = 1.0, np.eye(3)
    if path.lower().endswith('.dae'):
        unit, rot = collada_fix(path)
    xf = np.asarray(scale, float).reshape(3, 1) * (rot * unit)  # scale after the unit/up fix
    geoms = []
    try:
        for node in scene.graph.nodes_geometry:
            T, gname = scene.graph[node]
            g = scene.geometry.get(gname)
            if g is not None and hasattr(g, 'faces') and len(g.faces):
                geoms.append((T, g))
    except Exception as e:  # noqa: BLE001
        raise MeshLoadError('cannot read mesh %s: %s' % (path, e))
    parts = []
    for T, g in geoms:
        g = g.copy()
        try:
            g.apply_transform(T)
        except Exception:  # noqa: BLE001
            pass
        v = np.asarray(g.vertices, float).dot(xf.T)
        f = np.asarray(g.faces, np.int64)
        if np.linalg.det(xf) < 0:          # mirrored by a negative scale: keep winding outward
            f = f[:, ::-1]
        good = np.all(np.isfinite(v), axis=1)
        if not good.all():
            f = f[np.all(good[f], axis=1)]
            v = np.where(good[:, None], v, 0.0)
        if len(f) == 0:
            continue
        f, closed = fix_winding(v, f)
        visual = getattr(g, 'visual', None)
        uv = None
        if visual is not None and getattr(visual, 'kind', None) == 'texture':
            raw_uv = getattr(visual, 'uv', None)
            if raw_uv is not None and len(raw_uv) == len(v):
                uv = np.asarray(raw_uv, float)
        parts.append(MeshPart(v, f, closed, uv, visual))
    if not parts:
        raise MeshLoadError('mesh %s has no triangles' % path)
    return LoadedMesh(path, scale, parts)


def load(path, scale=(1.0, 1.0, 1.0)):
    """The :class:`LoadedMesh` of a mesh file with the model's scale (see module doc);
    cached per (file, modification time, scale). Raises MeshLoadError."""
    scale = tuple(float(s) for s in np.broadcast_to(np.asarray(scale, float), (3,)))
    try:
        st = os.stat(path)
        key = (os.path.realpath(path), st.st_mtime_ns, st.st_size, scale)
    except (OSError, TypeError, ValueError):
        raise MeshLoadError('mesh file %r not found' % (path,))
    with _cache_lock:
        mesh = _cache.get(key)
    if mesh is None:
        mesh = _read(path, scale)
        with _cache_lock:
            _cache[key] = mesh
    return mesh
