"""The magnetometer / compass (thesis 3.3.4) on the real phone model and World, both
engines, without ROS: the field in Android's device frame follows yaw and the world's north
offset alpha; hector's parameters override the world's field; hard-iron offset and CDD
noise; both URDF syntaxes; bad parameters; same seed same data."""
import logging
import math
import os

import numpy as np
import pytest

from sim_world.sdf import load_world_file
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

from simsensors.magnetometer import CDD_SIGMA, Magnetometer

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'worlds', 'office.world')
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')
TOL = 6 * CDD_SIGMA


def make_world(engine, seed=2):
    w = World(physics=engine, seed=seed)
    w.environment = load_world_file(OFFICE).environment
    return w


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = make_world(request.param)
    phone = load_urdf_file(PHONE)
    phone.static = True
    w.add_model(phone, pose=Pose((3, -2, 0.8)))
    yield w
    w.shutdown()


def mag(world, name='mobile_device'):
    return [p for p in world.plugins[name] if isinstance(p, Magnetometer)][0]


def face_up(world, yaw_deg):
    world.set_state('mobile_device', Pose.from_xyz_rpy((3, -2, 0.8), (0, 0, math.radians(yaw_deg))))
    world.step(40)
    return mag(world).last_value


def test_top_at_north_reads_along_plus_y_turned_by_declination(world):
    env = world.environment
    f, inc, dec = env.magnetic_elements()
    assert 45e-6 < f < 52e-6 and 60 < inc < 68 and 2 < dec < 6      # Munich, WMM
    h, v = f * math.cos(math.radians(inc)), f * math.sin(math.radians(inc))
    b = face_up(world, 338.5)                      # yaw = alpha: the top points north
    d = math.radians(dec)
    # device frame: y = top = north, x = right = east, z out of the screen (up)
    assert b == pytest.approx([h * math.sin(d), h * math.cos(d), -v], abs=TOL)
    msg = mag(world).last_msg
    assert msg.header.frame_id == 'mobile_device_frame'
    assert msg.magnetic_field_covariance[0] == pytest.approx(CDD_SIGMA ** 2)


def test_yaw_plus_90_turns_the_field_by_minus_90(world):
    b0 = np.mean([face_up(world, 338.5) for _ in range(20)], axis=0)
    b1 = np.mean([face_up(world, 338.5 + 90) for _ in range(20)], axis=0)
    # the phone turned left by 90 deg: the field turns right by 90 deg in its frame
    assert b1[:2] == pytest.approx([b0[1], -b0[0]], abs=TOL / 3)
    assert b1[2] == pytest.approx(b0[2], abs=TOL / 3)
    heading = math.degrees(math.atan2(b0[0], b0[1]))
    assert heading == pytest.approx(world.environment.get('magnetic_declination'), abs=1.0)


def test_follows_alpha(world):
    env = world.environment
    env.set('north_alpha', 90.0)               # north along world +y now
    b = face_up(world, 90.0)
    f, inc, dec = env.magnetic_elements()
    h = f * math.cos(math.radians(inc))
    assert b[1] == pytest.approx(h * math.cos(math.radians(dec)), abs=TOL)
    b = face_up(world, 338.5)                  # the old north is now 111.5 deg to the left
    assert math.degrees(math.atan2(b[0], b[1])) == pytest.approx(
        dec - (90.0 - 338.5 + 360.0), abs=2.0)


def robot(params, name='r'):
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="m" filename="libhector_gazebo_ros_magnetic.so">
        <bodyName>base</bodyName>%s</plugin></gazebo></robot>''' % (name, params))


def test_hector_field_parameters_and_hard_iron_offset():
    w = make_world('ode')
    try:
        w.add_model(robot('<magnitude>5e-5</magnitude><inclination>0</inclination>'
                          '<declination>0</declination><referenceHeading>0</referenceHeading>'
                          '<offset>1e-6 -2e-6 3e-6</offset><gaussianNoise>0</gaussianNoise>'),
                    pose=Pose((0, 0, 1)))
        w.step(100)
        # heading 0: the world x axis points north; body frame = world frame
        assert mag(w, 'r').last_value == pytest.approx([5e-5 + 1e-6, -2e-6, 3e-6], abs=1e-12)
    finally:
        w.shutdown()


def test_2011_syntax():
    w = make_world('bullet')
    try:
        w.add_model(parse_urdf('''<robot name="r"
            xmlns:controller="http://playerstage.sourceforge.net/gazebo/xmlschema/#controller">
          <link name="base"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
          <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
          <gazebo><controller:gazebo_ros_magnetic name="m" plugin="libgazebo_ros_magnetic.so">
          <updateRate>25</updateRate><robotNamespace>/phone</robotNamespace>
          </controller:gazebo_ros_magnetic></gazebo></robot>'''), pose=Pose((0, 0, 1)))
        m = mag(w, 'r')
        assert m.timer.rate == 25 and m.topic == '/phone/magnetic'
        w.step(100)
        assert np.linalg.norm(m.last_value) == pytest.approx(
            w.environment.magnetic_elements()[0], abs=TOL)
    finally:
        w.shutdown()


@pytest.mark.parametrize('params, words', [
    ('<magnitude>1.0</magnitude>', 'magnitude must be'),
    ('<inclination>120</inclination>', 'inclination must be'),
    ('<updateRate>-5</updateRate>', 'updateRate must be'),
    ('<gaussianNoise>loud</gaussianNoise>', 'gaussianNoise must be'),
])
def test_bad_parameters_one_line_and_loads(params, words, caplog):
    w = make_world('ode')
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(robot(params), pose=Pose((0, 0, 1)))
        lines = [r.getMessage() for r in caplog.records if words in r.getMessage()]
        assert len(lines) == 1 and 'libhector_gazebo_ros_magnetic.so' in lines[0] \
            and 'model r' in lines[0]
        w.step(100)
        assert np.linalg.norm(mag(w, 'r').last_value) > 40e-6
    finally:
        w.shutdown()


def test_same_seed_same_data():
    def run(seed):
        w = make_world('ode', seed)
        try:
            w.add_model(robot(''), pose=Pose((0, 0, 1)))
            out = []
            for _ in range(10):
                w.step(20)
                out.append(tuple(mag(w, 'r').last_value))
            return out
        finally:
            w.shutdown()
    a, b, c = run(1), run(1), run(2)
    assert a == b and a != c
    assert np.std(np.array(a)[:, 0]) > 0.1 * CDD_SIGMA
