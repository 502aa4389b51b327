"""World.pass_states: the sensors of one plugin pass share the link states they read
(one entity_state per link and pass), a teleport during the pass clears them, and nothing
outlives the pass (a sensor updated by hand after set_state reads the new pose)."""
import pytest

from sim_world.transforms import Pose
from sim_world.urdf import parse_urdf
from sim_world.world import World

from simsensors.barometer import Barometer
from simsensors.magnetometer import Magnetometer


def robot():
    return parse_urdf('''<robot name="r"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="m" filename="libgazebo_ros_magnetic.so"><bodyName>base</bodyName>
        <updateRate>10</updateRate></plugin>
      <plugin name="b" filename="libgazebo_ros_air_pressure.so"><bodyName>base</bodyName>
        <updateRate>10</updateRate><gaussianNoise>0</gaussianNoise></plugin></gazebo></robot>''')


@pytest.fixture(params=['ode', 'bullet'])
def world(request):
    w = World(physics=request.param, seed=1)
    w.add_model(robot(), pose=Pose((0, 0, 1)))
    yield w
    w.shutdown()


def test_one_state_per_link_and_pass(world):
    calls = []
    orig = world.entity_state
    world.entity_state = lambda e: calls.append(e) or orig(e)
    world.step(1000)                      # ~10 passes of both sensors at 10 Hz
    n = [p.pub.count for p in world.plugins['r']]
    assert n[0] == n[1] >= 10
    assert calls.count('r::base') == n[0]   # not one per sensor
    assert world.pass_states is None      # nothing outlives a pass


def test_fresh_outside_a_pass_and_after_a_teleport_in_a_pass(world):
    baro = [p for p in world.plugins['r'] if isinstance(p, Barometer)][0]
    mag = [p for p in world.plugins['r'] if isinstance(p, Magnetometer)][0]
    world.step(100)
    p1 = baro.last_value
    world.set_state('r', Pose((0, 0, 11)))
    baro.update(world.sim_time)           # by hand, no step: reads the new height
    assert baro.last_value == pytest.approx(world.environment.pressure_at(11.0))
    assert baro.last_value < p1 - 100
    # a plugin teleporting the model during a pass: the later sensor sees the new pose
    orig = mag.update

    def teleport_then_measure(t):
        orig(t)
        world.set_state('r', Pose((0, 0, 21)))
    mag.update = teleport_then_measure
    world.plugins['r'].sort(key=lambda p: 0 if p is mag else 1)
    world.step(100)
    assert baro.last_value == pytest.approx(world.environment.pressure_at(21.0), abs=0.5)
