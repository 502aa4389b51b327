"""URDF and xacro loading into ``sim_world.model.Model``.

Both Gazebo extension syntaxes load:

* 2011 (thesis appendix A, Gazebo 0.x)::

    <gazebo reference="link"><sensor:camera name="..."><imageSize>480 800</imageSize>
      <controller:gazebo_ros_camera name="..." plugin="libgazebo_ros_camera.so">...
    <gazebo><controller:gazebo_ros_video plugin="libgazebo_ros_video.so">...

* Gazebo classic::

    <gazebo reference="link"><sensor type="camera" name="..."><update_rate>30</update_rate>
      <camera><horizontal_fov>1.0</horizontal_fov><image><width>480</width>...</camera>
      <plugin name="..." filename="libgazebo_ros_camera.so">...
    <gazebo><plugin name="..." filename="libgazebo_ros_video.so">...

``<turnGravityOff>true</turnGravityOff>`` (or classic ``<gravity>false</gravity>``) and
``<material>Gazebo/Black</material>`` in ``<gazebo reference=...>`` apply to the link.
Every problem raises ``ModelError`` with a message that names the element.
"""
import os
import xml.etree.ElementTree as ET

import numpy as np

from .model import (Collision, Geometry, Inertial, Joint, Link, Material, Model, ModelError,
                    PluginSpec, Visual, _local, check_position, parse_floats)
from .transforms import InvalidPose, Pose

__all__ = ['load_urdf_file', 'parse_urdf', 'process_xacro', 'parse_pose_attrs']


def process_xacro(path, mappings=None):
    """Expand a xacro file to URDF text (``xacro`` from PyPI, the ROS implementation)."""
    if not os.path.isfile(path):
        raise ModelError('model file %s does not exist' % path)
    try:
        import xacro
    except ImportError:
        raise ModelError('cannot expand %s: the xacro module is not installed' % path)
    try:
        # xacro defines 'pi' itself; the thesis's file redefines it: say nothing about that
        import io
        import contextlib
        with contextlib.redirect_stderr(io.StringIO()):
            doc = xacro.process_file(path, mappings=mappings or {})
    except Exception as e:  # noqa: BLE001 - xacro raises XacroException, ExpatError, NameError...
        raise ModelError('xacro could not expand %s: %s' % (path, str(e).strip() or type(e).__name__))
    return doc.toxml()


def load_urdf_file(path, name=None, mappings=None):
    """Load a .urdf or .urdf.xacro / .xacro file."""
    if not os.path.isfile(path):
        raise ModelError('model file %s does not exist' % path)
    if path.endswith('.xacro'):
        text = process_xacro(path, mappings)
    else:
        with open(path) as f:
            text = f.read()
        if 'xacro:' in text:
            text = process_xacro(path, mappings)
    return parse_urdf(text, name=name, base_dir=os.path.dirname(os.path.abspath(path)))


_floats = parse_floats   # one number-list parser for URDF and SDF (sim_world.model)


def _float_attr(el, attr, what, default=None):
    v = el.get(attr)
    if v is None:
        if default is None:
            raise ModelError('%s: missing attribute %s' % (what, attr))
        return default
    return _floats(v, 1, '%s %s' % (what, attr))[0]


def parse_pose_attrs(el, what):
    """Pose of a URDF <origin xyz="" rpy=""/> element (None -> identity)."""
    if el is None:
        return Pose()
    xyz = _floats(el.get('xyz', '0 0 0'), 3, what + ' origin xyz')
    check_position(xyz, what + ' origin xyz')
    rpy = _floats(el.get('rpy', '0 0 0'), 3, what + ' origin rpy')
    try:
        return Pose.from_xyz_rpy(xyz, rpy)
    except InvalidPose as e:
        raise ModelError('%s origin: %s' % (what, e))


def _geometry(el, what):
    if el is None:
        raise ModelError('%s has no <geometry>' % what)
    shapes = list(el)
    if not shapes:
        raise ModelError('%s: empty <geometry>' % what)
    s = shapes[0]
    kind = _local(s.tag)
    if kind == 'box':
        return Geometry('box', size=_floats(s.get('size'), 3, what + ' box size'))
    if kind == 'cylinder':
        return Geometry('cylinder', radius=_float_attr(s, 'radius', what + ' cylinder'),
                        length=_float_attr(s, 'length', what + ' cylinder'))
    if kind == 'sphere':
        return Geometry('sphere', radius=_float_attr(s, 'radius', what + ' sphere'))
    if kind == 'mesh':
        fn = s.get('filename')
        if not fn:
            raise ModelError('%s mesh has no filename' % what)
        scale = _floats(s.get('scale', '1 1 1'), 3, what + ' mesh scale')
        return Geometry('mesh', filename=fn, scale=scale)
    raise ModelError('%s: unsupported geometry <%s>' % (what, kind))


