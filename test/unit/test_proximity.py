"""The proximity sensor (thesis 3.3.7) on the real phone model and World, both engines,
without ROS: a ray along the screen's +z through the world's geometry (bad parameters:
test_sensor_contract.py)."""
import pytest

from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf

from simsensors.proximity import Proximity, proximity_value

import worlds
from worlds import needs_raycast

SENSOR = (0.055, 0.012, 1 + 0.01088 / 2 + 0.0005)     # the sensor link, phone at (0, 0, 1)
world = worlds.world_fixture(seed=4, phone=(0, 0, 1))


def hand(static=True):
    m = parse_urdf('''<robot name="hand"><link name="palm">
      <inertial><mass value="0.4"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3"/></inertial>
      <collision><geometry><box size="0.1 0.1 0.02"/></geometry></collision></link>
      <gazebo reference="palm"><turnGravityOff>true</turnGravityOff></gazebo></robot>''')
    m.static = static
    return m


def prox(world, name='mobile_device'):
    return worlds.plugin_of(world, Proximity, name)


def at(h):
    """Pose of the hand box whose underside is h above the sensor."""
    return Pose((SENSOR[0], SENSOR[1], SENSOR[2] + h + 0.01))


@needs_raycast
def test_near_and_far_binary(world):
    p = prox(world)
    world.step(200)
    assert p.last_value == 0.05                     # nothing near: max_range (Android: 5 cm)
    world.add_model(hand(), pose=at(0.02))
    world.step(200)
    assert p.last_value == 0.0                      # something within 5 cm: near
    assert p.hit is not None and p.hit.model == 'hand'
    assert p.last_msg.range == 0.0 and p.last_msg.max_range == pytest.approx(0.05)
    assert p.last_msg.radiation_type == p.last_msg.INFRARED
    world.set_state('hand', at(0.08))
    world.step(200)
    assert p.last_value == 0.05                     # 8 cm away: far again


@needs_raycast
def test_ignores_its_own_phone_and_looks_along_the_screen_normal(world):
    """The ray starts inside the phone's bounding box but ignores the phone; a hand beside
    the phone (not along +z) is not seen; turned face down, the desk under it is."""
    p = prox(world)
    world.add_model(hand(), pose=Pose((SENSOR[0] + 0.2, SENSOR[1], SENSOR[2] + 0.03)))
    world.step(200)
    assert p.last_value == 0.05
    world.set_state('hand', Pose((SENSOR[0], SENSOR[1], SENSOR[2] - 0.05)))  # below the phone
    world.step(200)
    assert p.last_value == 0.05
    world.set_state('mobile_device', Pose.from_xyz_rpy((0, 0, 1), (3.14159265, 0, 0)))
    world.step(200)
    assert p.last_value == 0.0                      # now the screen faces the hand below


@needs_raycast
def test_distance_mode(world):
    phone = load_urdf_file(worlds.PHONE)
    for spec in phone.plugins:
        if spec.filename == 'libgazebo_ros_proximity.so':
            for el in spec.element:
                if el.tag == 'mode':
                    el.text = 'distance'
    phone.name = 'phone2'
    world.add_model(phone, pose=Pose((2, 0, 1)))
    p = prox(world, 'phone2')
    assert p.p.mode == 'distance'
    world.add_model(hand(), pose=Pose((2 + SENSOR[0], SENSOR[1], SENSOR[2] + 0.03 + 0.01)))
    world.step(200)
    assert p.last_value == pytest.approx(0.03, abs=1e-3)


@needs_raycast
def test_on_change_and_slow_repeat(world):
    p = prox(world)
    world.step(3500)                      # 3.5 s unchanged: t = 0, 1, 2, 3
    assert p.pub.count == 4
    world.add_model(hand(), pose=at(0.01))
    world.step(110)                       # the next 10 Hz sample sees it: published at once
    assert p.pub.count == 5 and p.pub.last.range == 0.0


def test_pure_values():
    assert proximity_value(None) == 0.05
    assert proximity_value(0.049) == 0.0
    assert proximity_value(0.2) == 0.05
    assert proximity_value(0.03, 'distance') == 0.03
    assert proximity_value(0.001, 'distance', min_range=0.005) == 0.005
    assert proximity_value(0.3, 'distance') == 0.05


@needs_raycast
def test_same_seed_same_data():
    def run():
        with worlds.opened('ode', 9, phone=(0, 0, 1)) as w:
            w.add_model(hand(), pose=at(0.03))
            return worlds.sample(w, 100, 10, lambda: prox(w).last_value)
    assert run() == run()
