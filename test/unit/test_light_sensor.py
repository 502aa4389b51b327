"""The ambient light sensor (thesis 3.3.12) on the real phone in the office world, both
engines, without ROS (bad parameters: test_sensor_contract.py)."""
import math

import numpy as np
import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf

from simsensors.light_sensor import LightSensor, luminance

import worlds
from worlds import needs_raycast

DESK = (3.32, -2.10, 0.75)            # desk top centre
HALF = 0.01088 / 2
world = worlds.world_fixture(seed=2, office='world', phone=(DESK[0], DESK[1], 1.0))


def light(world):
    return worlds.plugin_of(world, LightSensor, 'mobile_device')


def reading(world, steps=400):
    world.step(steps)
    return light(world).last_value


@needs_raycast
def test_under_the_office_light_hundreds_of_lux(world):
    lux, color, clean = reading(world)
    assert 200 < lux < 900
    names = [n for _, _, n in light(world).parts]
    assert 'desk_lamp' in names and 'sun' not in names     # indoors: no sun
    assert lux == pytest.approx(clean, rel=0.05, abs=1)    # 1 % jitter, 1 lx steps
    # the lamp's part is the inverse-square law at the lamp's distance
    lamp = [lt for lt in world.lights if lt.name == 'desk_lamp'][0]
    p = world.link_pose('mobile_device', 'mobile_proximity_sensor').p
    v = lamp.pose.p - p
    r = np.linalg.norm(v)
    part = [e for e, _, n in light(world).parts if n == 'desk_lamp'][0]
    assert part == pytest.approx(1500 * luminance(lamp.diffuse) * v[2] / r / r ** 2, rel=1e-6)
    assert color[2] < color[0]                               # the lamp is warm (0.5 0.5 0.45)


@needs_raycast
def test_face_down_on_the_desk_reads_near_zero(world):
    world.set_state('mobile_device', Pose.from_xyz_rpy((DESK[0], DESK[1], DESK[2] + 0.015 + HALF + 0.0008),
                                                       (math.pi, 0, 0)))
    lux, color, clean = reading(world, 10)
    assert clean < 1.0 and lux < 2.0
    # turned back up at the same place: hundreds
    world.set_state('mobile_device', Pose((DESK[0], DESK[1], DESK[2] + 0.015 + HALF + 0.0008)))
    lux, _, _ = reading(world, 400)
    assert lux > 200


@needs_raycast
def test_occluded_lamp(world):
    """A board between the lamp and the phone takes the lamp's part away."""
    before = reading(world)[2]
    board = parse_urdf('''<robot name="board"><link name="b">
      <collision><geometry><box size="0.5 0.5 0.01"/></geometry></collision></link></robot>''')
    board.static = True
    world.add_model(board, pose=Pose((DESK[0], DESK[1], 1.6)))
    after = reading(world)[2]
    assert after < before - 200
    assert 'desk_lamp' not in [n for _, _, n in light(world).parts]


def test_outdoors_daylight_and_environment(world):
    """Outside the office (x > 6.1) face up in the open: about the environment's daylight
    (10000 lx); the sun's direction matters (tilted away: less); night: no daylight."""
    world.set_state('mobile_device', Pose((9.0, -3.0, 1.0)))
    lux = reading(world)[2]
    assert lux == pytest.approx(10000, rel=0.05)
    assert any(n == 'sun' for _, _, n in light(world).parts)
    # tilted 60 degrees away from the sun (sun direction -0.4 0.3 -0.85: it shines from +x -y)
    world.set_state('mobile_device', Pose.from_xyz_rpy((9.0, -3.0, 1.0), (0, -math.radians(60), 0)))
    tilted = reading(world)[2]
    assert tilted < 0.6 * lux
    world.set_state('mobile_device', Pose((9.0, -3.0, 1.0)))
    world.environment.set('daylight', 0.0)
    night = reading(world)[2]
    assert night < 100
    # the time of day: the sun over Munich at noon of an equinox (~75 klx), then midnight
    world.environment.set('time_of_day', 12.0)
    noon = world.environment.get('daylight')
    assert 60000 < noon < 90000
    assert reading(world, 201)[2] == pytest.approx(noon + night, rel=0.05)
    world.environment.set('time_of_day', 0.0)
    assert reading(world, 201)[2] == pytest.approx(night, abs=2)
    world.environment.set('daylight', 10000)


def test_same_seed_same_data():
    def run():
        with worlds.opened('ode', 12, office='world', phone=(DESK[0], DESK[1], 1.0)) as w:
            return worlds.sample(w, 200, 10, lambda: light(w).last_value[0])
    a, b = run(), run()
    assert a == b and len(set(a)) > 1          # jitter differs from sample to sample
