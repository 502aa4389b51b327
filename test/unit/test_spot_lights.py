"""Spot lights (SDF <spot>): the world parser keeps the cone, and the camera (renderer) and
the light sensor agree about the same scene: the spot lights its cone and not beside it."""
import math

import numpy as np
import pytest

from sim_world.model import Light, ModelError
from sim_world.render import CameraView
from sim_world.render.renderer import cone_image
from sim_world.sdf import parse_world
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

import os
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')

SPOT_WORLD = '''<sdf version="1.6"><world name="spot">
  <scene><ambient>0.1 0.1 0.1 1</ambient></scene>
  <light name="spot" type="spot">
    <pose>0 0 2 0 0 0</pose>
    <diffuse>1 1 1 1</diffuse>
    <direction>0 0 -1</direction>
    <attenuation><range>10</range></attenuation>
    <spot><inner_angle>0.4</inner_angle><outer_angle>0.8</outer_angle><falloff>1</falloff></spot>
  </light>
  <include><uri>model://ground_plane</uri></include>
</world></sdf>'''


def test_parser_keeps_the_cone_and_direction():
    w = parse_world(SPOT_WORLD)
    lt = w.lights[0]
    assert lt.kind == 'spot'
    assert (lt.inner_angle, lt.outer_angle, lt.falloff) == (0.4, 0.8, 1.0)
    assert np.allclose(lt.world_direction(), (0, 0, -1))
    # the cone: full inside the inner half angle (0.2 rad), none outside the outer (0.4 rad)
    assert lt.spot_factor((math.tan(0.1), 0, -1)) == 1.0
    assert lt.spot_factor((math.tan(0.45), 0, -1)) == 0.0
    mid = lt.spot_factor((math.tan(0.3), 0, -1))
    assert 0.3 < mid < 0.7
    # a rotated pose turns the direction
    lt.pose = Pose.from_xyz_rpy((0, 0, 2), (0, math.pi / 2, 0))
    assert np.allclose(lt.world_direction(), (-1, 0, 0), atol=1e-9)
    # a point light has no cone
    assert Light('p', 'point').spot_factor((1, 0, 0)) == 1.0


@pytest.mark.parametrize('spot, words', [
    ('<inner_angle>1</inner_angle><outer_angle>0.5</outer_angle>', 'inner_angle 1 is wider'),
    ('<outer_angle>-1</outer_angle>', 'angles must be positive'),
    ('<falloff>x</falloff>', 'spot falloff'),
])
def test_bad_spot_names_the_light(spot, words):
    text = SPOT_WORLD.replace(
        '<inner_angle>0.4</inner_angle><outer_angle>0.8</outer_angle><falloff>1</falloff>', spot)
    with pytest.raises(ModelError) as e:
        parse_world(text)
    assert "light 'spot'" in str(e.value) and words in str(e.value)


