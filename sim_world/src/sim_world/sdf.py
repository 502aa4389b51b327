"""World files: the SDF subset sim_world reads.

Supported (SDF 1.4-1.7 element names)::

  <sdf><world name="...">
    <gravity>0 0 -9.81</gravity>
    <physics><max_step_size>0.001</max_step_size><real_time_factor>1</real_time_factor>
             <gravity>...</gravity></physics>
    <scene><ambient>r g b a</ambient><background>r g b a</background>
           <shadows>false</shadows></scene>  (shadows: spot lights and the sun cast shadows in
           the cameras, a depth pass per light and frame; off unless set, unlike SDF's
           default, for speed)
    <light name type="directional|point|spot"><pose>x y z r p y</pose><diffuse/>
           <specular/><direction>x y z</direction><attenuation><range/></attenuation>
           <spot><inner_angle/><outer_angle/><falloff/></spot></light>
    <include><uri>model://ground_plane</uri></include>      (also model://sun)
    <model name="..."><static>true</static><pose>x y z r p y</pose>
      <link name="..."><pose/><gravity>false</gravity>
        <inertial><mass/><pose/><inertia><ixx/>...</inertia></inertial>
        <collision name><pose/><geometry>box|cylinder|sphere|plane|mesh</geometry></collision>
        <visual name><pose/><geometry>...</geometry>
          <material><ambient/><diffuse>r g b a</diffuse><script><name>Gazebo/Wood</name></script>
                    <pbr><metal><albedo_map>file.png</albedo_map></metal></pbr>
                    <texture>file.png</texture>  (simvid shorthand)
                    <lighting>false</lighting></material></visual>
        <sensor type="camera" ...><plugin filename="..."/></sensor>
      </link>
      <joint name type="fixed|revolute|continuous|prismatic"><parent/><child/><pose/>
        <axis><xyz/><limit/><dynamics/><initial_position/></axis></joint>
        (<parent>world</parent>: the model is welded where it is put)
      <plugin name filename>...</plugin>
    </model>
  </world></sdf>

A ``<model>`` may also stand alone (the spawn_sdf_model service). Relative file names
resolve against the world file's folder. Errors raise ``ModelError`` naming the element.
"""
import math
import os
import xml.etree.ElementTree as ET

import numpy as np

from .model import (Collision, Geometry, Inertial, Joint, Light, Link, Material, Model,
                    ModelError, PluginSpec, Visual, _local, check_position, parse_floats)
from .transforms import InvalidPose, Pose

__all__ = ['WorldDescription', 'load_world_file', 'parse_world', 'parse_sdf_model',
           'ground_plane_model']


class WorldDescription(object):
    def __init__(self, name='default'):
        self.name = name
        self.gravity = np.array([0.0, 0.0, -9.81])
        self.max_step_size = None
        self.real_time_factor = None
        self.ambient = np.array([0.4, 0.4, 0.4, 1.0])
        self.background = np.array([0.7, 0.7, 0.7, 1.0])
        self.shadows = False        # <scene><shadows>: spot lights cast shadows in cameras
        self.lights = []
        self.models = []
        self.environment = None     # sim_world.environment.Environment


_vec = parse_floats      # one number-list parser for URDF and SDF (sim_world.model)


def _child_text(el, tag, default=None):
    c = el.find(tag)
    if c is None or c.text is None:
        return default
    return c.text.strip()


def _pose(el, what):
    c = el.find('pose')
    if c is None or not (c.text or '').strip():
        return Pose()
    v = _vec(c.text, 6, what + ' <pose>')
    check_position(v[:3], what + ' <pose>')
    try:
        return Pose.from_xyz_rpy(v[:3], v[3:])
    except InvalidPose as e:
        raise ModelError('%s <pose>: %s' % (what, e))


def _bool(text, default=False):
    if text is None:
        return default
    return text.strip().lower() in ('1', 'true', 'yes', 'on')


