"""Fuzzed models through what /gazebo/spawn_urdf_model and /gazebo/spawn_sdf_model do
(``sim_world.spawn.spawn_xml``), no roscore (issue 19 item 3; through the real services:
test/test_fuzz_spawn_ros.py).

Inputs: the phone's URDF (both syntaxes, thesis appendix A and Gazebo classic), the flycam,
and every model of the example worlds as standalone SDF, mutated: numbers replaced by wrong
types, huge or tiny numbers, NaN/inf, negative or zero masses and inertias; links and joints
removed, duplicated or renamed; unknown elements, deep nesting, unicode; broken XML (cut,
bytes flipped). The world files themselves go through ``parse_world`` the same way, and the
xacro sources through ``load_urdf_file`` (xacro, then the URDF parser).

Every request is answered (success, or ``SpawnModel: ...`` naming the problem, never an
internal error); a rejected model leaves nothing behind; after every request the world
steps, and every model's pose stays finite (the physics engines never see NaN, or a mass,
inertia or size that breaks them: the loaders bound them). The suite runs 150 derandomized
inputs; bench/fuzz runs more, randomised (MDS_FUZZ_EXAMPLES, MDS_FUZZ_SEED)."""
import functools
import glob
import math
import os
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from sim_world.model import ModelError
from sim_world.sdf import parse_world
from sim_world.spawn import spawn_xml
from sim_world.transforms import Pose
from sim_world.urdf import process_xacro

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
URDF = os.path.join(ROOT, 'sim_world', 'urdf')
WORLDS = sorted(glob.glob(os.path.join(ROOT, 'sim_world', 'worlds', '*.world')) +
                glob.glob(os.path.join(ROOT, 'test', 'rostest', '*.world')))

NASTY_NUMBERS = ['nan', 'NaN', 'inf', '-inf', '1e308', '-1e308', '1e-308', '0', '-0', '-1',
                 '-0.001', '1e30', '-1e30', '1e12', '4e9', '1e-12', '0x10', '1_000', '',
                 ' ', 'abc', 'true', '1 2', '1 2 3 4 5 6 7', '\u2212 1', '\u00bd', '١٢',
                 '1e', '--1', '9' * 400]


# articulated models (issue 48): every joint type, limits, dynamics, mimic, a massless link
_INERTIAL = ('<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/>'
             '</inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>')
ARTICULATED_URDF = '''<robot name="arm">
<link name="base">%(i)s</link><link name="upper">%(i)s</link><link name="lower">%(i)s</link>
<link name="slide">%(i)s</link><link name="flange"/><link name="tool">%(i)s</link>
<joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
<origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="20" velocity="2"/>
<dynamics damping="0.1" friction="0.05"/></joint>
<joint name="elbow" type="continuous"><parent link="upper"/><child link="lower"/>
<origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><mimic joint="shoulder" multiplier="2"/></joint>
<joint name="rail" type="prismatic"><parent link="lower"/><child link="slide"/>
<origin xyz="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="0" upper="0.1" effort="5" velocity="1"/></joint>
<joint name="mount" type="fixed"><parent link="slide"/><child link="flange"/></joint>
<joint name="wrist" type="revolute"><parent link="flange"/><child link="tool"/>
<axis xyz="1 0 0"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
</robot>''' % {'i': _INERTIAL}
ARTICULATED_SDF = '''<sdf version="1.6"><model name="door">
<link name="post"><inertial><mass>5</mass></inertial>
<collision name="c"><geometry><box><size>0.1 0.1 2</size></box></geometry></collision></link>
<link name="leaf"><pose>0.5 0 0 0 0 0</pose><inertial><mass>10</mass></inertial>
<collision name="c"><geometry><box><size>0.9 0.04 2</size></box></geometry></collision></link>
<joint name="hinge" type="revolute"><parent>post</parent><child>leaf</child>
<pose>-0.45 0 0 0 0 0</pose><axis><xyz>0 0 1</xyz><limit><lower>0</lower><upper>1.5</upper>
<effort>20</effort><velocity>1</velocity></limit><dynamics><damping>0.5</damping>
<friction>0.1</friction></dynamics></axis></joint></model></sdf>'''


