"""The world's data model: models made of links, joints, visuals, collisions, plugins.

Loaders (``sim_world.urdf`` for URDF/xacro, ``sim_world.sdf`` for world files) build these
objects; the physics backends, the renderer and the plugins read them. Poses of visuals,
collisions and inertials are relative to their link; a link's pose in the model follows
from the joint tree (``Model.link_poses``). Units are SI (REP 103).
"""
import logging
import math
import os

import numpy as np

from .transforms import Pose

log = logging.getLogger('sim_world.model')

__all__ = ['ModelError', 'parse_floats', 'check_position', 'MAX_MASS', 'MIN_MASS', 'MAX_INERTIA',
           'MAX_SIZE', 'MAX_POSITION', 'Geometry', 'Material', 'Visual', 'Collision', 'Inertial', 'Link',
           'Joint', 'joint_motion', 'MAX_JOINT_VALUE', 'PluginSpec', 'Light', 'Model', 'cuboid_inertia', 'cylinder_inertia',
           'sphere_inertia']


class ModelError(ValueError):
    """A model description that cannot be loaded; the message names the problem."""


# Bounds of what a model may declare, checked when it is parsed: beyond them ODE aborts the
# process (dxNormalize4 assertion) or Bullet's state turns NaN as soon as the body touches
# something (found by test/unit/test_fuzz_spawn.py: mass and inertia 1e300), or the body
# falls through the ground (a box of 1e30 m, a centre of mass 1e300 m off its link). They are
# far beyond any phone, room or building.
MIN_MASS = 1e-6          # kg (1 mg)
MAX_MASS = 1e6           # kg (1000 t)
MAX_INERTIA = 1e6        # kg m^2, every entry of a link's inertia tensor
MAX_SIZE = 1e4           # m: box edges, radii, lengths, plane sizes; |mesh scale|
MAX_POSITION = 1e6       # m: every offset of a model's parts, and a model's place in the world


def check_position(xyz, what):
    """ModelError unless every coordinate is within +-MAX_POSITION m."""
    if np.any(np.abs(np.asarray(xyz, dtype=float)) > MAX_POSITION):
        raise ModelError('%s: position %s is farther than %g m from its frame'
                         % (what, [float('%g' % v) for v in xyz], MAX_POSITION))


def parse_floats(text, n, what):
    """n finite numbers from a whitespace-separated text (URDF attributes, SDF elements);
    ModelError naming ``what`` otherwise. The one number-list parser of both model formats."""
    try:
        vals = np.array([float(v) for v in (text or '').split()])
    except ValueError:
        raise ModelError('%s: %r is not %d numbers' % (what, text, n))
    if vals.shape != (n,):
        raise ModelError('%s: %r is not %d numbers' % (what, text, n))
    if not np.all(np.isfinite(vals)):
        raise ModelError('%s: %r has a non-finite number' % (what, text))
    return vals