def test_cone_image_is_the_cone():
    img = cone_image(0.4, 0.8, 1.0).astype(float)[:, :, 0] / 255
    n = img.shape[0]
    assert img[n // 2, n // 2] == pytest.approx(1.0, abs=0.01)
    assert img[0, 0] == 0 and img[n // 2, 0] < 0.05      # the edge of the frustum: outer cone
    # the frustum's full angle is the outer angle: a pixel at angle a off the axis
    lt = Light('s', 'spot', inner_angle=0.4, outer_angle=0.8, falloff=1.0)
    for a in (0.1, 0.25, 0.3, 0.35):
        u = (math.tan(a) / math.tan(0.4) + 1) / 2 * n - 0.5
        assert img[n // 2, int(round(u))] == pytest.approx(lt.spot_factor((math.tan(a), 0, -1)),
                                                          abs=0.06)


@pytest.fixture
def world(tmp_path):
    path = tmp_path / 'spot.world'
    path.write_text(SPOT_WORLD)
    w = World(physics='ode', seed=3)
    w.load_world_file(str(path))
    w.add_model(load_urdf_file(PHONE), pose=Pose((0.3, 0.3, 0.05)))
    yield w
    w.shutdown()


def _lux(world, xy):
    from simsensors.light_sensor import LightSensor
    world.set_state('mobile_device', Pose((xy[0], xy[1], 0.02)))
    world.step(300)
    sensor = [p for p in world.plugins['mobile_device'] if isinstance(p, LightSensor)][0]
    return sensor.last_value[2], dict((n, e) for e, _, n in sensor.parts)


def test_a_spot_lights_its_cone_and_not_beside_it_in_camera_and_light_sensor(world):
    # the camera: looking straight down from 3 m over the spot
    cam = CameraView(200, 200, hfov=math.radians(100),
                     pose=Pose.from_xyz_rpy((0, 0, 3), (0, math.pi / 2, 0)))
    img = world.renderer.render(cam).astype(float).mean(axis=2)

    def pix(x, y):
        (u, v), _ = cam.project((x, y, 0))
        return img[int(round(v)) - 1:int(round(v)) + 2, int(round(u)) - 1:int(round(u)) + 2].mean()
    centre, inside, beside, far = pix(0, -0.3), pix(0.5, -0.3), pix(1.5, -0.3), pix(-2, -1.5)
    assert centre > 100 and inside > 60                  # lit in the cone (radius 0.84 m)
    assert beside < 30 and far < 30                      # ambient 0.1 x the ground only
    assert abs(beside - far) < 3
    # the light sensor, on the floor at the same places
    lux_in, parts_in = _lux(world, (0.0, 0.3))
    lux_out, parts_out = _lux(world, (1.5, 0.3))
    assert parts_in.get('spot', 0) > 200                 # 1500 cd / 2^2 ~ 375 lx
    assert 'spot' not in parts_out
    assert lux_out < 0.2 * lux_in
    # between the inner and the outer cone, both follow the cone factor: the sensor's
    # spot part is the inverse-square law times it; the camera's lit ground (above its
    # ambient level, no distance attenuation in the renderer) is the cosine law times it
    lt = world.lights[0]
    _, parts_mid = _lux(world, (2 * math.tan(0.3) - 0.055, -0.012))
    p = world.link_pose('mobile_device', 'mobile_proximity_sensor').p
    v = lt.pose.p - p
    r = np.linalg.norm(v)
    cone = lt.spot_factor(-v)
    assert 0.2 < cone < 0.8
    assert parts_mid['spot'] == pytest.approx(1500 * cone * v[2] / r ** 3, rel=1e-6)
    for x in (0.45, 0.55, 0.62, 0.7):
        g = np.array([x, -0.3, 0.0])
        to = g - lt.pose.p
        c0 = np.array([0, -0.3, -2.0])
        expect = lt.spot_factor(to) * (-to[2] / np.linalg.norm(to)) / (2.0 / np.linalg.norm(c0))
        got = (pix(x, -0.3) - beside) / (centre - beside)
        assert got == pytest.approx(expect, abs=0.08), x


def test_shadows_a_board_under_the_spot_shades_camera_and_light_sensor_alike(tmp_path):
    """<scene><shadows>true</shadows>: a board between the spot and the floor leaves a
    shadow in the camera image where the light sensor's ray cast finds the lamp blocked."""
    path = tmp_path / 'spot.world'
    path.write_text(SPOT_WORLD.replace('<scene>', '<scene><shadows>true</shadows>'))
    w = World(physics='ode', seed=3)
    try:
        w.load_world_file(str(path))
        assert w.shadows and w.renderer.spot_shadows
        w.add_model(load_urdf_file(PHONE), pose=Pose((-0.05, -0.05, 0.05)))
        board = parse_urdf('''<robot name="board"><link name="b">
          <visual><geometry><box size="0.3 0.3 0.01"/></geometry></visual>
          <collision><geometry><box size="0.3 0.3 0.01"/></geometry></collision></link>
          <gazebo><static>true</static></gazebo></robot>''', name='board')
        w.add_model(board, pose=Pose((0, 0, 1.0)))
        cam = CameraView(200, 150, hfov=math.radians(70), pose=Pose.from_xyz_rpy(
            (2.5, 0, 1.0), (0, math.atan2(1.0, 2.5), math.pi)))
        img = w.renderer.render(cam).astype(float).mean(axis=2)

        def pix(x, y):
            (u, v), _ = cam.project((x, y, 0))
            return img[int(round(v)), int(round(u))]
        shade, lit, beside = pix(0.22, 0.1), pix(0.45, 0.1), pix(1.5, 0.1)
        assert abs(shade - beside) < 4                   # in the board's shadow: ambient only
        assert lit > shade + 40                          # in the cone, outside the shadow
        lux, parts = _lux(w, (-0.05, -0.05))
        assert 'spot' not in parts
        _, parts_lit = _lux(w, (0.45 - 0.055, 0.1))
        assert parts_lit.get('spot', 0) > 100
        # without shadows the camera lights the floor under the board
        w.renderer.spot_shadows = False
        img = w.renderer.render(cam).astype(float).mean(axis=2)
        assert pix(0.22, 0.1) > beside + 40
    finally:
        w.shutdown()


SUN_WORLD = '''<sdf version="1.6"><world name="sun">
  <scene><ambient>0.2 0.2 0.2 1</ambient><shadows>true</shadows></scene>
  <light name="sun" type="directional">
    <diffuse>0.8 0.8 0.8 1</diffuse>
    <direction>0.3 0.2 -1</direction>
  </light>
  <include><uri>model://ground_plane</uri></include>
  <model name="board"><static>true</static><pose>0 0 1 0 0 0</pose>
    <link name="l">
      <visual name="v"><geometry><box><size>0.6 0.6 0.02</size></box></geometry></visual>
      <collision name="c"><geometry><box><size>0.6 0.6 0.02</size></box></geometry></collision>
    </link></model>
</world></sdf>'''


def test_sun_shadows_in_the_camera_with_scene_shadows(tmp_path):
    """<scene><shadows>true</shadows>: a board 1 m over the ground casts the sun's shadow
    (offset along the sun's direction), where the light sensor's ray finds the sun blocked;
    without shadows the camera lights the ground there."""
    path = tmp_path / 'sun.world'
    path.write_text(SUN_WORLD)
    w = World(physics='ode', seed=3)
    try:
        w.load_world_file(str(path))
        assert w.renderer.sun_shadows
        cam = CameraView(200, 150, hfov=math.radians(90), pose=Pose.from_xyz_rpy(
            (-2.0, 0.0, 2.5), (0, math.radians(50), 0)))
        d = np.array([0.3, 0.2, -1.0])
        shade = np.array([0.0, 0.0, 1.0]) + d * 1.0          # under the board along the sun
        img = w.renderer.render(cam).astype(float).mean(axis=2)

        def pix(p):
            (u, v), _ = cam.project(p)
            return img[int(round(v)), int(round(u))]
        in_shadow, lit = pix(shade), pix(shade + (0, 1.0, 0))   # beside it
        assert lit > in_shadow + 40
        assert in_shadow < 40                                # ambient only: 0.2 x the ground
        w.renderer.sun_shadows = False
        img = w.renderer.render(cam).astype(float).mean(axis=2)
        assert abs(pix(shade) - pix(shade + (0, 1.0, 0))) < 8   # both lit without shadows
        # the light sensor agrees: its ray to the sun is blocked there, free beside it
        assert w.raycast(shade + (0, 0, 0.01), -d / np.linalg.norm(d), 100) is not None
        assert w.raycast(shade + (0, 1.0, 0.01), -d / np.linalg.norm(d), 100) is None
    finally:
        w.shutdown()