@functools.lru_cache(maxsize=None)
def sources():
    """[(kind, name, xml text)]: the models the fuzzer mutates."""
    out = []
    for f in ('mobile_device.urdf.xacro', 'mobile_device_2011.urdf.xacro', 'flycam.urdf.xacro'):
        out.append(('urdf', f, process_xacro(os.path.join(URDF, f))))
    out.append(('urdf', 'articulated.urdf', ARTICULATED_URDF))
    out.append(('sdf', 'articulated.sdf', ARTICULATED_SDF))
    for w in WORLDS:
        root = ET.parse(w).getroot()
        for el in root.iter():     # a spawned SDF model resolves files against sim_world's
            if el.tag in ('texture', 'albedo_map', 'uri') and el.text and \
                    not el.text.startswith(('/', 'model://', 'file://', 'package://')):
                el.text = os.path.join(os.path.dirname(w), el.text.strip())   # cwd: make
        for m in root.iter('model'):                                          # them absolute
            out.append(('sdf', '%s:%s' % (os.path.basename(w), m.get('name')),
                        '<sdf version="1.6">%s</sdf>' % ET.tostring(m, encoding='unicode')))
    return out


def _elements(root):
    return [e for e in root.iter()]


def mutate_tree(text, draw):
    """One structural mutation of an XML text (or of its bytes when it does not parse, or
    nests too deep for ElementTree's writer)."""
    try:
        return _mutate_tree(text, draw)
    except (ET.ParseError, RecursionError):
        return mutate_bytes(text, draw)


def _mutate_tree(text, draw):
    root = ET.fromstring(text)
    els = _elements(root)
    kind = draw(st.sampled_from(['number', 'number', 'number', 'attr_junk', 'text_junk',
                                 'remove', 'duplicate', 'rename_ref', 'unknown', 'nest',
                                 'unicode_name', 'mass', 'inertia', 'size', 'joint']))
    if kind in ('number', 'attr_junk'):
        withattrs = [(e, k) for e in els for k in e.attrib]
        withtext = [e for e in els if (e.text or '').strip() and len(e) == 0]
        if withattrs and (not withtext or draw(st.booleans())):
            e, k = draw(st.sampled_from(withattrs))
            e.set(k, _value(e.get(k), draw, junk=kind == 'attr_junk'))
        elif withtext:
            e = draw(st.sampled_from(withtext))
            e.text = _value(e.text, draw, junk=kind == 'attr_junk')
    elif kind == 'text_junk':
        e = draw(st.sampled_from(els))
        e.text = draw(st.text(max_size=40))
    elif kind == 'remove':
        parents = [(p, c) for p in els for c in p]
        if parents:
            p, c = draw(st.sampled_from(parents))
            p.remove(c)
    elif kind == 'duplicate':
        parents = [(p, c) for p in els for c in p]
        if parents:
            p, c = draw(st.sampled_from(parents))
            p.append(ET.fromstring(ET.tostring(c)))
    elif kind == 'rename_ref':
        refs = [(e, k) for e in els for k in e.attrib if k in ('link', 'name', 'reference')]
        texts = [e for e in els if e.tag in ('parent', 'child')]
        if refs and (not texts or draw(st.booleans())):
            e, k = draw(st.sampled_from(refs))
            e.set(k, draw(st.sampled_from(['', 'base_link', 'nope', 'x' * 300, '\u00e9\u4e2d',
                                           'world'])))
        elif texts:
            draw(st.sampled_from(texts)).text = draw(st.sampled_from(['', 'nope', 'world']))
    elif kind == 'unknown':
        e = draw(st.sampled_from(els))
        ET.SubElement(e, draw(st.sampled_from(['foo', 'link', 'joint', 'inertial', 'geometry',
                                               'plugin', 'sensor', 'gazebo', 'mass'])))
    elif kind == 'nest':      # deep nesting, as text (ElementTree's writer recurses)
        e = draw(st.sampled_from(els))
        depth = draw(st.sampled_from([10, 200, 5000]))
        tag = draw(st.sampled_from(['link', 'visual', 'x']))
        e.append(ET.Comment('NEST'))
        return ET.tostring(root, encoding='unicode').replace(
            '<!--NEST-->', '<%s>' % tag * depth + '</%s>' % tag * depth)
    elif kind == 'joint':
        _mutate_joint(root, els, draw)
    elif kind == 'unicode_name':
        named = [e for e in els if 'name' in e.attrib]
        if named:
            draw(st.sampled_from(named)).set('name', draw(st.text(min_size=0, max_size=20)))
    elif kind == 'mass':
        for e in els:
            if e.tag == 'mass':
                v = draw(st.sampled_from(['-1', '0', '1e-30', '1e30', 'nan', '1e300', '5e-7']))
                if 'value' in e.attrib:
                    e.set('value', v)
                else:
                    e.text = v
    elif kind == 'inertia':
        v = draw(st.sampled_from(['0', '-1', '1e-30', '1e30', 'nan', '100', '1e300']))
        for e in els:
            if e.tag == 'inertia':
                for k in list(e.attrib):
                    if draw(st.booleans()):
                        e.set(k, v)
            if e.tag in ('ixx', 'iyy', 'izz', 'ixy', 'ixz', 'iyz') and draw(st.booleans()):
                e.text = v
    elif kind == 'size':
        v = draw(st.sampled_from(['1e30', '1e-30', '1e9', '1e-9', '1e6 1e6 1e6',
                                  '1e-9 1e-9 1e-9', '1e12 1 1']))
        for e in els:
            if e.tag in ('box', 'size') and 'size' in e.attrib:
                e.set('size', v if len(v.split()) == 3 else ' '.join([v] * 3))
            elif e.tag == 'size' and e.text:
                e.text = v if len(v.split()) == 3 else ' '.join([v] * len(e.text.split()))
            elif e.tag in ('radius', 'length') and e.text:
                e.text = v.split()[0]
            elif 'radius' in e.attrib or 'length' in e.attrib:
                for k in ('radius', 'length'):
                    if k in e.attrib:
                        e.set(k, v.split()[0])
            elif e.tag in ('origin', 'pose') and draw(st.booleans()):
                if 'xyz' in e.attrib:
                    e.set('xyz', ' '.join([v.split()[0]] * 3))
                elif e.text:
                    e.text = ' '.join([v.split()[0]] * 3 + ['0'] * 3)
    return ET.tostring(root, encoding='unicode')