class Geometry(object):
    """A shape. kind: 'box' (size xyz), 'cylinder' (radius, length along z),
    'sphere' (radius), 'plane' (normal, size xy), 'mesh' (filename, scale)."""
    KINDS = ('box', 'cylinder', 'sphere', 'plane', 'mesh')

    def __init__(self, kind, size=None, radius=0.0, length=0.0, filename=None,
                 scale=(1.0, 1.0, 1.0), normal=(0.0, 0.0, 1.0)):
        if kind not in self.KINDS:
            raise ModelError('unknown geometry %r' % kind)
        self.kind = kind
        self.size = np.asarray(size if size is not None else (0.0, 0.0, 0.0), dtype=float)
        self.radius = float(radius)
        self.length = float(length)
        self.filename = filename
        self.scale = np.asarray(scale, dtype=float)
        self.normal = np.asarray(normal, dtype=float)
        self._check()

    def _check(self):
        vals = list(self.size) + [self.radius, self.length] + list(self.scale)
        if not all(np.isfinite(vals)):
            raise ModelError('%s geometry has a non-finite dimension' % self.kind)
        if max(abs(v) for v in vals) > MAX_SIZE:
            raise ModelError('%s geometry has a dimension of %g m, larger than %g m'
                             % (self.kind, max(abs(v) for v in vals), MAX_SIZE))
        if self.kind == 'mesh' and (self.scale.shape != (3,) or np.any(self.scale == 0)):
            raise ModelError('mesh scale must be three non-zero numbers, got %s'
                             % list(self.scale))
        if self.kind == 'box' and (self.size.shape != (3,) or np.any(self.size <= 0)):
            raise ModelError('box size must be three positive numbers, got %s' % list(self.size))
        if self.kind in ('sphere', 'cylinder') and self.radius <= 0:
            raise ModelError('%s radius must be positive, got %g' % (self.kind, self.radius))
        if self.kind == 'cylinder' and self.length <= 0:
            raise ModelError('cylinder length must be positive, got %g' % self.length)
        if self.kind == 'mesh' and not self.filename:
            raise ModelError('mesh geometry without a filename')

    def __repr__(self):
        if self.kind == 'box':
            return 'Geometry(box %s)' % list(self.size)
        if self.kind == 'mesh':
            return 'Geometry(mesh %s)' % self.filename
        return 'Geometry(%s r=%g l=%g)' % (self.kind, self.radius, self.length)


# Colours of the Gazebo materials the thesis's models name (Gazebo/Black ...).
GAZEBO_MATERIALS = {
    'Gazebo/Black': (0.0, 0.0, 0.0, 1.0), 'Gazebo/White': (1.0, 1.0, 1.0, 1.0),
    'Gazebo/Grey': (0.7, 0.7, 0.7, 1.0), 'Gazebo/Gray': (0.7, 0.7, 0.7, 1.0),
    'Gazebo/DarkGrey': (0.35, 0.35, 0.35, 1.0), 'Gazebo/Red': (1.0, 0.0, 0.0, 1.0),
    'Gazebo/Green': (0.0, 1.0, 0.0, 1.0), 'Gazebo/Blue': (0.0, 0.0, 1.0, 1.0),
    'Gazebo/Yellow': (1.0, 1.0, 0.0, 1.0), 'Gazebo/Wood': (0.55, 0.38, 0.22, 1.0),
    'Gazebo/WoodPallet': (0.6, 0.45, 0.3, 1.0), 'Gazebo/Orange': (1.0, 0.5, 0.0, 1.0),
    'Gazebo/Purple': (0.5, 0.0, 0.5, 1.0), 'Gazebo/Turquoise': (0.0, 0.8, 0.8, 1.0),
}


class Material(object):
    """Colour (rgba 0..1), optional texture image path, and whether it is lit."""

    def __init__(self, rgba=(0.8, 0.8, 0.8, 1.0), texture=None, name=None, lit=True):
        self.rgba = np.asarray(rgba, dtype=float)
        self.texture = texture
        self.name = name
        self.lit = lit

    @classmethod
    def named(cls, name):
        return cls(GAZEBO_MATERIALS.get(name, (0.8, 0.8, 0.8, 1.0)), name=name)

    def __repr__(self):
        return 'Material(%s, rgba=%s, texture=%s)' % (self.name, list(self.rgba), self.texture)


class Visual(object):
    def __init__(self, geometry, origin=None, material=None, name=''):
        self.geometry = geometry
        self.origin = origin or Pose()
        self.material = material or Material()
        self.name = name


class Collision(object):
    def __init__(self, geometry, origin=None, name='', material=None):
        self.geometry = geometry
        self.origin = origin or Pose()
        self.name = name
        self.material = material      # radio material name (sim_world.raycast), or None


