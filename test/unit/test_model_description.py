"""/gazebo/get_model_description (sim_world.spawn.model_description, what gazebo_api's
handler answers with): a spawned model's request as sent, a world-file model's <model>
element, an unknown model refused by name. No roscore: the handler's logic on a World."""
import os
from types import SimpleNamespace

from sim_world.sdf import parse_sdf_model
from sim_world.spawn import model_description, spawn_xml
from sim_world.urdf import parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')

SDF = '''<sdf version="1.6"><model name="crate"><pose>0 0 0.1 0 0 0</pose>
  <link name="body"><inertial><mass>1</mass></inertial><visual name="v"><geometry><box><size>0.2 0.3 0.4</size></box></geometry>
  <material><diffuse>0.1 0.9 0.2 1</diffuse></material></visual></link></model></sdf>'''
URDF = '''<robot name="r"><link name="base"><inertial><mass value="0.1"/>
  <inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
  <visual><geometry><cylinder radius="0.05" length="0.2"/></geometry></visual></link></robot>'''


def req(xml, ns=''):
    return SimpleNamespace(model_xml=xml, robot_namespace=ns)


def test_spawned_models_answer_their_request():
    w = World(physics='ode', seed=0)
    try:
        assert spawn_xml(w, 'sdf', 'crate2', SDF)[0]
        assert spawn_xml(w, 'urdf', 'bot', URDF, '/bot')[0]
        spawned = {'crate2': ('sdf', req(SDF)), 'bot': ('urdf', req(URDF, '/bot'))}
        ok, msg, fmt, xml, ns, base = model_description(w, 'crate2', spawned)
        assert (ok, fmt, xml, ns) == (True, 'sdf', SDF, '')
        assert base == os.getcwd()          # where a relative mesh path resolved
        ok, msg, fmt, xml, ns, _ = model_description(w, 'bot', spawned)
        assert (ok, fmt, xml, ns) == (True, 'urdf', URDF, '/bot')
        # what it answers describes the model again (the studio's use)
        assert list(parse_urdf(xml, name='bot').links) == ['base']
    finally:
        w.shutdown()


def test_world_file_models_answer_their_model_element():
    w = World(physics='ode', seed=0)
    try:
        w.load_world_file(OFFICE)
        ok, msg, fmt, xml, ns, base = model_description(w, 'nfc_poster', {})
        assert ok and fmt == 'sdf' and ns == ''
        assert base == os.path.dirname(OFFICE)
        m = parse_sdf_model(xml, base)
        assert m.name == 'nfc_poster' and list(m.links) == ['poster']
        assert [p.filename for p in m.plugins] == ['libgazebo_ros_nfc_tag.so']
    finally:
        w.shutdown()


def test_unknown_and_undescribed_models_are_refused_by_name():
    w = World(physics='ode', seed=0)
    try:
        ok, msg, fmt, xml, _, _ = model_description(w, 'no_such', {})
        assert not ok and "'no_such'" in msg and xml == '' and fmt == ''
        m = parse_urdf(URDF, name='coded')
        m.source_xml = None                 # added by code: no text kept
        w.add_model(m)
        ok, msg, _, _, _, _ = model_description(w, 'coded', {})
        assert not ok and "'coded'" in msg and 'no description' in msg
    finally:
        w.shutdown()