def _geometry(gel, what):
    if gel is None or len(gel) == 0:
        raise ModelError('%s has no <geometry>' % what)
    s = gel[0]
    kind = _local(s.tag)
    if kind == 'box':
        return Geometry('box', size=_vec(_child_text(s, 'size'), 3, what + ' box size'))
    if kind == 'sphere':
        return Geometry('sphere', radius=_vec(_child_text(s, 'radius'), 1, what + ' radius')[0])
    if kind == 'cylinder':
        return Geometry('cylinder',
                        radius=_vec(_child_text(s, 'radius'), 1, what + ' radius')[0],
                        length=_vec(_child_text(s, 'length'), 1, what + ' length')[0])
    if kind == 'plane':
        return Geometry('plane', normal=_vec(_child_text(s, 'normal', '0 0 1'), 3, what + ' normal'),
                        size=list(_vec(_child_text(s, 'size', '100 100'), 2, what + ' size')) + [0.0])
    if kind == 'mesh':
        uri = _child_text(s, 'uri')
        if not uri:
            raise ModelError('%s mesh has no <uri>' % what)
        return Geometry('mesh', filename=uri,
                        scale=_vec(_child_text(s, 'scale', '1 1 1'), 3, what + ' mesh scale'))
    raise ModelError('%s: unsupported geometry <%s>' % (what, kind))


def _material(mel, what):
    if mel is None:
        return Material()
    rgba = None
    name = _child_text(mel, 'script/name')
    if mel.find('diffuse') is not None:
        rgba = _vec(_child_text(mel, 'diffuse'), 4, what + ' diffuse')
    elif mel.find('ambient') is not None:
        rgba = _vec(_child_text(mel, 'ambient'), 4, what + ' ambient')
    m = Material.named(name) if name else Material()
    if rgba is not None:
        m.rgba = rgba
    tex = _child_text(mel, 'texture') or _child_text(mel, 'pbr/metal/albedo_map')
    if tex:
        m.texture = tex
    m.lit = _bool(_child_text(mel, 'lighting'), True)
    return m


def _link(lel, model, what):
    name = lel.get('name')
    if not name:
        raise ModelError('%s: a <link> has no name' % what)
    lwhat = '%s link %r' % (what, name)
    inertial = None
    iel = lel.find('inertial')
    if iel is not None:
        mass = float(_vec(_child_text(iel, 'mass', '1'), 1, lwhat + ' mass')[0])
        kw = {}
        for k in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz'):
            t = _child_text(iel, 'inertia/' + k)
            if t is not None:
                kw[k] = float(_vec(t, 1, lwhat + ' ' + k)[0])
        inertial = Inertial(mass, _pose(iel, lwhat + ' inertial'), **kw)
    visuals = [Visual(_geometry(v.find('geometry'), lwhat + ' visual'), _pose(v, lwhat + ' visual'),
                      _material(v.find('material'), lwhat + ' visual'), name=v.get('name', ''))
               for v in lel.findall('visual')]
    collisions = [Collision(_geometry(c.find('geometry'), lwhat + ' collision'),
                            _pose(c, lwhat + ' collision'), name=c.get('name', ''),
                            material=(_child_text(c, 'material') or '').strip() or None)
                  for c in lel.findall('collision')]
    link = Link(name, inertial, visuals, collisions,
                gravity=_bool(_child_text(lel, 'gravity'), True))
    for sel in lel.findall('sensor'):
        for pel in sel.findall('plugin'):
            fn = pel.get('filename')
            if not fn:
                raise ModelError('%s sensor plugin has no filename' % lwhat)
            model.plugins.append(PluginSpec(fn, pel.get('name', ''), pel, sel,
                                            sel.get('type', 'camera'), name))
    return link, _pose(lel, lwhat)