JOINT_MUTATIONS = ['zero_axis', 'nan_limit', 'lower_above_upper', 'effort', 'gains', 'loop',
                   'mimic_cycle', 'unknown_parent', 'unknown_child', 'duplicate_name', 'type']


def _mutate_joint(root, els, draw):
    """One joint made wrong the ways issue 48 lists (URDF and SDF spellings)."""
    joints = [e for e in els if e.tag == 'joint']
    if not joints:
        return
    j = draw(st.sampled_from(joints))
    what = draw(st.sampled_from(JOINT_MUTATIONS))
    sdf = j.find('parent') is not None and 'link' not in j.find('parent').attrib
    axis = j.find('axis')
    if what == 'zero_axis':
        if axis is None:
            axis = ET.SubElement(j, 'axis')
        if sdf:
            (axis.find('xyz') if axis.find('xyz') is not None
             else ET.SubElement(axis, 'xyz')).text = '0 0 0'
        else:
            axis.set('xyz', '0 0 0')
    elif what in ('nan_limit', 'lower_above_upper', 'effort'):
        vals = {'nan_limit': ('nan', '1'), 'lower_above_upper': ('1', '-1'),
                'effort': ('-1', '1')}[what]
        if sdf:
            lim = (axis if axis is not None else ET.SubElement(j, 'axis')).find('limit')
            lim = lim if lim is not None else ET.SubElement(j.find('axis'), 'limit')
            for tag, v in zip(('lower', 'upper'), vals):
                (lim.find(tag) if lim.find(tag) is not None else ET.SubElement(lim, tag)).text = v
            if what == 'effort':
                (lim.find('effort') if lim.find('effort') is not None
                 else ET.SubElement(lim, 'effort')).text = '1e9'
        else:
            lim = j.find('limit') if j.find('limit') is not None else ET.SubElement(j, 'limit')
            lim.set('lower', vals[0])
            lim.set('upper', vals[1])
            lim.set('effort', '1e9' if what == 'effort' else lim.get('effort', '1'))
            lim.set('velocity', lim.get('velocity', '1'))
    elif what == 'gains':
        dyn = j.find('dynamics') if j.find('dynamics') is not None else ET.SubElement(j, 'dynamics')
        dyn.set('damping', draw(st.sampled_from(['1e6', '1e9', '-1', 'nan'])))
        dyn.set('friction', draw(st.sampled_from(['1e6', '1e9', '-1', '0'])))
    elif what == 'loop':        # a joint from a leaf back to the root
        k = ET.fromstring(ET.tostring(j))
        k.set('name', 'loop')
        links = [e.get('name') for e in els if e.tag == 'link']
        for tag, v in (('parent', links[-1]), ('child', links[0])):
            el = k.find(tag)
            if el is not None:
                if sdf:
                    el.text = v
                else:
                    el.set('link', v)
        root.append(k)
    elif what == 'mimic_cycle' and len(joints) > 1:
        a, b = joints[0], joints[1]
        ET.SubElement(a, 'mimic').set('joint', b.get('name'))
        ET.SubElement(b, 'mimic').set('joint', a.get('name'))
    elif what in ('unknown_parent', 'unknown_child'):
        el = j.find(what.split('_')[1])
        if el is not None:
            if sdf:
                el.text = 'nope'
            else:
                el.set('link', 'nope')
    elif what == 'duplicate_name' and len(joints) > 1:
        joints[1].set('name', joints[0].get('name'))
    elif what == 'type':
        j.set('type', draw(st.sampled_from(['floating', 'planar', 'ball', 'hinge', '',
                                            'continuous', 'fixed', 'prismatic'])))


