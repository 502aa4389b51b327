"""The IMU (accelerometer + gyroscope) of thesis section 3.3.3, code snippet 3.3.2:
``libgazebo_ros_imu.so`` (also ``libgazebo_ros_imu_sensor.so``).

Parameters (thesis / Gazebo classic names): bodyName (a link of the model; default the
link of ``<gazebo reference>`` or the root link), topicName (default ``imu``), frameName
(default the link), updateRate (Hz of sim time; 0 = every step), gaussianNoise (standard
deviation added to every value), xyzOffsets / rpyOffsets (the thesis's "initialize imu for
fake localization" offsets: added to the reported orientation's rpy).

Publishes sensor_msgs/Imu stamped with sim time, only while someone subscribes:
orientation of the link in the world, angular velocity in the link frame, and the specific
force an accelerometer measures, ``R^T (a - g)``, from the link velocity differentiated
over the update period. A phone held still (or floating with gravity off) reads +9.81 m/s^2
along the world's up axis; a free-falling one reads 0.
"""
import numpy as np

from ..transforms import quat_from_rpy, quat_multiply, quat_normalize
from . import Plugin, PluginError, register

__all__ = ['ImuModel', 'ImuPlugin']


class ImuModel(object):
    """The measurement, without ROS: feed it (time, pose, linear, angular) samples."""

    def __init__(self, gravity=(0.0, 0.0, -9.81), noise=0.0, rpy_offsets=(0.0, 0.0, 0.0),
                 seed=None):
        self.gravity = np.asarray(gravity, float)
        self.noise = float(noise)
        self.q_offset = quat_from_rpy(*rpy_offsets)
        self.rng = np.random.default_rng(seed)
        self._last = None   # (t, linear velocity in the world)

    def sample(self, t, pose, lin, ang):
        """(orientation quaternion, angular velocity (link frame), specific force (link
        frame)) at sim time t."""
        lin = np.asarray(lin, float)
        acc = np.zeros(3)
        if self._last is not None and t > self._last[0]:
            acc = (lin - self._last[1]) / (t - self._last[0])
        self._last = (t, lin.copy())
        inv = pose.inverse()
        force = inv.rotate(acc - self.gravity)
        gyro = inv.rotate(np.asarray(ang, float))
        q = quat_normalize(quat_multiply(self.q_offset, pose.q))
        if self.noise > 0:
            force = force + self.rng.normal(0.0, self.noise, 3)
            gyro = gyro + self.rng.normal(0.0, self.noise, 3)
        return q, gyro, force

    def reset(self):
        self._last = None


@register('libgazebo_ros_imu.so', 'libgazebo_ros_imu_sensor.so')
class ImuPlugin(Plugin):
    def load(self):
        self.body = self.param('bodyName', 'body_name') or self.spec.link or self.model.root_link
        if self.body not in self.model.links:
            raise PluginError('<bodyName> %r is not a link of model %r' % (self.body,
                                                                           self.model.name))
        self.update_rate = self.float_param('updateRate', 'update_rate', default=0.0)
        if self.update_rate < 0:
            raise PluginError('<updateRate> must be >= 0, got %g' % self.update_rate)
        noise = self.float_param('gaussianNoise', default=0.0)
        if noise < 0:
            raise PluginError('<gaussianNoise> must be >= 0, got %g' % noise)
        rpy = self._vec('rpyOffsets')
        self.xyz_offsets = self._vec('xyzOffsets')
        self.frame_id = self.param('frameName', 'frame_name') or self.body
        self.topic = self.resolve(self.param('topicName', 'topic_name') or 'imu')
        self.imu = ImuModel(getattr(self.world, 'gravity', (0, 0, -9.81)), noise, rpy)
        self.last = None
        self.pub = None
        if getattr(self.world, 'ros_enabled', False):
            import rospy
            from sensor_msgs.msg import Imu
            self.Imu = Imu
            self.pub = rospy.Publisher(self.topic, Imu, queue_size=10)
            rospy.loginfo('imu %s/%s: %s at %g Hz of sim time', self.model.name, self.body,
                          self.topic, self.update_rate)

    def _vec(self, name):
        text = self.param(name)
        if text is None:
            return np.zeros(3)
        try:
            v = np.array([float(x) for x in text.split()])
        except ValueError:
            v = np.array([])
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise PluginError('<%s> must be three numbers, got %r' % (name, text))
        return v

    def update(self, sim_time):
        if self.pub is not None and self.pub.get_num_connections() == 0:
            self.imu.reset()    # nobody listens: skip, and do not differentiate across the gap
            return
        pose, lin, ang = self.world.entity_state('%s::%s' % (self.model.name, self.body))
        self.last = self.imu.sample(sim_time, pose, lin, ang)
        if self.pub is None:
            return
        q, gyro, force = self.last
        msg = self.Imu()
        msg.header.stamp = self.world.ros_now()
        msg.header.frame_id = self.frame_id
        msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = \
            (float(v) for v in q)
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = \
            (float(v) for v in gyro)
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = \
            (float(v) for v in force)
        var = float(self.imu.noise) ** 2
        for cov in (msg.orientation_covariance, msg.angular_velocity_covariance,
                    msg.linear_acceleration_covariance):
            cov[0] = cov[4] = cov[8] = var
        self.pub.publish(msg)

    def reset(self):
        Plugin.reset(self)
        self.imu.reset()

    def shutdown(self):
        if self.pub is not None:
            self.pub.unregister()
            self.pub = None