def _sdf_element(text, tag, what, malformed):
    """The <tag> element of SDF text: the root itself, or the child of an <sdf> root."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise ModelError('%s (XML error: %s)' % (malformed, e))
    el = root.find(tag) if _local(root.tag) == 'sdf' else root
    if el is None or _local(el.tag) != tag:
        raise ModelError('%s has no <%s> element' % (what, tag))
    return el


def parse_sdf_model(mel, base_dir=None, what=None):
    """An SDF <model> element (or its XML text) -> Model."""
    source = mel if isinstance(mel, (str, bytes)) else None
    if source is not None:
        mel = _sdf_element(mel, 'model', 'SDF text', 'malformed SDF')
    name = mel.get('name')
    if not name:
        raise ModelError('an SDF <model> has no name')
    what = what or 'model %r' % name
    model = Model(name, pose=_pose(mel, what), static=_bool(_child_text(mel, 'static')),
                  base_dir=base_dir)
    link_frames = {}
    for lel in mel.findall('link'):
        link, lpose = _link(lel, model, what)
        if link.name in model.links:
            raise ModelError('%s: link %r defined twice' % (what, link.name))
        model.links[link.name] = link
        link_frames[link.name] = lpose
    if not model.links:
        raise ModelError('%s has no <link>' % what)
    if 'world' not in model.links and any(_child_text(j, 'parent') == 'world'
                                          for j in mel.findall('joint')):
        # a joint to the world (<parent>world</parent>) welds the model where it is put:
        # an empty root link named world, as a URDF's (sim_world.physics.articulation)
        links = list(model.links.items())
        model.links.clear()
        model.links['world'] = Link('world', None, [], [])
        model.links.update(links)
        link_frames['world'] = Pose()
    # SDF link poses are relative to the model frame; make the first link the root and
    # express the others through fixed joints from it.
    root_name = next(iter(model.links))
    root_pose = link_frames[root_name]
    model.pose = model.pose * root_pose
    joined = set()
    for jel in mel.findall('joint'):
        jname = jel.get('name', '?')
        parent, child = _child_text(jel, 'parent'), _child_text(jel, 'child')
        if parent not in model.links or child not in model.links:
            raise ModelError('%s joint %r connects unknown links %r -> %r'
                             % (what, jname, parent, child))
        origin = link_frames[parent].inverse() * link_frames[child]
        model.joints.append(_joint(jel, jname, parent, child, origin, what))
        joined.add(child)
    for lname in model.links:
        if lname != root_name and lname not in joined:
            # unjoined extra links of a static model (a desk's legs) move with the model
            model.joints.append(Joint('%s_fixed_%s' % (root_name, lname), 'fixed', root_name,
                                      lname, root_pose.inverse() * link_frames[lname]))
    for pel in mel.findall('plugin'):
        fn = pel.get('filename')
        if not fn:
            raise ModelError('%s plugin has no filename' % what)
        model.plugins.append(PluginSpec(fn, pel.get('name', ''), pel))
    # what the model was read from (/gazebo/get_model_description answers with it)
    model.source_xml = source.decode('utf-8', 'replace') if isinstance(source, bytes) \
        else source
    if model.source_xml is None:
        model.source_xml = ET.tostring(mel, encoding='unicode')
    return model.validate()


def _joint_number(el, tag, what, default):
    text = _child_text(el, tag)
    if text is None:
        return default
    return float(_vec(text, 1, '%s <%s>' % (what, tag))[0])


def _joint(jel, jname, parent, child, origin, what):
    """An SDF <joint>: <pose> (the joint frame in the child link's frame), <axis><xyz>
    (in the joint frame), <axis><limit> lower/upper/effort/velocity (|value| >= 1e15, SDF's
    default 1e16, is no limit), <axis><dynamics> damping/friction."""
    jwhat = '%s joint %r' % (what, jname)
    jtype = jel.get('type', 'fixed')
    if jtype not in Joint.TYPES:
        raise ModelError('%s: type %r is not supported (fixed, revolute, continuous, '
                         'prismatic)' % (jwhat, jtype))
    kw = {}
    ael = jel.find('axis')
    axis = (1.0, 0.0, 0.0) if jtype != 'revolute' else (0.0, 0.0, 1.0)
    if ael is not None:
        if _child_text(ael, 'xyz') is not None:
            axis = _vec(_child_text(ael, 'xyz'), 3, jwhat + ' <axis><xyz>')
        lel = ael.find('limit')
        if lel is not None:
            for tag in ('lower', 'upper'):
                v = _joint_number(lel, tag, jwhat + ' <limit>', None)
                if v is not None and abs(v) < 1e15:
                    kw[tag] = v
            kw['effort'] = _joint_number(lel, 'effort', jwhat + ' <limit>', -1.0)
            kw['velocity'] = _joint_number(lel, 'velocity', jwhat + ' <limit>', -1.0)
        if _child_text(ael, 'initial_position') is not None:    # SDF 1.5-1.7
            kw['initial'] = _joint_number(ael, 'initial_position', jwhat + ' <axis>', 0.0)
        dyn = ael.find('dynamics')
        if dyn is not None:
            kw['damping'] = _joint_number(dyn, 'damping', jwhat + ' <dynamics>', 0.0)
            kw['friction'] = _joint_number(dyn, 'friction', jwhat + ' <dynamics>', 0.0)
    initial = kw.pop('initial', None)
    joint = Joint(jname, jtype, parent, child, origin, axis, **kw)
    joint.frame = _pose(jel, jwhat)
    if initial is not None:
        joint.initial = initial
    return joint


def ground_plane_model():
    link = Link('link', None, [Visual(Geometry('plane', size=(100, 100, 0)),
                                      material=Material((0.55, 0.55, 0.55, 1.0)))],
                [Collision(Geometry('plane', size=(100, 100, 0)))])
    return Model('ground_plane', links={'link': link}, static=True)


def _sun():
    return Light('sun', 'directional', Pose((0, 0, 10)), (0.8, 0.8, 0.8, 1),
                 (0.2, 0.2, 0.2, 1), (-0.5, 0.1, -0.9))


def _light(lel):
    """An SDF <light> -> Light. Spot lights keep their cone (<spot>: inner_angle,
    outer_angle, falloff; SDF's defaults 0, 0, 0 would be a dark spot: an absent <spot>
    gives a 90-degree cone, inner 0, falloff 1)."""
    what = 'light %r' % lel.get('name')
    kind = lel.get('type', 'directional')
    if kind not in ('directional', 'point', 'spot'):
        raise ModelError('%s: unknown type %r (directional, point, spot)' % (what, kind))
    att = lel.find('attenuation')
    spot = {}
    sel = lel.find('spot')
    if sel is not None:
        for tag in ('inner_angle', 'outer_angle', 'falloff'):
            t = _child_text(sel, tag)
            if t is not None:
                spot[tag] = float(_vec(t, 1, '%s spot %s' % (what, tag))[0])
        if spot.get('inner_angle', 0.0) < 0 or spot.get('outer_angle', 1.0) <= 0 \
                or spot.get('falloff', 1.0) < 0:
            raise ModelError('%s <spot>: angles must be positive (inner >= 0, outer > 0) and '
                             'falloff >= 0, got %r' % (what, spot))
        if spot.get('inner_angle', 0.0) > spot.get('outer_angle', math.pi / 2):
            raise ModelError('%s <spot>: inner_angle %g is wider than outer_angle %g'
                             % (what, spot['inner_angle'], spot.get('outer_angle', math.pi / 2)))
    direction = _vec(_child_text(lel, 'direction', '0 0 -1'), 3, what + ' direction')
    if float(np.linalg.norm(direction)) < 1e-9:
        raise ModelError('%s: <direction> is the zero vector' % what)
    return Light(lel.get('name', 'light'), kind, _pose(lel, what),
                 _vec(_child_text(lel, 'diffuse', '0.8 0.8 0.8 1'), 4, what + ' diffuse'),
                 _vec(_child_text(lel, 'specular', '0.2 0.2 0.2 1'), 4, what + ' specular'),
                 direction,
                 range=float(_vec(_child_text(att, 'range', '20'), 1, what + ' range')[0])
                 if att is not None else 20.0, **spot)


def parse_world(text, base_dir=None):
    wel = _sdf_element(text, 'world', 'world file', 'malformed world file')
    w = WorldDescription(wel.get('name', 'default'))
    g = _child_text(wel, 'gravity') or _child_text(wel, 'physics/gravity')
    if g:
        w.gravity = _vec(g, 3, 'world gravity')
    step = _child_text(wel, 'physics/max_step_size')
    if step:
        w.max_step_size = float(_vec(step, 1, 'physics max_step_size')[0])
    rtf = _child_text(wel, 'physics/real_time_factor')
    if rtf:
        w.real_time_factor = float(_vec(rtf, 1, 'physics real_time_factor')[0])
    if wel.find('scene/ambient') is not None:
        w.ambient = _vec(_child_text(wel, 'scene/ambient'), 4, 'scene ambient')
    if wel.find('scene/background') is not None:
        w.background = _vec(_child_text(wel, 'scene/background'), 4, 'scene background')
    if wel.find('scene/shadows') is not None:
        w.shadows = _bool(_child_text(wel, 'scene/shadows'))
    for lel in wel.findall('light'):
        w.lights.append(_light(lel))
    for iel in wel.findall('include'):
        uri = _child_text(iel, 'uri', '')
        if uri.endswith('ground_plane'):
            w.models.append(ground_plane_model())
        elif uri.endswith('sun'):
            w.lights.append(_sun())
        else:
            raise ModelError('world <include> of %r: only model://ground_plane and model://sun '
                             'are built in; spawn other models with spawn_model' % uri)
    for mel in wel.findall('model'):
        w.models.append(parse_sdf_model(mel, base_dir))
    from .environment import EnvironmentError, parse_environment
    try:
        w.environment = parse_environment(wel)
    except EnvironmentError as e:
        raise ModelError('world %r: %s' % (w.name, e))
    names = [m.name for m in w.models]
    dup = set(n for n in names if names.count(n) > 1)
    if dup:
        raise ModelError('world has several models named %s' % sorted(dup))
    return w


def load_world_file(path):
    if not os.path.isfile(path):
        raise ModelError('world file %s does not exist' % path)
    with open(path, 'rb') as f:
        text = f.read()
    return parse_world(text, base_dir=os.path.dirname(os.path.abspath(path)))