class Inertial(object):
    """Mass (kg), centre of mass pose in the link, inertia tensor (kg m^2) in that frame."""

    def __init__(self, mass=1.0, origin=None, ixx=1e-3, ixy=0.0, ixz=0.0, iyy=1e-3,
                 iyz=0.0, izz=1e-3):
        self.mass = float(mass)
        self.origin = origin or Pose()
        self.inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], float)
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ModelError('inertial mass must be positive, got %r' % mass)
        if not MIN_MASS <= self.mass <= MAX_MASS:
            raise ModelError('inertial mass %g kg is outside [%g, %g] kg'
                             % (self.mass, MIN_MASS, MAX_MASS))
        if not np.all(np.isfinite(self.inertia)):
            raise ModelError('inertia has a non-finite entry')
        if np.any(np.abs(self.inertia) > MAX_INERTIA):
            raise ModelError('inertia has an entry larger than %g kg m^2: %s'
                             % (MAX_INERTIA, [float('%g' % v) for v in
                                              self.inertia[np.triu_indices(3)]]))


def cuboid_inertia(mass, sx, sy, sz):
    """(ixx, iyy, izz) of a solid cuboid with edge lengths sx, sy, sz along x, y, z.

    This is the thesis's equation 3.2. The thesis's appendix A writes the Nexus S as a box
    of size (height, width, depth) = (0.1239, 0.063, 0.01088) but takes ixx from height and
    depth, i.e. it treats the long edge as the y axis: cuboid_inertia(0.129, 0.063, 0.1239,
    0.01088) gives its numbers 0.000166, 0.000044, 0.000208.
    """
    return (mass / 12.0 * (sy * sy + sz * sz),
            mass / 12.0 * (sx * sx + sz * sz),
            mass / 12.0 * (sx * sx + sy * sy))


def cylinder_inertia(mass, radius, length):
    i = mass / 12.0 * (3 * radius * radius + length * length)
    return (i, i, mass * radius * radius / 2.0)


def sphere_inertia(mass, radius):
    i = 2.0 / 5.0 * mass * radius * radius
    return (i, i, i)


class Link(object):
    def __init__(self, name, inertial=None, visuals=None, collisions=None, gravity=True):
        self.name = name
        self.inertial = inertial
        self.visuals = visuals or []
        self.collisions = collisions or []
        self.gravity = gravity          # False for <turnGravityOff>true</turnGravityOff>
        self.self_collide = False


