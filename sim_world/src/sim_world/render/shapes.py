"""Triangle data for the renderer: primitives and meshes (no OpenGL here).

Every shape becomes a ``MeshData``: non-indexed triangles as float32 arrays of positions,
normals and texture coordinates (3 vertices per triangle), in the visual's frame, with the
geometry's scale applied. Mesh files are read by ``sim_world.mesh`` (the loader physics uses
too: trimesh, Collada's ``<unit meter>`` and ``<up_axis>``, consistent winding); here they get
normals computed from their faces: smooth within a crease angle, flat across sharper edges. A mesh
that is not closed is marked ``double_sided`` so the renderer draws both sides lit.

Box faces and texture coordinates: a box is six faces in the order of ``BOX_FACES``; the
image shown on a face (material texture or video texture) has its top edge towards the
face's "up" axis and is seen unmirrored from outside: ``+z`` face: up = +x; ``-z``: up =
-x; ``+x``/``-x``/``+y``/``-y`` faces: up = +z. This is the layout of Gazebo classic's box
mesh (common::MeshManager::CreateBox), so world files textured for Gazebo look the same.
Texture coordinate t = 0 is the image's top row.
"""
import logging
import math

import numpy as np

from .. import mesh as _mesh
from ..mesh import MeshLoadError

__all__ = ['MeshData', 'MeshLoadError', 'BOX_FACES', 'box', 'cylinder', 'sphere', 'plane',
           'load_mesh', 'crease_normals', 'geometry_mesh']

log = logging.getLogger('sim_world.render')

BOX_FACES = ('+x', '-x', '+y', '-y', '+z', '-z')
_AXES = {'+x': (0, 1.0), '-x': (0, -1.0), '+y': (1, 1.0), '-y': (1, -1.0),
         '+z': (2, 1.0), '-z': (2, -1.0)}


class MeshData(object):
    """Triangles ready for a vertex buffer.

    positions, normals: (n, 3) float32; uvs: (n, 2) float32; n = 3 * triangles.
    faces: {face name: (first vertex, vertex count)} for boxes, else {}.
    double_sided: draw without culling and with two-sided lighting.
    parts: [(first vertex, count, rgba or None, texture image or None)] for meshes
    whose file brings its own colours/textures (used when the visual has no material).
    """

    def __init__(self, positions, normals, uvs=None, faces=None, double_sided=False,
                 parts=None):
        self.positions = np.ascontiguousarray(positions, np.float32).reshape(-1, 3)
        self.normals = np.ascontiguousarray(normals, np.float32).reshape(-1, 3)
        n = len(self.positions)
        if uvs is None:
            uvs = np.zeros((n, 2), np.float32)
        self.uvs = np.ascontiguousarray(uvs, np.float32).reshape(-1, 2)
        if len(self.normals) != n or len(self.uvs) != n or n % 3:
            raise ValueError('inconsistent mesh arrays: %d positions, %d normals, %d uvs'
                             % (n, len(self.normals), len(self.uvs)))
        self.faces = faces or {}
        self.double_sided = double_sided
        self.parts = parts or []

    @property
    def count(self):
        return len(self.positions)

    def interleaved(self):
        """(n, 8) float32: x y z nx ny nz s t."""
        return np.ascontiguousarray(np.hstack([self.positions, self.normals, self.uvs]),
                                    np.float32)

    def bounds(self):
        if not self.count:
            return np.zeros(3), np.zeros(3)
        return self.positions.min(axis=0), self.positions.max(axis=0)


def _face_frame(face):
    axis, sign = _AXES[face]
    n = np.zeros(3)
    n[axis] = sign
    if axis == 2:
        up = np.array([sign, 0.0, 0.0])        # +z: image top at +x; -z: at -x (as Gazebo)
    else:
        up = np.array([0.0, 0.0, 1.0])
    right = np.cross(up, n)
    return n, up, right


CELL = 0.25          # target edge length (m) of the grid big faces are split into
MAX_DIV = 16         # at most this many cells along a face edge


def _divisions(length):
    return int(min(MAX_DIV, max(1, math.ceil(length / CELL - 1e-9))))


def _grid(origin, right, up, nr, nu):
    """Triangles of a quad split into nr x nu cells; origin = bottom-left corner, right/up =
    full edge vectors. Returns positions (n, 3), uvs (n, 2) with t = 0 at the top edge."""
    i, j = np.meshgrid(np.arange(nr), np.arange(nu), indexing='ij')
    i, j = i.ravel(), j.ravel()
    corners = []
    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 0), (1, 1), (0, 1)):
        corners.append(((i + di) / float(nr), (j + dj) / float(nu)))
    a = np.stack([c[0] for c in corners], axis=1).reshape(-1)
    b = np.stack([c[1] for c in corners], axis=1).reshape(-1)
    pos = origin[None, :] + a[:, None] * right[None, :] + b[:, None] * up[None, :]
    uv = np.stack([a, 1.0 - b], axis=1)
    return pos, uv


