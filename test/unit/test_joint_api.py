"""The joint and link services (sim_world.joint_api, issue 48): gazebo_msgs' md5sums, and
each handler on a World without roscore (the services only route requests to them).

md5sums: those of gazebo_msgs (ROS 1, noetic-devel), as printed by the gennodejs code
generated from gazebo_msgs in public repositories (request/response md5sums of
ApplyJointEffort, SetModelConfiguration, SetJointProperties, GetJointProperties,
GetLinkState, GetLinkProperties, GetModelProperties) and recomputed here by genmsg from
our srv/ and msg/ files, which carry the same definitions.
"""
import math

import pytest
import rospy

from mobile_device_sim.msg import LinkState, LinkStates, ODEJointProperties
from mobile_device_sim.srv import (ApplyJointEffortRequest, GetJointPropertiesRequest,
                                   GetJointProperties, GetLinkPropertiesRequest,
                                   GetLinkStateRequest, GetModelPropertiesRequest,
                                   JointRequestRequest, SetJointPropertiesRequest,
                                   SetLinkStateRequest, SetModelConfigurationRequest)
import mobile_device_sim.srv as srvs

from sim_world.joint_api import JointRosApi
from sim_world.physics import ENGINES
from sim_world.transforms import Pose
from sim_world.world import World

from test_joints import door, pendulum

MD5 = {
    'GetJointProperties': '7b30be900f50aa21efec4a0ec92d91c9',
    'SetJointProperties': '15a76e921b1410c698d82782ea5fa370',
    'ApplyJointEffort': 'c0039811b8cc919490b3cff748cdf46b',
    'JointRequest': '0be1351618e1dc030eb7959d9a4902de',
    'SetModelConfiguration': '10e3139d3b669c40afc057d38956fff7',
    'GetModelProperties': '5717f7bd34ed990fa80e28b3015027a3',
    'GetLinkState': '09d6c98cce97b35f7ab9bd70300657ab',
    'SetLinkState': '8a5146eb66ae4d26b0860b08f3f271be',
    'GetLinkProperties': '0e06a70386d0ee3fb880c02f23fcd821',
}
# published by gennodejs from gazebo_msgs (see the module docstring)
PART_MD5 = {
    ('ApplyJointEffort', 'Request'): '2c3396ab9af67a509ecd2167a8fe41a2',
    ('SetModelConfiguration', 'Request'): '160eae60f51fabff255480c70afa289f',
    ('SetJointProperties', 'Request'): '331fd8f35fd27e3c1421175590258e26',
    ('GetJointProperties', 'Response'): 'cd7b30a39faa372283dc94c5f6457f82',
    ('GetLinkState', 'Response'): '8ba55ad34f9c072e75c0de57b089753b',
    ('GetLinkProperties', 'Response'): 'a8619f92d17cfcc3958c0fd13299443d',
    ('GetModelProperties', 'Response'): 'b7f370938ef77b464b95f1bab3ec5028',
}


@pytest.mark.parametrize('name', sorted(MD5))
def test_service_md5sums_are_gazebo_msgs(name):
    assert getattr(srvs, name)._md5sum == MD5[name]


@pytest.mark.parametrize('name, part', sorted(PART_MD5))
def test_request_response_md5sums_are_gazebo_msgs(name, part):
    assert getattr(srvs, name + part)._md5sum == PART_MD5[(name, part)]


def test_message_md5sums_are_gazebo_msgs():
    assert LinkState._md5sum == '0818ebbf28ce3a08d48ab1eaa7309ebe'
    assert LinkStates._md5sum == '48c080191eb15c41858319b4d8a609c2'
    assert ODEJointProperties._md5sum == '1b744c32a920af979f53afe2f9c3511f'


class FakeApi(object):
    def __init__(self, world):
        self.world = world


@pytest.fixture(params=ENGINES)
def api(request):
    w = World(physics=request.param)
    w.add_model(door(friction=0.0))
    w.add_model(pendulum(), pose=Pose((5.0, 0.0, 0.0)))     # clear of the door
    yield JointRosApi(FakeApi(w), serve=False)
    w.shutdown()


def test_get_joint_properties_real_type(api):
    r = api.get_joint_properties(GetJointPropertiesRequest('door::hinge'))
    assert r.success and r.type == GetJointProperties._response_class.REVOLUTE
    assert r.position == [pytest.approx(0.0, abs=1e-9)] and len(r.rate) == 1
    r = api.get_joint_properties(GetJointPropertiesRequest('pend::hinge'))
    assert r.success and r.type == GetJointProperties._response_class.CONTINUOUS
    r = api.get_joint_properties(GetJointPropertiesRequest('frame'))
    assert r.success and r.type == GetJointProperties._response_class.FIXED


@pytest.mark.parametrize('name, words', [('nope', "'nope'"), ('hinge', 'ambiguous'),
                                         ('ghost::hinge', "'ghost'"), ('', 'no joint name')])