class Joint(object):
    """A joint as Gazebo's URDF converter (sdformat parser_urdf) reads it.

    type: 'fixed', 'revolute', 'continuous', 'prismatic' are simulated; 'floating' and
    'planar' are refused when the model is validated. ``origin``: the child link's frame in
    the parent link's frame at position zero (URDF ``<origin>``); ``axis``: unit vector in
    the joint (= child link) frame. ``lower``/``upper``: position limits (rad or m; None:
    unlimited; continuous joints have none); ``effort`` (N m or N) and ``velocity`` (rad/s
    or m/s): limits, -1 for none (Gazebo's convention); ``damping`` (N m s/rad) viscous,
    ``friction`` (N m) Coulomb; ``mimic``: (joint name, multiplier, offset) or None (kept,
    not simulated: Gazebo classic's converter ignores it too); ``preserve``: a fixed joint
    kept as a joint (``<preserveFixedJoint>``) instead of lumped; ``initial``: position at
    spawn (``spawn_model -J``)."""
    TYPES = ('fixed', 'revolute', 'continuous', 'prismatic', 'floating', 'planar')
    MOVABLE = ('revolute', 'continuous', 'prismatic')

    def __init__(self, name, type, parent, child, origin=None, axis=(1.0, 0.0, 0.0),
                 lower=None, upper=None, effort=-1.0, velocity=-1.0, damping=0.0,
                 friction=0.0, mimic=None, preserve=False):
        if type not in self.TYPES:
            raise ModelError('joint %r has unknown type %r' % (name, type))
        self.name = name
        self.type = type
        self.parent = parent
        self.child = child
        self.origin = origin or Pose()
        self.axis = np.asarray(axis, dtype=float)
        self.lower = None if lower is None else float(lower)
        self.upper = None if upper is None else float(upper)
        self.effort = float(effort)
        self.velocity = float(velocity)
        self.damping = float(damping)
        self.friction = float(friction)
        self.mimic = mimic
        self.preserve = bool(preserve)
        self.initial = 0.0
        self.frame = Pose()      # joint frame in the child link frame (SDF <pose>)

    @property
    def movable(self):
        return self.type in self.MOVABLE

    def check(self, what=''):
        """ModelError naming the joint for values no engine can simulate; returns the list
        of warnings (strings) for values Gazebo accepts and treats in its own way."""
        what = '%sjoint %r' % (what, self.name)
        warnings = []
        if self.type in ('floating', 'planar'):
            raise ModelError('%s: %s joints are not supported (Gazebo classic does not simulate '
                             'them either); use separate models or a fixed joint'
                             % (what, self.type))
        vals = [self.effort, self.velocity, self.damping, self.friction]
        vals += [v for v in (self.lower, self.upper) if v is not None]
        if not all(math.isfinite(v) for v in vals):
            raise ModelError('%s: limit or dynamics value is not finite' % what)
        if not self.movable:
            return warnings
        a = self.axis
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-9:
            raise ModelError('%s: axis %s is not a direction' % (what, list(np.ravel(a))))
        self.axis = a / np.linalg.norm(a)
        if self.damping < 0 or self.friction < 0:
            raise ModelError('%s: damping %g and friction %g must be >= 0'
                             % (what, self.damping, self.friction))
        for v, n in ((self.damping, 'damping'), (self.friction, 'friction')):
            if v > MAX_JOINT_VALUE:
                raise ModelError('%s: %s %g is larger than %g' % (what, n, v, MAX_JOINT_VALUE))
        if self.effort > MAX_JOINT_VALUE:
            warnings.append('%s: effort limit %g capped at %g' % (what, self.effort,
                                                                  MAX_JOINT_VALUE))
            self.effort = MAX_JOINT_VALUE
        for v in (self.lower, self.upper):
            if v is not None and abs(v) > MAX_POSITION:
                raise ModelError('%s: limit %g is beyond %g' % (what, v, MAX_POSITION))
        if self.type == 'continuous':
            self.lower = self.upper = None
        elif (self.lower is not None and self.upper is not None
              and self.lower > self.upper):
            # ODE (Gazebo's engine): "if the high stop is less than the low stop then both
            # stops will be ineffective"
            warnings.append('%s: lower limit %g is above upper limit %g: both limits are '
                            'ignored, as ODE in Gazebo does' % (what, self.lower, self.upper))
            self.lower = self.upper = None
        if self.effort == 0 and self.type != 'continuous':
            warnings.append('%s: effort limit 0: efforts on it are clamped to 0, as in Gazebo'
                            % what)
        return warnings

    def __repr__(self):
        return 'Joint(%s %s %s->%s)' % (self.name, self.type, self.parent, self.child)


#: bound of a joint's damping, friction and effort limit (fuzzed models: 1e9 N m)
MAX_JOINT_VALUE = 1e6


def joint_motion(joint, q):
    """Pose of the child frame in the joint frame at position ``q``."""
    if not joint.movable or q == 0:
        return Pose()
    if joint.type == 'prismatic':
        m = Pose(joint.axis * q)
    else:
        a = joint.axis / max(np.linalg.norm(joint.axis), 1e-12)
        s = math.sin(q / 2.0)
        m = Pose((0.0, 0.0, 0.0), (a[0] * s, a[1] * s, a[2] * s, math.cos(q / 2.0)))
    f = joint.frame
    if np.any(f.p) or f.q[3] != 1.0:
        return f * m * f.inverse()
    return m