def box(size):
    """Box centred at the origin with edge lengths ``size`` (x, y, z). Faces longer than
    CELL are split into a grid so per-vertex lighting (point lights) stays smooth."""
    h = np.asarray(size, float) / 2.0
    pos, nor, uv, faces = [], [], [], {}
    first = 0
    for face in BOX_FACES:
        n, up, right = _face_frame(face)
        c = n * h
        r = right * h
        u = up * h
        bl = c - r - u
        nr = _divisions(2 * np.linalg.norm(r))
        nu = _divisions(2 * np.linalg.norm(u))
        p, t = _grid(bl, 2 * r, 2 * u, nr, nu)
        faces[face] = (first, len(p))
        first += len(p)
        pos.append(p)
        uv.append(t)
        nor.append(np.repeat(n[None, :], len(p), axis=0))
    return MeshData(np.vstack(pos), np.vstack(nor), np.vstack(uv), faces=faces)


def cylinder(radius, length, segments=32):
    """Cylinder along z centred at the origin: smooth side, flat caps."""
    a = np.linspace(0.0, 2 * math.pi, segments + 1)
    ca, sa = np.cos(a), np.sin(a)
    hz = length / 2.0
    pos, nor, uv = [], [], []
    for i in range(segments):
        j = i + 1
        p0 = (radius * ca[i], radius * sa[i], -hz)
        p1 = (radius * ca[j], radius * sa[j], -hz)
        p2 = (radius * ca[j], radius * sa[j], hz)
        p3 = (radius * ca[i], radius * sa[i], hz)
        n0 = (ca[i], sa[i], 0.0)
        n1 = (ca[j], sa[j], 0.0)
        s0, s1 = float(i) / segments, float(j) / segments
        pos += [p0, p1, p2, p0, p2, p3]
        nor += [n0, n1, n1, n0, n1, n0]
        uv += [(s0, 1), (s1, 1), (s1, 0), (s0, 1), (s1, 0), (s0, 0)]
        # caps (counter-clockwise seen from outside)
        pos += [(0, 0, hz), p3, p2]
        nor += [(0, 0, 1)] * 3
        uv += [(0.5, 0.5), (0.5 + ca[i] / 2, 0.5 - sa[i] / 2), (0.5 + ca[j] / 2, 0.5 - sa[j] / 2)]
        pos += [(0, 0, -hz), p1, p0]
        nor += [(0, 0, -1)] * 3
        uv += [(0.5, 0.5), (0.5 + ca[j] / 2, 0.5 + sa[j] / 2), (0.5 + ca[i] / 2, 0.5 + sa[i] / 2)]
    return MeshData(pos, nor, uv)


def sphere(radius, slices=32, stacks=16):
    """UV sphere centred at the origin."""
    th = np.linspace(0.0, math.pi, stacks + 1)          # from +z down
    ph = np.linspace(0.0, 2 * math.pi, slices + 1)
    T, P = np.meshgrid(th, ph, indexing='ij')
    n = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
    st = np.stack([P / (2 * math.pi), T / math.pi], axis=-1)
    tri = []
    for i in range(stacks):
        for j in range(slices):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            if i != 0:
                tri.append((a, b, d))
            if i != stacks - 1:
                tri.append((d, b, c))
    idx = np.array(tri).reshape(-1, 2)
    nn = n[idx[:, 0], idx[:, 1]]
    return MeshData(nn * radius, nn, st[idx[:, 0], idx[:, 1]])


def plane(normal=(0, 0, 1), size=(1.0, 1.0)):
    """A double-sided rectangle through the origin, perpendicular to ``normal``."""
    n = np.asarray(normal, float)
    nl = np.linalg.norm(n)
    n = n / nl if nl > 1e-9 else np.array([0, 0, 1.0])
    ref = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    up = ref - n * n.dot(ref)
    up /= np.linalg.norm(up)
    right = np.cross(up, n)
    sx, sy = (list(size) + [1.0, 1.0])[:2]
    if sx <= 0 or sy <= 0:
        sx, sy = 1.0, 1.0
    r, u = right * sy / 2.0, up * sx / 2.0
    pos, uv = _grid(-r - u, 2 * r, 2 * u, min(32, _divisions(sy)), min(32, _divisions(sx)))
    return MeshData(pos, np.repeat(n[None, :], len(pos), axis=0), uv, double_sided=True)