def _value(old, draw, junk=False):
    if junk:
        return draw(st.text(max_size=30))
    n = len((old or '').split()) or 1
    if draw(st.booleans()):
        return ' '.join(draw(st.sampled_from(NASTY_NUMBERS)) for _ in range(n))
    return draw(st.sampled_from(NASTY_NUMBERS))


def mutate_bytes(text, draw):
    b = bytearray(text.encode('utf-8', 'surrogatepass'))
    if not b:
        return draw(st.text(max_size=50))
    kind = draw(st.sampled_from(['cut', 'flip', 'insert', 'delete']))
    i = draw(st.integers(0, len(b) - 1))
    if kind == 'cut':
        b = b[:i]
    elif kind == 'flip':
        b[i] ^= 1 << draw(st.integers(0, 7))
    elif kind == 'insert':
        b[i:i] = draw(st.sampled_from([b'<', b'>', b'&', b'<!--', b']]>', b'\x00', b'\xff',
                                       '\u202e\ud7ff'.encode('utf-8', 'surrogatepass'),
                                       b'<!DOCTYPE x [<!ENTITY a "aaaa">]>', b'&a;']))
    else:
        del b[i:i + draw(st.integers(1, 64))]
    return b.decode('utf-8', 'replace')


def world_is_sane(world, steps=60):
    """Every model's pose finite after stepping; the physics engine still answers."""
    world.step(steps)
    for name in list(world.models):
        pose = world.physics.model_pose(name)
        assert np.all(np.isfinite(pose.p)) and np.all(np.isfinite(pose.q)), (name, pose)
        lin, ang = world.physics.model_twist(name)
        assert np.all(np.isfinite(lin)) and np.all(np.isfinite(ang)), (name, lin, ang)
        for ln, lp in world.physics.link_poses(name).items():     # articulated links too
            assert np.all(np.isfinite(lp.p)) and np.all(np.isfinite(lp.q)), (name, ln, lp)
        for jn, (q, v) in world.physics.joint_states(name).items():
            assert math.isfinite(q) and math.isfinite(v), (name, jn, q, v)


def check_spawn(world, kind, xml, name='fuzzed'):
    """Spawn one request; returns (success, message). The world keeps what it had."""
    before = set(world.models)
    # just above the ground: the model touches it within the steps below
    ok, msg = spawn_xml(world, kind, name, xml, initial_pose=Pose((0.0, 0.0, 0.02)))
    assert isinstance(ok, bool) and isinstance(msg, str) and '\n' not in msg, msg
    if ok:
        assert set(world.models) == before | {name}
    else:
        assert msg.startswith('SpawnModel: '), msg
        assert 'internal error' not in msg, msg
        assert set(world.models) == before, msg
        assert not world.physics.has_model(name), msg
    world_is_sane(world)
    if ok:
        world.delete_model(name)
    return ok, msg