class PluginSpec(object):
    """A plugin the model declares (Gazebo classic ``<plugin filename=...>`` or the 2011
    ``<controller:xxx plugin="lib....so">``).

    filename: the library name ('libgazebo_ros_camera.so'); name: the instance name;
    element: the plugin/controller XML element (xml.etree) holding its parameters;
    sensor: the enclosing sensor element (or None) with imageSize, updateRate, hfov ...;
    sensor_type: 'camera', 'imu' ... or None; link: the link named by
    ``<gazebo reference="...">`` (or None for a model plugin).
    """

    def __init__(self, filename, name='', element=None, sensor=None, sensor_type=None,
                 link=None):
        self.filename = filename
        self.name = name
        self.element = element
        self.sensor = sensor
        self.sensor_type = sensor_type
        self.link = link

    def param(self, *names, **kw):
        """Text of the first child element (of the plugin, then of the sensor) with one of
        ``names``; ``default`` when none is present."""
        for parent in (self.element, self.sensor):
            if parent is None:
                continue
            for n in names:
                for child in parent:
                    if _local(child.tag) == n and child.text is not None:
                        return child.text.strip()
        return kw.get('default')

    def __repr__(self):
        return 'PluginSpec(%s, name=%r, link=%r, sensor=%r)' % (
            self.filename, self.name, self.link, self.sensor_type)


def _local(tag):
    """Tag name without namespace or 'prefix:' part."""
    if not isinstance(tag, str):
        return ''
    if '}' in tag:
        tag = tag.split('}', 1)[1]
    return tag.split(':')[-1]


class Light(object):
    """A world light (SDF ``<light>``). ``direction`` is in the light's frame (its pose
    rotates it); spot lights (``kind='spot'``) also have a cone: ``inner_angle`` and
    ``outer_angle`` are the full apex angles (radians) of the bright inner cone and of the
    cone outside which the light gives nothing, ``falloff`` the exponent between them, as
    Gazebo (Ogre) defines SDF ``<spot>``; see ``spot_factor``."""

    def __init__(self, name, kind='directional', pose=None, diffuse=(0.8, 0.8, 0.8, 1.0),
                 specular=(0.2, 0.2, 0.2, 1.0), direction=(0.0, 0.0, -1.0),
                 attenuation=(1.0, 0.0, 0.0), range=20.0, inner_angle=0.0,
                 outer_angle=math.pi / 2, falloff=1.0):
        self.name = name
        self.kind = kind  # 'directional', 'point', 'spot'
        self.pose = pose or Pose()
        self.diffuse = np.asarray(diffuse, float)
        self.specular = np.asarray(specular, float)
        self.direction = np.asarray(direction, float)
        self.attenuation = attenuation
        self.range = range
        self.inner_angle = float(inner_angle)
        self.outer_angle = float(outer_angle)
        self.falloff = float(falloff)

    def world_direction(self):
        """Unit vector the light shines along, in the world frame."""
        d = self.pose.rotate(self.direction)
        n = float(np.linalg.norm(d))
        return d / n if n > 1e-9 else np.array([0.0, 0.0, -1.0])

    def spot_factor(self, to_point):
        """Share (0..1) of the light's intensity sent towards ``to_point`` (a world vector
        from the light to the lit point; any length): 1 for point and directional lights;
        for a spot, Ogre's (Gazebo's) cone ``clamp((cos a - cos(outer/2)) / (cos(inner/2) -
        cos(outer/2)), 0, 1) ** falloff`` with ``a`` the angle off the spot's direction."""
        if self.kind != 'spot':
            return 1.0
        v = np.asarray(to_point, float)
        n = float(np.linalg.norm(v))
        if n < 1e-12:
            return 1.0
        return float(self.cone(float(np.dot(v / n, self.world_direction()))))

    def cone(self, cos_angle):
        """The spot's cone factor of the cosine(s) of the angle off its axis (numpy arrays
        too): ``clamp((c - cos(outer/2)) / (cos(inner/2) - cos(outer/2)), 0, 1) ** falloff``."""
        c = np.asarray(cos_angle, float)
        ci = math.cos(min(self.inner_angle, self.outer_angle) / 2.0)
        co = math.cos(self.outer_angle / 2.0)
        if ci - co < 1e-9:
            return np.where(c >= co, 1.0, 0.0)
        t = np.clip((c - co) / (ci - co), 0.0, 1.0)
        return np.where(t > 0, t ** self.falloff, 0.0)