def test_unknown_joint_is_success_false_naming_it(api, name, words):
    r = api.get_joint_properties(GetJointPropertiesRequest(name))
    assert not r.success and words in r.status_message
    r = api.apply_joint_effort(ApplyJointEffortRequest(joint_name=name, effort=1.0))
    assert not r.success and words in r.status_message


def test_apply_joint_effort_for_a_duration(api):
    w = api.world
    req = ApplyJointEffortRequest(joint_name='door::hinge', effort=10.0,
                                  duration=rospy.Duration(0.1))
    assert api.apply_joint_effort(req).success
    w.step(100)
    _, v1 = w.physics.joint_state('door', 'hinge')
    w.step(100)
    q2, v2 = w.physics.joint_state('door', 'hinge')
    assert v1 > 0.05 and v2 == pytest.approx(v1, rel=1e-3)   # no effort after 0.1 s
    bad = ApplyJointEffortRequest(joint_name='door::hinge', effort=float('nan'),
                                  duration=rospy.Duration(1))
    r = api.apply_joint_effort(bad)
    assert not r.success and 'hinge' in r.status_message


def test_effort_forever_and_clear(api):
    w = api.world
    api.apply_joint_effort(ApplyJointEffortRequest(joint_name='door::hinge', effort=5.0,
                                                   duration=rospy.Duration(-1)))
    w.step(200)
    v1 = w.physics.joint_state('door', 'hinge')[1]
    api.clear_joint_forces(JointRequestRequest('door::hinge'))
    w.step(100)
    v2 = w.physics.joint_state('door', 'hinge')[1]
    w.step(100)
    assert v1 > 0 and w.physics.joint_state('door', 'hinge')[1] == pytest.approx(v2, rel=1e-3)


def test_set_model_configuration_and_properties(api):
    w = api.world
    r = api.set_model_configuration(SetModelConfigurationRequest(
        model_name='door', joint_names=['hinge'], joint_positions=[1.2]))
    assert r.success
    assert w.physics.joint_state('door', 'hinge') == pytest.approx((1.2, 0.0), abs=1e-9)
    r = api.set_model_configuration(SetModelConfigurationRequest(
        model_name='door', joint_names=['nope'], joint_positions=[1.0]))
    assert not r.success and "'nope'" in r.status_message
    r = api.set_model_configuration(SetModelConfigurationRequest(
        model_name='door', joint_names=['hinge'], joint_positions=[]))
    assert not r.success
    r = api.get_model_properties(GetModelPropertiesRequest('door'))
    assert r.success and r.joint_names == ['hinge'] and 'leaf' in r.body_names
    r = api.get_model_properties(GetModelPropertiesRequest('nope'))
    assert not r.success and "'nope'" in r.status_message


def test_set_joint_properties(api):
    w = api.world
    cfg = ODEJointProperties(damping=[2.0], fmax=[3.0])
    assert api.set_joint_properties(SetJointPropertiesRequest('door::hinge', cfg)).success
    js = w.physics._joint_of('door', 'hinge')[1]
    assert (js.damping, js.friction) == (2.0, 3.0)
    r = api.set_joint_properties(SetJointPropertiesRequest(
        'door::hinge', ODEJointProperties(hiStop=[1.0])))
    assert not r.success and 'hiStop' in r.status_message
    r = api.set_joint_properties(SetJointPropertiesRequest(
        'door::hinge', ODEJointProperties(damping=[-1.0])))
    assert not r.success and 'hinge' in r.status_message


def test_link_state_and_properties(api):
    w = api.world
    w.physics.set_joint_positions('door', {'hinge': math.pi / 2})
    r = api.get_link_state(GetLinkStateRequest('door::leaf', ''))
    assert r.success
    q = r.link_state.pose.orientation
    assert [q.z, q.w] == pytest.approx([math.sin(math.pi / 4), math.cos(math.pi / 4)], abs=1e-4)
    r = api.get_link_state(GetLinkStateRequest('door::leaf', 'door::post'))
    assert r.success
    assert not api.get_link_state(GetLinkStateRequest('door::nope', '')).success
    r = api.get_link_properties(GetLinkPropertiesRequest('door::leaf'))
    assert r.success and r.mass == 10.0 and r.com.position.x == pytest.approx(0.45)
    st = LinkState(link_name='door::leaf')
    st.pose.orientation.w = 1.0
    r = api.set_link_state(SetLinkStateRequest(st))
    assert not r.success and 'root link' in r.status_message
    st = LinkState(link_name='pend::world')
    st.pose.position.x = 3.0
    st.pose.orientation.w = 1.0
    assert api.set_link_state(SetLinkStateRequest(st)).success
    assert w.physics.link_pose('pend', 'base').p == pytest.approx([3.0, 0.0, 2.0], abs=1e-6)
