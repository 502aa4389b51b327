"""The package's Gazebo-compatible messages and services must have gazebo_msgs' md5sums,
so that Gazebo clients (rosservice, gazebo_ros scripts, anything built against gazebo_msgs)
talk to sim_world unchanged.

Reference: the real gazebo_msgs definitions of ROS Noetic, copied verbatim from
github.com/ros-simulation/gazebo_ros_pkgs, branch noetic-devel (commit f9e1a4607842, Nov 2023),
paths gazebo_msgs/msg/*.msg and gazebo_msgs/srv/*.srv, into test/data/gazebo_msgs/.
The constants below are what genmsg 0.6.0 (Debian 12) computes from those texts, with
std_msgs/geometry_msgs from Debian's ROS packages; they equal the md5sums that
`rosmsg md5 gazebo_msgs/...` prints on a Noetic machine with gazebo_msgs installed.
The test checks both: our generated classes against the constants, and the constants
against a fresh genmsg computation from the stored real texts.
"""
import os

import pytest

import genmsg
import genmsg.gentools
import genmsg.msg_loader

DATA = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), 'data',
                    'gazebo_msgs')

# genmsg md5sums of gazebo_msgs (noetic-devel), see module docstring.
GAZEBO_MSGS_MD5 = {
    'msg/ModelState': '9330fd35f2fcd82d457e54bd54e10593',
    'msg/ModelStates': '48c080191eb15c41858319b4d8a609c2',
    'srv/GetModelState': '4c515e936d3319c9610c559c60bfc3d4',
    'srv/SetModelState': '5b3ab0281d4f5445def017e3a2e4a07b',
    'srv/SpawnModel': '9ed9c82c96abe1a00c3e8cdaeee24413',
    'srv/DeleteModel': '9ce56b4e9e54616de25d796dc972a262',
    'msg/ContactState': '48c0ffb054b8c444f870cecea1ee50d9',
    'msg/ContactsState': 'acbcb1601a8e525bf72509f18e6f668d',
}


def _ros_msg_dir(pkg):
    try:
        import rospkg
        return os.path.join(rospkg.RosPack().get_path(pkg), 'msg')
    except Exception:  # noqa: BLE001 - fall back to Debian's layout
        return '/usr/share/%s/msg' % pkg


def _genmsg_md5(kind, name):
    search = {'gazebo_msgs': [os.path.join(DATA, 'msg')],
              'std_msgs': [_ros_msg_dir('std_msgs')],
              'geometry_msgs': [_ros_msg_dir('geometry_msgs')]}
    ctx = genmsg.MsgContext.create_default()
    if kind == 'msg':
        spec = genmsg.msg_loader.load_msg_by_type(ctx, 'gazebo_msgs/' + name, search)
    else:
        spec = genmsg.msg_loader.load_srv_from_file(
            ctx, os.path.join(DATA, 'srv', name + '.srv'), 'gazebo_msgs/' + name)
    genmsg.msg_loader.load_depends(ctx, spec, search)
    return genmsg.gentools.compute_md5(ctx, spec)


def _our_class(kind, name):
    if kind == 'msg':
        import mobile_device_sim.msg as mod
    else:
        import mobile_device_sim.srv as mod
    return getattr(mod, name)


@pytest.mark.parametrize('key', sorted(GAZEBO_MSGS_MD5))
def test_reference_md5_matches_real_gazebo_text(key):
    kind, name = key.split('/')
    assert _genmsg_md5(kind, name) == GAZEBO_MSGS_MD5[key]


@pytest.mark.parametrize('key', sorted(GAZEBO_MSGS_MD5))
def test_generated_md5_equals_gazebo_msgs(key):
    kind, name = key.split('/')
    cls = _our_class(kind, name)
    assert cls._md5sum == GAZEBO_MSGS_MD5[key], (
        'mobile_device_sim/%s differs from gazebo_msgs/%s: field names or types changed'
        % (name, name))


@pytest.mark.parametrize('name', ['GetModelState', 'SetModelState', 'SpawnModel',
                                  'DeleteModel'])
def test_service_request_response_md5(name):
    """Request and response halves must match too (rospy checks them per connection)."""
    search = {'gazebo_msgs': [os.path.join(DATA, 'msg')],
              'std_msgs': [_ros_msg_dir('std_msgs')],
              'geometry_msgs': [_ros_msg_dir('geometry_msgs')]}
    ctx = genmsg.MsgContext.create_default()
    spec = genmsg.msg_loader.load_srv_from_file(
        ctx, os.path.join(DATA, 'srv', name + '.srv'), 'gazebo_msgs/' + name)
    genmsg.msg_loader.load_depends(ctx, spec, search)
    cls = _our_class('srv', name)
    assert cls._request_class._md5sum == genmsg.gentools.compute_md5(ctx, spec.request)
    assert cls._response_class._md5sum == genmsg.gentools.compute_md5(ctx, spec.response)


def test_field_names_and_types_match():
    """Same slots in the same order as gazebo_msgs (package prefix aside)."""
    from mobile_device_sim.msg import ModelState, ModelStates
    assert ModelState.__slots__ == ['model_name', 'pose', 'twist', 'reference_frame']
    assert ModelState._slot_types == ['string', 'geometry_msgs/Pose', 'geometry_msgs/Twist',
                                      'string']
    assert ModelStates.__slots__ == ['name', 'pose', 'twist']
    assert ModelStates._slot_types == ['string[]', 'geometry_msgs/Pose[]',
                                       'geometry_msgs/Twist[]']


# pr2_msgs/PowerState (the thesis's battery message, code snippet 3.3.4): the real text of
# github.com/PR2/pr2_common pr2_msgs/msg/PowerState.msg is stored in test/data/pr2_msgs/msg/;
# genmsg computes e6fa46a387cad0b7a80959a21587a6c9 from it, the md5sum rosserial and
# rosnodejs ship for pr2_msgs/PowerState.
PR2_POWER_STATE_MD5 = 'e6fa46a387cad0b7a80959a21587a6c9'
PR2_DATA = os.path.join(os.path.dirname(DATA), 'pr2_msgs')


def test_power_state_md5_equals_pr2_msgs():
    search = {'pr2_msgs': [os.path.join(PR2_DATA, 'msg')],
              'std_msgs': [_ros_msg_dir('std_msgs')]}
    ctx = genmsg.MsgContext.create_default()
    spec = genmsg.msg_loader.load_msg_by_type(ctx, 'pr2_msgs/PowerState', search)
    genmsg.msg_loader.load_depends(ctx, spec, search)
    assert genmsg.gentools.compute_md5(ctx, spec) == PR2_POWER_STATE_MD5
    from mobile_device_sim.msg import PowerState
    assert PowerState._md5sum == PR2_POWER_STATE_MD5
    assert PowerState.__slots__ == ['header', 'power_consumption', 'time_remaining',
                                    'prediction_method', 'relative_capacity', 'AC_present']