@pytest.fixture(scope='module', params=['ode', 'bullet'])
def world(request):
    from sim_world.world import World
    from sim_world.sdf import ground_plane_model
    w = World(physics=request.param, step_size=0.001, seed=1)
    w.add_model(ground_plane_model())
    yield w
    w.shutdown() if hasattr(w, 'shutdown') else None


_FUZZ = dict(max_examples=int(os.environ.get('MDS_FUZZ_EXAMPLES', '150')), deadline=None,
             derandomize=not os.environ.get('MDS_FUZZ_SEED'), database=None,
             suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                    HealthCheck.data_too_large])


@settings(**_FUZZ)
@given(data=st.data())
def test_fuzzed_models_spawn_or_are_refused_by_name(world, data):
    kind, _src, text = data.draw(st.sampled_from(sources()))
    for _ in range(data.draw(st.integers(1, 3))):
        if data.draw(st.integers(0, 9)) == 0:
            text = mutate_bytes(text, data.draw)
        else:
            text = mutate_tree(text, data.draw)
    check_spawn(world, kind, text)


@settings(**dict(_FUZZ, max_examples=max(1, _FUZZ['max_examples'] // 3)))
@given(data=st.data())
def test_fuzzed_world_files_load_or_are_one_model_error(data):
    text = open(data.draw(st.sampled_from(WORLDS))).read()
    for _ in range(data.draw(st.integers(1, 3))):
        text = mutate_tree(text, data.draw) if data.draw(st.integers(0, 4)) else \
            mutate_bytes(text, data.draw)
    try:
        parse_world(text, base_dir=os.path.join(ROOT, 'sim_world', 'worlds'))
    except ModelError as e:
        assert str(e) and '\n' not in str(e).strip(), str(e)


def test_the_unmutated_sources_spawn(world):
    for kind, src, text in sources():
        ok, msg = check_spawn(world, kind, text, name='clean')
        assert ok, (src, msg)


def _box_robot(size='0.1 0.1 0.1', mass='1', inertia='0.01', com='0 0 0', link='l'):
    return ('<robot name="b"><link name="%s"><inertial><origin xyz="%s"/><mass value="%s"/>'
            '<inertia ixx="%s" iyy="%s" izz="%s" ixy="0" ixz="0" iyz="0"/></inertial>'
            '<collision><geometry><box size="%s"/></geometry></collision></link></robot>'
            % (link, com, mass, inertia, inertia, inertia, size))


@pytest.mark.parametrize('xml, why', [
    # found: ODE aborted the process (dxNormalize4 assertion), Bullet's twist turned NaN
    (_box_robot(mass='1e300', inertia='1e300'), 'inertial mass 1e+300 kg is outside'),
    (_box_robot(inertia='1e300'), 'inertia has an entry larger than 1e+06 kg m^2'),
    (_box_robot(mass='1e-300'), 'inertial mass 1e-300 kg is outside'),
    # found: Bullet put a box of 1e30 m at z = 1e28; both engines let these fall through
    (_box_robot(size='1e30 1e30 1e30'), 'box geometry has a dimension of 1e+30 m'),
    (_box_robot(com='1e300 0 0'), "link 'l' inertial origin xyz: position [1e+300, 0.0, 0.0] "
                                  "is farther than 1e+06 m"),
])
def test_regression_sizes_masses_and_offsets_that_break_the_engines_are_refused(world, xml,
                                                                                why):
    ok, msg = check_spawn(world, 'urdf', xml)
    assert not ok and why in msg, msg
    ok, msg = spawn_xml(world, 'urdf', 'far', _box_robot(),
                        initial_pose=Pose((2e6, 0.0, 0.0)))
    assert not ok and 'farther than 1e+06 m from the origin' in msg, msg
    assert check_spawn(world, 'urdf', _box_robot(mass='1e6', inertia='1e6'))[0]


def test_regression_a_status_message_is_one_line_whatever_the_names(world):
    # found: a link named '\n' made the status message (and its log line) two lines
    xml = _box_robot(link='&#10;').replace('<robot name="b">', '<robot name="b"><gazebo '
                                         'reference="nope"><static>true</static></gazebo>')
    ok, msg = check_spawn(world, 'urdf', xml)
    assert not ok and '\\n' in msg and '\n' not in msg, msg


def test_regression_a_plugin_that_fails_to_load_refuses_the_model_and_leaves_nothing(world):
    # found through the services (test_fuzz_spawn_ros.py): a second phone in the namespace
    # of the first made its plugins' rospy.Service raise 'service [/mobile_device/...]
    # already registered' out of the spawn handler (an error instead of an answer) and left
    # the model half added. A plugin's unexpected error now refuses the model, unloading the
    # plugins already loaded.
    from sim_world import plugins

    events = []

    @plugins.register('libfuzz_ok_plugin.so')
    class Ok(plugins.Plugin):
        def shutdown(self):
            events.append('ok shut down')

    @plugins.register('libfuzz_clash_plugin.so')
    class Clash(plugins.Plugin):
        def load(self):
            events.append('clash registered something')
            raise RuntimeError('service [/x/set_device_time] already registered')

        def shutdown(self):
            events.append('clash shut down')

    xml = _box_robot().replace('</robot>', '<gazebo><plugin name="a" filename='
                               '"libfuzz_ok_plugin.so"/><plugin name="b" filename='
                               '"libfuzz_clash_plugin.so"/></gazebo></robot>')
    ok, msg = check_spawn(world, 'urdf', xml, name='clash')
    assert not ok and "plugin libfuzz_clash_plugin.so of model 'clash' cannot be loaded: " \
        "RuntimeError: service [/x/set_device_time] already registered" in msg, msg
    assert events == ['clash registered something', 'clash shut down', 'ok shut down']
    assert 'clash' not in world.plugins


XACROS = sorted(glob.glob(os.path.join(URDF, '*.xacro')))


@settings(**dict(_FUZZ, max_examples=max(1, _FUZZ['max_examples'] // 3)))
@given(data=st.data())
def test_fuzzed_xacro_sources_load_or_are_one_model_error(tmp_path_factory, data):
    """The xacro sources mutated the same way (a spawn_model -file or a scenario's
    spawn_model action expands them first): sim_world.urdf.load_urdf_file gives a model or
    one ModelError, never another exception (xacro's own errors, SystemExit included)."""
    from sim_world.urdf import load_urdf_file
    src = data.draw(st.sampled_from(XACROS))
    text = open(src).read()
    for prefix, uri in re.findall(r'xmlns:(\w+)="([^"]+)"', text):
        ET.register_namespace(prefix, uri)     # ElementTree keeps xacro:, sensor: ...
    for _ in range(data.draw(st.integers(1, 2))):
        text = mutate_tree(text, data.draw) if data.draw(st.integers(0, 4)) else \
            mutate_bytes(text, data.draw)
    path = os.path.join(str(tmp_path_factory.getbasetemp()), 'fuzzed.urdf.xacro')
    with open(path, 'w', encoding='utf-8', errors='surrogatepass') as f:
        f.write(text)
    try:
        load_urdf_file(path)
    except ModelError as e:
        assert str(e).strip(), e


@pytest.mark.parametrize('mutation', JOINT_MUTATIONS)
@pytest.mark.parametrize('source', ['articulated.urdf', 'articulated.sdf'])
def test_each_bad_joint_is_refused_or_warned_by_name(world, source, mutation, caplog):
    """Issue 48's list, one at a time: refused with a message naming the joint (or its
    link), or spawned with a warning naming it; the world keeps stepping with finite poses."""
    import logging
    kind, _, text = next(s for s in sources() if s[1] == source)
    root = ET.fromstring(text)
    els = _elements(root)
    joints = [e for e in els if e.tag == 'joint']
    picks = iter([joints[0], mutation])     # the first joint, this mutation, then first choices

    def draw(strategy):
        try:
            return next(picks)
        except StopIteration:
            return _first(strategy)
    _mutate_joint(root, els, draw)
    xml = ET.tostring(root, encoding='unicode')
    with caplog.at_level(logging.WARNING):
        ok, msg = check_spawn(world, kind, xml, name='bad_joint')
    if mutation in ('mimic_cycle', 'lower_above_upper') and ok:
        assert 'cycle' in caplog.text or 'ignored' in caplog.text or kind == 'sdf'
    if not ok:
        assert any(n in msg for n in ("'shoulder'", "'hinge'", "'loop'", "'nope'", 'joint',
                                      "'base'", "'post'", 'root link')), msg


def _first(strategy):
    """The first value of a sampled_from / booleans strategy (deterministic picks)."""
    elems = getattr(strategy, 'elements', None)
    if elems is not None:
        return list(elems)[0]
    return False
