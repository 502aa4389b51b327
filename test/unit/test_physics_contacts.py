"""engine.contacts(model, link): contact points of one link with the rest of the world, the
same on ODE and Bullet (the touch screen and the buttons read them)."""
import numpy as np
import pytest

from sim_world.physics import make_engine
from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

from worlds import finger

PHONE = parse_urdf('''<robot name="phone">
  <link name="body"><inertial><mass value="0.129"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
    <collision><geometry><box size="0.12 0.06 0.01"/></geometry></collision></link>
  <joint name="j" type="fixed"><parent link="body"/><child link="screen"/><origin xyz="0.002 0 0.005"/></joint>
  <link name="screen"><inertial><mass value="0.0001"/><inertia ixx="1e-8" iyy="1e-8" izz="1e-8"/></inertial>
    <collision><geometry><box size="0.09 0.054 0.0005"/></geometry></collision></link>
  <gazebo reference="body"><turnGravityOff>true</turnGravityOff></gazebo>
  <gazebo reference="screen"><turnGravityOff>true</turnGravityOff></gazebo></robot>''')


@pytest.fixture(params=['ode', 'bullet'])
def engine(request):
    e = make_engine(request.param)
    yield e
    e.close()


def add(engine, model, pose):
    model.pose = pose
    engine.add_model(model)


def test_finger_on_screen(engine):
    """A sphere pressed 0.4 mm into the screen at (x, y): contact points of link 'screen'
    there, depth 0.4 mm, normal pushing the phone down (-z); nothing on a link that is
    not touched by it far away; the finger sees the mirror contact."""
    add(engine, PHONE, Pose((0, 0, 1)))
    top = 1 + 0.005 + 0.00025
    add(engine, finger(), Pose((0.012, -0.01, top + 0.005 - 0.0004)))
    cs = engine.contacts('phone', 'screen')
    assert cs, 'no contact on the screen'
    c = max(cs, key=lambda c: c.depth)
    assert c.model == 'phone' and c.link == 'screen'
    assert c.other_model == 'finger' and c.other_link == 'tip'
    assert c.position[:2] == pytest.approx([0.012, -0.01], abs=5e-4)
    if engine.name == 'ode':
        assert c.depth == pytest.approx(0.0004, abs=1.5e-4)
    else:
        # pybullet keeps a 1 mm collision margin around boxes, so a 0.5 mm thin screen box
        # acts as 2 mm thick: the depth reads up to 0.75 mm more (README, touch section)
        assert 0.0004 <= c.depth <= 0.0004 + 0.00075 + 2e-4
    assert c.normal == pytest.approx([0, 0, -1], abs=2e-2)
    f = engine.contacts('finger')
    assert f and all(x.other_model == 'phone' for x in f)
    assert max(x.normal[2] for x in f) == pytest.approx(1.0, abs=1e-3)


def test_no_contact_when_apart_and_bad_names(engine):
    add(engine, PHONE, Pose((0, 0, 1)))
    add(engine, finger(), Pose((0, 0, 1.02)))
    assert engine.contacts('phone', 'screen') == []
    assert engine.contacts('phone') == []
    engine.step(1)
    engine.set_model_pose('finger', Pose((0, 0, 1.0098)))
    assert engine.contacts('phone', 'screen')
    with pytest.raises(KeyError, match='no link'):
        engine.contacts('phone', 'keyboard')
    with pytest.raises(KeyError):
        engine.contacts('ghost')


def test_contact_with_static_world(engine):
    """A box resting on a static table: contacts with the static model's link names."""
    table = parse_urdf('''<robot name="table"><link name="top">
      <collision><geometry><box size="1 1 0.1"/></geometry></collision></link></robot>''')
    table.static = True
    add(engine, table, Pose((0, 0, 0.5)))
    add(engine, PHONE, Pose((0, 0, 0.5 + 0.05 + 0.005 - 0.0003)))
    cs = engine.contacts('phone', 'body')
    assert cs and all(c.other_model == 'table' and c.other_link == 'top' for c in cs)
    assert np.mean([c.normal[2] for c in cs]) == pytest.approx(1.0, abs=1e-3)
    assert engine.contacts('phone', 'screen') == []


def test_contacts_after_a_teleport(engine):
    """Contacts describe the pose just set, before any step (fresh bounding boxes)."""
    table = parse_urdf('''<robot name="table"><link name="top">
      <collision><geometry><box size="1 1 0.1"/></geometry></collision></link></robot>''')
    table.static = True
    add(engine, PHONE, Pose((0, 0, 2)))
    add(engine, table, Pose((0, 0, 0.5)))
    engine.step(1)
    assert engine.contacts('phone') == []
    engine.set_model_pose('phone', Pose((0.1, 0, 0.5 + 0.05 + 0.005 - 0.0003)))
    cs = engine.contacts('phone', 'body')
    assert cs and all(c.other_model == 'table' for c in cs)