def _material(el, named, what):
    if el is None:
        return None
    name = el.get('name')
    color = el.find('color')
    tex = el.find('texture')
    if color is None and tex is None and name in named:
        return named[name]
    rgba = (0.8, 0.8, 0.8, 1.0)
    if color is not None:
        rgba = _floats(color.get('rgba'), 4, what + ' material color rgba')
    elif name:
        rgba = Material.named(name).rgba
    m = Material(rgba, name=name, texture=tex.get('filename') if tex is not None else None)
    if name and name not in named:
        named[name] = m
    return m


def _bool(text):
    return (text or '').strip().lower() in ('1', 'true', 'yes', 'on')


def parse_urdf(text, name=None, base_dir=None, robot_namespace=''):
    """Parse URDF text (already xacro-expanded) into a validated Model."""
    if text is None or not text.strip():
        raise ModelError('empty model description')
    try:
        root = ET.fromstring(text.encode('utf-8') if isinstance(text, str) else text)
    except ET.ParseError as e:
        raise ModelError('malformed URDF (XML error: %s)' % e)
    if _local(root.tag) != 'robot':
        raise ModelError('not a URDF: the root element is <%s>, expected <robot>' % _local(root.tag))
    model_name = name or root.get('name')
    if not model_name:
        raise ModelError('URDF <robot> has no name and none was given')
    leftovers = sorted(set(_local(c.tag) for c in root if isinstance(c.tag, str)
                           and _local(c.tag) in ('property', 'macro', 'include', 'arg')))
    if leftovers:
        raise ModelError('model %r still contains xacro elements (%s): expand it with xacro '
                         'first' % (model_name, ', '.join(leftovers)))
    model = Model(model_name, base_dir=base_dir, robot_namespace=robot_namespace)
    model.source_xml = text
    named = {}
    for m in root.findall('material'):
        _material(m, named, 'robot material %r' % m.get('name'))

    zero_mass = []
    for lel in root.findall('link'):
        lname = lel.get('name')
        if not lname:
            raise ModelError('a <link> has no name')
        if lname in model.links:
            raise ModelError('link %r is defined twice' % lname)
        what = 'link %r' % lname
        inertial = None
        iel = lel.find('inertial')
        if iel is not None:
            mel = iel.find('mass')
            if mel is None:
                raise ModelError('%s inertial has no <mass>' % what)
            mass = _float_attr(mel, 'value', what + ' mass')
            inel = iel.find('inertia')
            kw = {}
            if inel is not None:
                for k in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz'):
                    kw[k] = _float_attr(inel, k, what + ' inertia', default=0.0)
            if mass == 0:
                # Gazebo's converter: a zero-mass link is a link without inertia (lumped
                # into its parent by a fixed joint, otherwise dropped; sim_world.physics)
                zero_mass.append(lname)
            else:
                inertial = Inertial(mass, parse_pose_attrs(iel.find('origin'), what + ' inertial'),
                                    **kw)
        visuals = []
        for i, vel in enumerate(lel.findall('visual')):
            vwhat = '%s visual %d' % (what, i)
            visuals.append(Visual(_geometry(vel.find('geometry'), vwhat),
                                  parse_pose_attrs(vel.find('origin'), vwhat),
                                  _material(vel.find('material'), named, vwhat),
                                  name=vel.get('name', '')))
        collisions = []
        for i, cel in enumerate(lel.findall('collision')):
            cwhat = '%s collision %d' % (what, i)
            collisions.append(Collision(_geometry(cel.find('geometry'), cwhat),
                                        parse_pose_attrs(cel.find('origin'), cwhat),
                                        name=cel.get('name', ''),
                                        material=(cel.find('material').get('name')
                                                  if cel.find('material') is not None
                                                  else None)))
        model.links[lname] = Link(lname, inertial, visuals, collisions)

    for jel in root.findall('joint'):
        jname = jel.get('name') or '?'
        what = 'joint %r' % jname
        p, c = jel.find('parent'), jel.find('child')
        if p is None or c is None or not p.get('link') or not c.get('link'):
            raise ModelError('%s needs <parent link=...> and <child link=...>' % what)
        model.joints.append(_joint(jel, jname, p.get('link'), c.get('link'), what))

    for gel in root.findall('gazebo'):
        _gazebo_extension(gel, model)
    if zero_mass and not model.static and all(
            link.inertial is None for link in model.links.values()):
        raise ModelError('link %r inertial mass must be positive, got 0 (no link of model %r '
                         'has a mass)' % (zero_mass[0], model_name))
    return model.validate()