def crease_normals(vertices, faces, angle_deg=40.0):
    """Per-corner normals ((m*3, 3) float) of triangles ``faces`` over ``vertices``.

    Each corner gets the angle-weighted mean normal of the triangles around its vertex
    (vertices merged by position) whose normal is within ``angle_deg`` of its own
    triangle's: smooth on curved surfaces, flat across sharp edges. Degenerate triangles get
    their neighbours' normal or +z.
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    m = len(f)
    if m == 0:
        return np.zeros((0, 3))
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    unit = np.zeros_like(cross)
    ok = area2 > 1e-20
    unit[ok] = cross[ok] / area2[ok, None]
    vid, _ = _mesh.merge_ids(v)                        # merge vertices by position
    corner_v = vid[f].reshape(-1)
    corner_f = np.repeat(np.arange(m), 3)
    order = np.argsort(corner_v, kind='stable')
    sv = corner_v[order]
    starts = np.flatnonzero(np.r_[True, sv[1:] != sv[:-1]])
    counts = np.diff(np.r_[starts, len(sv)])
    k = np.repeat(counts, counts)                 # group size of each sorted corner
    gstart = np.repeat(starts, counts)            # group start of each sorted corner
    pi = np.repeat(np.arange(len(sv)), k)         # sorted corner index, one row per pair
    offs = np.arange(len(pi)) - np.repeat(np.cumsum(k) - k, k)
    pj = np.repeat(gstart, k) + offs
    fi = corner_f[order][pi]
    fj = corner_f[order][pj]
    cos_lim = math.cos(math.radians(angle_deg))
    dots = np.einsum('ij,ij->i', unit[fi], unit[fj])
    keep = (dots >= cos_lim) | (fi == fj)
    # weight: the angle of triangle fj at the shared vertex (symmetric on regular meshes)
    cj = order[pj[keep]] % 3                      # corner slot of the partner in its face
    e1 = tri[fj[keep], (cj + 1) % 3] - tri[fj[keep], cj]
    e2 = tri[fj[keep], (cj + 2) % 3] - tri[fj[keep], cj]
    n1 = np.linalg.norm(e1, axis=1)
    n2 = np.linalg.norm(e2, axis=1)
    with np.errstate(all='ignore'):
        ang = np.arccos(np.clip(np.einsum('ij,ij->i', e1, e2) / (n1 * n2), -1.0, 1.0))
    ang = np.nan_to_num(ang)
    acc = np.zeros((len(sv), 3))
    w = unit[fj[keep]] * ang[:, None]
    for c in range(3):
        acc[:, c] = np.bincount(pi[keep], weights=w[:, c], minlength=len(sv))
    out = np.empty_like(acc)
    out[order] = acc
    ln = np.linalg.norm(out, axis=1)
    bad = ln < 1e-20
    out[~bad] /= ln[~bad, None]
    out[bad] = np.repeat(unit, 3, axis=0)[bad]
    still = np.linalg.norm(out, axis=1) < 0.5
    out[still] = (0.0, 0.0, 1.0)
    return out


def _image_of(visual):
    """RGBA uint8 image of a trimesh TextureVisuals' material, or None."""
    mat = getattr(visual, 'material', None)
    img = None
    for attr in ('image', 'baseColorTexture'):
        img = getattr(mat, attr, None)
        if img is not None:
            break
    if img is None:
        return None
    try:
        return np.asarray(img.convert('RGBA'))
    except Exception:  # noqa: BLE001
        return None


def _color_of(visual):
    mat = getattr(visual, 'material', None)
    for attr in ('main_color', 'baseColorFactor', 'diffuse'):
        c = getattr(mat, attr, None)
        if c is not None:
            c = np.asarray(c, float).reshape(-1)
            if c.size >= 3:
                if c.max() > 1.0:
                    c = c / 255.0
                return tuple(list(c[:3]) + [c[3] if c.size > 3 else 1.0])
    if getattr(visual, 'kind', None) in ('face', 'vertex'):
        try:
            c = np.asarray(visual.main_color, float) / 255.0
            return tuple(c[:4])
        except Exception:  # noqa: BLE001
            return None
    return None


def load_mesh(path, scale=(1.0, 1.0, 1.0), crease_deg=40.0):
    """Read a mesh file into MeshData (see module doc). Raises MeshLoadError.

    The file is read by ``sim_world.mesh.load`` (shared with physics: units, up axis, scale,
    winding repair, cache); here only normals, texture coordinates and colours are added."""
    lm = _mesh.load(path, scale)
    pos, nor, uvs, parts = [], [], [], []
    first = 0
    double = False
    for part in lm.parts:
        v, f = part.vertices, part.faces
        double = double or not part.closed
        corners = f.reshape(-1)
        pos.append(v[corners])
        nor.append(crease_normals(v, f, crease_deg))
        uv = None
        img = None
        visual = part.visual
        if part.uv is not None:
            uv = part.uv[corners].copy()
            uv[:, 1] = 1.0 - uv[:, 1]          # file uv: v=0 at the bottom; ours: t=0 at top
            img = _image_of(visual)
        uvs.append(uv if uv is not None else np.zeros((len(corners), 2)))
        parts.append((first, len(corners), _color_of(visual) if visual is not None else None,
                      img))
        first += len(corners)
    return MeshData(np.vstack(pos), np.vstack(nor), np.vstack(uvs), double_sided=double,
                    parts=parts)


def geometry_mesh(geometry, resolve_path=None):
    """MeshData of a ``sim_world.model.Geometry``."""
    k = geometry.kind
    if k == 'box':
        return box(geometry.size)
    if k == 'cylinder':
        return cylinder(geometry.radius, geometry.length)
    if k == 'sphere':
        return sphere(geometry.radius)
    if k == 'plane':
        return plane(geometry.normal, geometry.size[:2])
    if k == 'mesh':
        path = resolve_path(geometry.filename) if resolve_path else geometry.filename
        return load_mesh(path, geometry.scale)
    raise MeshLoadError('unknown geometry kind %r' % k)
