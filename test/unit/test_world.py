"""World without ROS: sim-time plugin schedule, states in relative frames, reset, errors."""
import logging

import numpy as np
import pytest

from sim_world import plugins
from sim_world.model import ModelError
from sim_world.transforms import InvalidPose, Pose
from sim_world.urdf import parse_urdf

import worlds

CALLS = []


@plugins.register('libtest_counter.so')
class Counter(plugins.Plugin):
    def load(self):
        rate = self.float_param('updateRate', default=0.0)
        if rate < 0:
            raise plugins.PluginError('updateRate must be >= 0')
        self.update_rate = rate

    def update(self, sim_time):
        CALLS.append((self.spec.name, round(sim_time, 6)))
        if self.param('explode') == 'yes':
            raise RuntimeError('boom')


def box_robot(name='r', plugin_xml='', gravity=True):
    g = '' if gravity else '<gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>'
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>
      <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
      <link name="tip"><inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/>
      </inertial></link>
      <joint name="j" type="fixed"><parent link="base"/><child link="tip"/>
      <origin xyz="0.5 0 0"/></joint>%s%s</robot>''' % (name, g, plugin_xml))


world = worlds.world_fixture(seed=None, step_size=0.001)


def test_plugin_rate_follows_sim_time(world):
    del CALLS[:]
    xml = ('<gazebo><plugin name="a" filename="libtest_counter.so"><updateRate>30</updateRate>'
           '</plugin><plugin name="b" filename="libtest_counter.so"><updateRate>7</updateRate>'
           '</plugin></gazebo>')
    world.add_model(box_robot(plugin_xml=xml, gravity=False), pose=Pose((0, 0, 1)))
    world.step(2000)  # 2 s of sim time
    a = [t for n, t in CALLS if n == 'a']
    b = [t for n, t in CALLS if n == 'b']
    assert len(a) == 60 + 1 and len(b) == 14 + 1    # t = 0 counts too
    assert np.allclose(np.diff(a), 1 / 30.0, atol=0.001 + 1e-9)
    assert a[-1] == pytest.approx(2.0, abs=0.0011)


def test_the_worlds_scan_fires_each_plugin_when_its_own_timer_says(world):
    """World._update_plugins/reschedule read the timers inline: every plugin (rates 0, 7,
    30, 333 Hz, a rate changed mid-run by another plugin's update) fires exactly at the sim
    times its own UpdateTimer gives, step by step."""
    from sim_world.plugins.timer import UpdateTimer
    del CALLS[:]
    rates = {'every': 0, 'seven': 7, 'thirty': 30, 'fast': 333}
    xml = ''.join('<plugin name="%s" filename="libtest_counter.so"><updateRate>%g'
                  '</updateRate></plugin>' % kv for kv in rates.items())
    world.add_model(box_robot('scan', '<gazebo>%s</gazebo>' % xml, gravity=False),
                    pose=Pose((0, 0, 1)))
    mine = world.plugins['scan']
    own = {p.spec.name: UpdateTimer(p.timer.rate) for p in mine}
    expect = []
    for i in range(1, 700):
        if i == 300:                        # a rate changed from outside the scan
            nxt = [p for p in mine if p.spec.name == 'seven'][0]
            nxt.timer.set_rate(50, world.sim_time)
            own['seven'].set_rate(50, world.sim_time)
            world.reschedule()
        world.step(1)
        t = world.sim_time
        expect += [(n, round(t, 6)) for n in sorted(own) if own[n].due(t)]
    got = sorted(c for c in CALLS if c[1] > 0)
    assert got == sorted(expect)
    assert len([c for c in got if c[0] == 'every']) == 699


def test_failing_plugin_does_not_stop_the_world(world, caplog):
    del CALLS[:]
    xml = ('<gazebo><plugin name="bad" filename="libtest_counter.so"><updateRate>100</updateRate>'
           '<explode>yes</explode></plugin></gazebo>')
    with caplog.at_level(logging.ERROR):
        world.add_model(box_robot(plugin_xml=xml), pose=Pose((0, 0, 1)))
        world.step(100)
    assert world.sim_time == pytest.approx(0.1)
    assert len([c for c in CALLS if c[0] == 'bad']) == 11
    errors = [r for r in caplog.records if 'boom' in r.getMessage()]
    assert len(errors) == 1        # one line, not one per update


def test_unknown_plugin_warns_once_and_model_loads(world, caplog):
    # one warning per library name and process: a name of its own for each engine's run
    lib = 'libgazebo_ros_imu_never_%s.so' % world.physics_name
    xml = '<gazebo><plugin name="x" filename="%s"/></gazebo>' % lib
    with caplog.at_level(logging.WARNING):
        world.add_model(box_robot('r1', xml))
        world.add_model(box_robot('r2', xml))
    assert 'r1' in world.models and 'r2' in world.models
    warns = [r for r in caplog.records if lib in r.getMessage()]
    assert len(warns) == 1


def test_bad_plugin_param_is_one_error_and_model_loads(world, caplog):
    xml = ('<gazebo><plugin name="neg" filename="libtest_counter.so"><updateRate>-1</updateRate>'
           '</plugin></gazebo>')
    with caplog.at_level(logging.ERROR):
        world.add_model(box_robot(plugin_xml=xml))
    assert world.plugins['r'] == []
    assert any('updateRate must be' in r.getMessage() for r in caplog.records)


def test_states_in_relative_frames(world):
    world.add_model(box_robot('a', gravity=False), pose=Pose.from_xyz_rpy((1, 2, 3), (0, 0, 1.5707963)))
    world.add_model(box_robot('b', gravity=False), pose=Pose((2, 2, 3)))
    pose, lin, ang = world.get_state('b', 'a')
    # b is 1 m along world x from a; a is yawed 90 deg, so that is a's -y
    assert pose.p == pytest.approx([0, -1, 0], abs=1e-6)
    tip, _, _ = world.entity_state('a::tip')
    assert tip.p == pytest.approx([1, 2.5, 3], abs=1e-6)
    world.set_state('b', Pose((0, 0, 1)), reference_frame='a')
    assert world.model_state('b')[0].p == pytest.approx([1, 2, 4], abs=1e-6)
    with pytest.raises(KeyError, match='no_such'):
        world.get_state('b', 'no_such')
    with pytest.raises(KeyError, match='ambiguous'):
        world.entity_state('tip')
    with pytest.raises(KeyError):
        world.get_state('ghost')


def test_reset_and_teleport(world):
    world.add_model(box_robot('r'), pose=Pose((0, 0, 1)))
    world.step(300)
    assert world.model_state('r')[0].p[2] < 1.0      # falling
    world.set_state('r', Pose((5, 5, 5)))
    assert world.model_state('r')[0].p == pytest.approx([5, 5, 5])
    world.reset()
    assert world.model_state('r')[0].p == pytest.approx([0, 0, 1])
    assert world.model_state('r')[1] == pytest.approx([0, 0, 0])
    with pytest.raises(InvalidPose):
        world.set_state('r', Pose((0, 0, 1)), lin=[np.nan, 0, 0])


def test_duplicate_and_delete(world):
    world.add_model(box_robot('r'))
    with pytest.raises(ModelError, match='already exists'):
        world.add_model(box_robot('r'))
    world.delete_model('r')
    assert 'r' not in world.models
    with pytest.raises(KeyError):
        world.delete_model('r')


def test_office_world_loads_with_phone(world):
    import os
    from sim_world.urdf import load_urdf_file
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    world.load_world_file(os.path.join(root, 'sim_world', 'worlds', 'office.world'))
    world.add_model(load_urdf_file(os.path.join(root, 'sim_world', 'urdf',
                                                'mobile_device.urdf.xacro')),
                    pose=Pose((3.288, -2.11, 1.0)))
    names = [p.spec.filename for p in world.plugins['mobile_device']]
    assert 'libgazebo_ros_camera.so' in names and 'libgazebo_ros_video.so' in names
    world.step(50)
    assert world.model_state('mobile_device')[0].p == pytest.approx([3.288, -2.11, 1.0], abs=1e-6)