def _joint(jel, jname, parent, child, what):
    """One URDF <joint>, read as urdfdom and sdformat's parser_urdf read it: <limit> is
    required for revolute and prismatic joints (lower/upper default 0, effort and velocity
    required); <axis> defaults to x; <dynamics damping friction>; <mimic>."""
    jtype = jel.get('type', '')
    axis = jel.find('axis')
    kw = {}
    lel = jel.find('limit')
    if lel is not None:
        kw['effort'] = _float_attr(lel, 'effort', what + ' limit')
        kw['velocity'] = _float_attr(lel, 'velocity', what + ' limit')
        if jtype in ('revolute', 'prismatic'):
            kw['lower'] = _float_attr(lel, 'lower', what + ' limit', default=0.0)
            kw['upper'] = _float_attr(lel, 'upper', what + ' limit', default=0.0)
    elif jtype in ('revolute', 'prismatic'):
        raise ModelError('%s is %s but has no <limit> (URDF requires one with effort and '
                         'velocity)' % (what, jtype))
    dyn = jel.find('dynamics')
    if dyn is not None:
        kw['damping'] = _float_attr(dyn, 'damping', what + ' dynamics', default=0.0)
        kw['friction'] = _float_attr(dyn, 'friction', what + ' dynamics', default=0.0)
    mel = jel.find('mimic')
    if mel is not None:
        if not mel.get('joint'):
            raise ModelError('%s <mimic> names no joint' % what)
        kw['mimic'] = (mel.get('joint'),
                       _float_attr(mel, 'multiplier', what + ' mimic', default=1.0),
                       _float_attr(mel, 'offset', what + ' mimic', default=0.0))
    return Joint(jname, jtype, parent, child, parse_pose_attrs(jel.find('origin'), what),
                 _floats(axis.get('xyz'), 3, what + ' axis') if axis is not None
                 else (1.0, 0.0, 0.0), **kw)


def _gazebo_extension(gel, model):
    ref = gel.get('reference')
    link = None
    if ref:
        if ref not in model.links:
            # joints may be referenced too (Gazebo allows it); anything else is an error
            if ref in [j.name for j in model.joints]:
                joint = model.joint(ref)
                for child in gel:
                    if isinstance(child.tag, str) and _local(child.tag) == 'preserveFixedJoint':
                        joint.preserve = _bool(child.text)
                return
            raise ModelError('<gazebo reference="%s"> names no link of model %r (links: %s)'
                             % (ref, model.name, ', '.join(model.links)))
        link = model.links[ref]
    for child in gel:
        if not isinstance(child.tag, str):
            continue
        tag = _local(child.tag)
        text = (child.text or '').strip()
        if tag == 'turnGravityOff' and link is not None:
            link.gravity = not _bool(text)
        elif tag == 'gravity' and link is not None:
            link.gravity = _bool(text)
        elif tag == 'material' and link is not None and text:
            for v in link.visuals:
                v.material = Material.named(text)
        elif tag == 'selfCollide' and link is not None:
            link.self_collide = _bool(text)
        elif tag == 'static' and link is None:
            model.static = _bool(text)
        elif tag == 'sensor' or (isinstance(child.tag, str) and _is_ns(child.tag, 'sensor')):
            _sensor(child, model, ref)
        elif tag == 'plugin' or _is_ns(child.tag, 'controller'):
            _plugin(child, model, ref, None, None)


def _is_ns(tag, prefix):
    """True for '{...#prefix}name' (namespaced) or 'prefix:name' tags."""
    if tag.startswith('{'):
        return tag.split('}', 1)[0].endswith('#' + prefix)
    return tag.startswith(prefix + ':')


def _sensor(sel, model, link):
    if _local(sel.tag) == 'sensor':
        stype = sel.get('type', 'camera')      # classic <sensor type="camera">
    else:
        stype = _local(sel.tag)                 # 2011 <sensor:camera>
    found = False
    for child in sel.iter():
        if child is sel or not isinstance(child.tag, str):
            continue
        if _local(child.tag) == 'plugin' or _is_ns(child.tag, 'controller'):
            _plugin(child, model, link, sel, stype)
            found = True
    if not found:
        # a sensor without a ROS plugin still exists (Gazebo renders it for nobody): keep
        # nothing, but do not fail.
        pass


def _plugin(pel, model, link, sensor, stype):
    filename = pel.get('filename') or pel.get('plugin')
    if not filename and _is_ns(pel.tag, 'controller'):
        # 2011 controllers built into Gazebo name no library (thesis snippet 3.3.1:
        # <controller:generic_gps>): the controller type is the name, lib<type>.so
        filename = 'lib%s.so' % _local(pel.tag)
    if not filename:
        raise ModelError('plugin element <%s> of model %r names no library (filename= or plugin=)'
                         % (_local(pel.tag), model.name))
    model.plugins.append(PluginSpec(filename, name=pel.get('name', ''), element=pel,
                                    sensor=sensor, sensor_type=stype, link=link))
