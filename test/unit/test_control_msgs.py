"""ros_control's messages (issue 48 part 4): this package's copies of controller_manager_msgs
and control_msgs (Debian 12 ships neither) carry the upstream md5sums, so a Gazebo user's
clients (controller_manager's spawner, MoveIt's FollowJointTrajectory client, rqt) connect.
The expected values are the upstream packages' generated md5sums (controller_manager_msgs of
ros_control noetic, control_msgs 1.5), not computed from our copies."""
import pytest

UPSTREAM = {
    'srv.LoadController': '647e5c54b8d6468952d8d31f1efe96c0',
    'srv.UnloadController': '647e5c54b8d6468952d8d31f1efe96c0',
    'srv.SwitchController': 'b29a7abc673b2c54c14b54e50f8d06a5',
    'srv.ListControllers': '1341feb2e63fa791f855565d0da950d8',
    'srv.ListControllerTypes': 'c1d4cd11aefa9f97ba4aeb5b33987f4e',
    'srv.ReloadControllerLibraries': '40e8c411fd1797d2e2c486018f846040',
    'srv.QueryTrajectoryState': 'ec93cdecbd8062d761aa52b7c90cd44b',
    'msg.ControllerState': 'aeb6b261d97793ab74099a3740245272',
    'msg.JointTrajectoryControllerState': '10817c60c2486ef6b33e97dcd87f4474',
    'msg.FollowJointTrajectoryGoal': '69636787b6ecbde4d61d711979bc7ecb',
    'msg.FollowJointTrajectoryActionGoal': 'cff5c1d533bf2f82dd0138d57f4304bb',
    'msg.FollowJointTrajectoryResult': '493383b18409bfb604b4e26c676401d2',
    'msg.FollowJointTrajectoryActionResult': 'c4fb3b000dc9da4fd99699380efcc5d9',
    'msg.FollowJointTrajectoryFeedback': '10817c60c2486ef6b33e97dcd87f4474',
    'msg.FollowJointTrajectoryActionFeedback': 'd8920dc4eae9fc107e00999cce4be641',
}


@pytest.mark.parametrize('name', sorted(UPSTREAM))
def test_md5sum_equals_upstream(name):
    import importlib
    kind, cls = name.split('.')
    mod = importlib.import_module('mobile_device_sim.' + kind)
    assert getattr(mod, cls)._md5sum == UPSTREAM[name]


def test_trajectory_msgs_is_debians_own():
    from trajectory_msgs.msg import JointTrajectory
    assert JointTrajectory._type == 'trajectory_msgs/JointTrajectory'
    assert JointTrajectory._md5sum == '65b4f94a94d1ed67169da35a02f33d3f'