class Model(object):
    """A named set of links connected by joints, with a pose of its root link in the world."""

    def __init__(self, name, links=None, joints=None, pose=None, static=False, plugins=None,
                 base_dir=None, robot_namespace=''):
        self.name = name
        self.links = links or {}            # name -> Link (insertion ordered)
        self.joints = joints or []
        self.pose = pose or Pose()           # world pose of the root link
        self.static = static
        self.plugins = plugins or []         # [PluginSpec]
        self.base_dir = base_dir or os.getcwd()   # for relative mesh/texture paths
        self.robot_namespace = robot_namespace
        self.tf_prefix = None    # tf frame prefix; None: the robot namespace (see gazebo_api)
        self.source_xml = None
        self.warnings = []       # what validate() warned about (each logged once)

    @property
    def welded(self):
        """True when the root link is named ``world``: the model is welded to the world
        (Gazebo's URDF convention for a fixed-base robot)."""
        return self.root_link == 'world'

    def joint(self, name):
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError('model %r has no joint %r' % (self.name, name))

    def _warn(self, text):
        if text not in self.warnings:
            self.warnings.append(text)
            log.warning('model %r: %s', self.name, text)

    @property
    def root_link(self):
        children = set(j.child for j in self.joints)
        roots = [n for n in self.links if n not in children]
        if not roots:
            raise ModelError('model %r has no root link (joint loop?)' % self.name)
        return roots[0]

    def validate(self):
        if not self.links:
            raise ModelError('model %r has no links' % self.name)
        names = set()
        jnames = set()
        for j in self.joints:
            if j.name in jnames:
                raise ModelError('model %r: joint %r is defined twice' % (self.name, j.name))
            jnames.add(j.name)
            for w in j.check():
                self._warn(w)
            if j.parent == j.child:
                raise ModelError('joint %r joins link %r to itself' % (j.name, j.parent))
            if j.parent not in self.links:
                raise ModelError('joint %r names unknown parent link %r' % (j.name, j.parent))
            if j.child not in self.links:
                raise ModelError('joint %r names unknown child link %r' % (j.name, j.child))
            if j.child in names:
                raise ModelError('link %r is the child of two joints' % j.child)
            names.add(j.child)
        roots = [n for n in self.links if n not in names]
        if len(roots) != 1:
            raise ModelError('model %r must have exactly one root link, has %d: %s'
                             % (self.name, len(roots), roots))
        self.link_poses()  # detects loops / unreachable links
        self._check_mimic()
        self.resolve_paths()
        for p in self.plugins:
            if p.link is not None and p.link not in self.links:
                raise ModelError('<gazebo reference="%s"> names an unknown link of model %r'
                                 % (p.link, self.name))
        return self

    def _check_mimic(self):
        """A mimic naming an unknown or non-movable joint, or a mimic cycle: one warning
        naming the joint, and the mimic is dropped (it is never simulated: Gazebo classic's
        converter ignores <mimic> too)."""
        by_name = dict((j.name, j) for j in self.joints)
        for j in self.joints:
            if j.mimic is None:
                continue
            target = by_name.get(j.mimic[0])
            if target is None or not target.movable:
                self._warn('joint %r mimics %r, which is not a movable joint of the model: '
                           'mimic dropped' % (j.name, j.mimic[0]))
                j.mimic = None
        for j in self.joints:
            seen, k = [j.name], j
            while k is not None and k.mimic is not None:
                k = by_name.get(k.mimic[0])
                if k is not None and k.name in seen:
                    self._warn('joints %s mimic each other in a cycle: mimic of %r dropped'
                               % (seen, j.name))
                    j.mimic = None
                    break
                if k is not None:
                    seen.append(k.name)

    def joint_poses(self, positions=None):
        """{link name: pose in the model frame} with movable joints at ``positions``
        ({joint name: value}; missing ones at their ``initial`` value)."""
        positions = positions or {}
        poses = {self.root_link: Pose()}
        by_parent = {}
        for j in self.joints:
            by_parent.setdefault(j.parent, []).append(j)
        stack = [self.root_link]
        while stack:
            parent = stack.pop()
            for j in by_parent.get(parent, []):
                poses[j.child] = poses[parent] * j.origin * joint_motion(
                    j, positions.get(j.name, j.initial))
                stack.append(j.child)
        return poses

    def link_poses(self):
        """{link name: pose of the link in the model (root link) frame}, from joint origins
        at their zero position."""
        poses = {self.root_link: Pose()}
        by_parent = {}
        for j in self.joints:
            by_parent.setdefault(j.parent, []).append(j)
        stack = [self.root_link]
        while stack:
            parent = stack.pop()
            for j in by_parent.get(parent, []):
                if j.child in poses:
                    raise ModelError('joint loop at link %r' % j.child)
                poses[j.child] = poses[parent] * j.origin
                stack.append(j.child)
        missing = set(self.links) - set(poses)
        if missing:
            raise ModelError('links not connected to the root: %s' % sorted(missing))
        return poses

    def resolve_paths(self):
        """Make every mesh and texture reference an absolute file path (idempotent)."""
        packs = {}          # one rospkg.RosPack for the model: one walk of ROS_PACKAGE_PATH
        for link in self.links.values():
            for v in link.visuals:
                if v.geometry.kind == 'mesh':
                    v.geometry.filename = self.resolve_path(v.geometry.filename, packs)
                if v.material.texture:
                    v.material.texture = self.resolve_path(v.material.texture, packs)
            for c in link.collisions:
                if c.geometry.kind == 'mesh':
                    c.geometry.filename = self.resolve_path(c.geometry.filename, packs)

    def resolve_path(self, path, packs=None):
        """Absolute path of a mesh/texture reference (file://, package://, relative).
        ``packs``: a dict to keep the rospkg.RosPack in across calls (its package walk)."""
        if path is None:
            return None
        if path.startswith('file://'):
            path = path[len('file://'):]
        if path.startswith('package://'):
            pkg, _, rest = path[len('package://'):].partition('/')
            try:
                import rospkg
                packs = {} if packs is None else packs
                if 'rospack' not in packs:
                    packs['rospack'] = rospkg.RosPack()
                return os.path.join(packs['rospack'].get_path(pkg), rest)
            except Exception:  # noqa: BLE001 - rospkg raises various errors
                return _on_model_path(pkg, rest) or os.path.join(self.base_dir, rest)
        if path.startswith('model://'):
            name, _, rest = path[len('model://'):].partition('/')
            return _on_model_path(name, rest) or \
                os.path.join(self.base_dir, path[len('model://'):])
        if not os.path.isabs(path):
            return os.path.normpath(os.path.join(self.base_dir, path))
        return path


def _on_model_path(name, rest):
    """``<dir>/<name>/<rest>`` for the first entry of ``GAZEBO_MODEL_PATH`` that has it (as
    Gazebo finds ``model://name/...``; here also ``package://name/...`` when ROS knows no
    package of that name, e.g. pybullet_data's xarm/xarm_description with
    ``GAZEBO_MODEL_PATH=<pybullet_data>/xarm``); None when none has it."""
    for d in os.environ.get('GAZEBO_MODEL_PATH', '').split(os.pathsep):
        if d:
            cand = os.path.join(d, name, rest)
            if os.path.exists(cand):
                return cand
    return None
