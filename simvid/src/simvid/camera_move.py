"""camera_move: fly a model with a joystick (thesis section 4.2, table 4.2).

Each sensor_msgs/Joy message with a non-zero value moves the model relative to its OWN
frame: the translation axes (0, 1, 2 = x, y, z) and the rotation axes (3, 4, 5 = roll,
pitch, yaw, as spacenav_node publishes them) are divided by ``linear_scaler`` /
``angular_scaler`` (thesis default 100: full deflection moves 1 cm and turns 0.01 rad per
message), combined into the transform ``movement``, and the new pose is
``pose_out = pose_in * movement`` -- the thesis's btTransform product, computed with
``sim_world.transforms`` (tf2 conventions). The pose is read with /gazebo/get_model_state and
written with /gazebo/set_model_state.
"""
import numpy as np

from sim_world.logonce import LogOnce
from sim_world.transforms import Pose

__all__ = ['main', 'movement_from_axes', 'apply_movement', 'CameraMove']


def movement_from_axes(axes, linear_scaler=100.0, angular_scaler=100.0):
    """Joy axes -> movement Pose in the model's own frame, or None when all are zero."""
    a = np.zeros(6)
    vals = np.asarray(list(axes)[:6], float)
    a[:len(vals)] = vals
    if not np.all(np.isfinite(a)):
        raise ValueError('joystick axes contain a non-finite value: %s' % list(a))
    if not np.any(a):
        return None
    if linear_scaler == 0 or angular_scaler == 0:
        raise ValueError('linear_scaler and angular_scaler must not be zero')
    return Pose.from_xyz_rpy(a[:3] / linear_scaler, a[3:6] / angular_scaler)


def apply_movement(pose_in, movement):
    """pose_out = pose_in * movement (movement expressed in the model's frame)."""
    return pose_in * movement


class CameraMove(object):
    """The ROS side: Joy in, get/set_model_state out."""

    def __init__(self, joy_topic='/spacenav/joy', model_name='flycam', linear_scaler=100.0,
                 angular_scaler=100.0, wait=True):
        import rospy
        from sensor_msgs.msg import Joy
        from mobile_device_sim.msg import ModelState
        from mobile_device_sim.srv import GetModelState, SetModelState
        self.rospy = rospy
        self.ModelState = ModelState
        self.model_name = model_name
        self.linear_scaler = float(linear_scaler)
        self.angular_scaler = float(angular_scaler)
        if self.linear_scaler == 0 or self.angular_scaler == 0:
            raise ValueError('linear_scaler and angular_scaler must not be zero')
        if wait:
            from sim_world.netutil import wait_for_service
            for srv in ('/gazebo/get_model_state', '/gazebo/set_model_state'):
                if not wait_for_service(srv, timeout=5.0, caller=rospy.get_name()):
                    rospy.logwarn('camera_move: waiting for %s (is sim_world running?)', srv)
                    wait_for_service(srv, caller=rospy.get_name())
        self.get_state = rospy.ServiceProxy('/gazebo/get_model_state', GetModelState,
                                            persistent=False)
        self.set_state = rospy.ServiceProxy('/gazebo/set_model_state', SetModelState,
                                            persistent=False)
        self.moves = 0
        self._errors = LogOnce(say=lambda text: self.rospy.logerr('camera_move: %s', text),
                               until_changed=True)
        self.sub = rospy.Subscriber(joy_topic, Joy, self.on_joy, queue_size=1)

    def _error(self, msg):
        self._errors(msg)              # one line per distinct problem, not one per message

    def on_joy(self, joy):
        try:
            movement = movement_from_axes(joy.axes, self.linear_scaler, self.angular_scaler)
        except ValueError as e:
            self._error(str(e))
            return
        if movement is None:
            return
        try:
            res = self.get_state(self.model_name, 'world')
        except self.rospy.ServiceException as e:
            self._error('get_model_state failed: %s' % e)
            return
        if not res.success:
            self._error(res.status_message)
            return
        pose_out = apply_movement(Pose.from_msg(res.pose), movement)
        state = self.ModelState()
        state.model_name = self.model_name
        state.pose = pose_out.to_msg()
        state.twist = res.twist
        state.reference_frame = 'world'
        try:
            out = self.set_state(state)
        except self.rospy.ServiceException as e:
            self._error('set_model_state failed: %s' % e)
            return
        if not out.success:
            self._error(out.status_message)
            return
        self._errors.ok()
        self.moves += 1


def main():
    """``rosrun mobile_device_sim camera_move`` (the whole node; the script in
    simvid/nodes/ only calls it)."""
    import rospy
    rospy.init_node('camera_move')
    try:
        CameraMove(joy_topic=rospy.get_param('~joy_topic', '/spacenav/joy'),
                   model_name=rospy.get_param('~model_name', 'flycam'),
                   linear_scaler=rospy.get_param('~linear_scaler', 100.0),
                   angular_scaler=rospy.get_param('~angular_scaler', 100.0))
    except ValueError as e:
        rospy.logfatal('camera_move: %s', e)
        return 1
    rospy.spin()
    return 0
