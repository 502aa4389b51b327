"""libgazebo_ros_joint_state_publisher.so (sim_world.plugins.joint_state_publisher, issue 48):
the named joints at updateRate Hz of sim time, names in order, sim-time stamps; a jointName
that is not a simulated joint is one error naming it, and the model stays. No roscore."""
import logging

import pytest

from sim_world.physics import ENGINES
from sim_world.world import World

from test_joints import door

PLUGIN = ('<gazebo><plugin name="jsp" filename="libgazebo_ros_joint_state_publisher.so">'
          '<jointName>%s</jointName><updateRate>50</updateRate></plugin></gazebo></robot>')


def door_with_plugin(joints):
    from sim_world.urdf import parse_urdf
    m = door()
    return parse_urdf(m.source_xml.replace('</robot>', PLUGIN % joints))


@pytest.mark.parametrize('physics', ENGINES)
def test_joint_states_at_the_rate_in_sim_time(physics):
    w = World(physics=physics, seed=1)
    try:
        w.add_model(door_with_plugin('hinge'))
        plugin = w.find_plugins('door')[0]
        stamps = []
        orig = plugin.update

        def spy(t):
            orig(t)
            stamps.append(plugin.last_msg.header.stamp.to_sec())
        plugin.update = spy
        w.physics.apply_joint_effort('door', 'hinge', 20.0, steps=300)
        w.step(1000)
        assert len(stamps) == pytest.approx(50, abs=1)
        gaps = [b - a for a, b in zip(stamps[1:], stamps[2:])]   # the first tick: the first step
        assert all(abs(g - 0.02) < 1e-6 for g in gaps)
        msg = plugin.last_msg
        assert msg.name == ['hinge'] and msg.header.stamp.to_sec() == pytest.approx(stamps[-1])
        q, v = w.physics.joint_state('door', 'hinge')
        assert msg.position[0] > 0.1 and abs(msg.position[0] - q) < 0.02 * abs(v) + 1e-9
    finally:
        w.shutdown()


def test_unknown_joint_name_is_one_error_naming_it(caplog):
    w = World(physics='ode', seed=1)
    try:
        with caplog.at_level(logging.ERROR):
            w.add_model(door_with_plugin('hinge, nope'))
        assert 'door' in w.models
        assert "'nope'" in caplog.text
        assert not [p for p in w.find_plugins('door')
                    if p.spec.filename == 'libgazebo_ros_joint_state_publisher.so']
    finally:
        w.shutdown()
