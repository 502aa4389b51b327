"""The IMU (accelerometer + gyroscope) of thesis section 3.3.3, code snippet 3.3.2:
``libgazebo_ros_imu.so`` (also ``libgazebo_ros_imu_sensor.so``, hector's
``libhector_gazebo_ros_imu.so``), on the shared sensor layer.

Publishes sensor_msgs/Imu stamped with sim time, only while someone subscribes, in the
report frame (``frameName``; default ``mobile_device_frame``, Android's device frame, where
the model has it): the orientation of that frame in the world, the angular velocity and the
specific force an accelerometer measures, ``R^T (a - g)``, from the body's velocity
differentiated over the update period (a phone lying face up at rest reads +9.81 m/s^2 on
z, standing upright +9.81 on y; a free-falling one reads 0).

Error models (hector names, per channel; each one number or three): ``accel*`` (default the
Android CDD limit, sigma 0.05 m/s^2), ``rate*`` (default variance 1e-7 rad^2/s^2 per Hz of the
update rate), ``orientation*`` (rpy noise, rad; default none). The thesis's single
``gaussianNoise`` still works: it sets the accelerometer and gyroscope sigma alike, as in
2011. ``rpyOffsets`` is added to the reported orientation; ``xyzOffsets`` (position of the
sensor on the body, which an Imu message cannot carry) is refused with one error line: put
the IMU on a link at that offset instead. Covariances come from the error models; the
orientation covariance is non-zero only when orientation noise is set.
"""
import numpy as np

from sim_world.transforms import quat_from_rpy, quat_multiply, quat_normalize
from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['ImuPlugin', 'ACCEL_SIGMA', 'GYRO_VARIANCE_PER_HZ']

#: Android CDD 7.3.1 / 7.3.4 figures used as the phone's defaults
ACCEL_SIGMA = 0.05             # m/s^2
GYRO_VARIANCE_PER_HZ = 1e-7    # rad^2/s^2 per Hz


@register('libgazebo_ros_imu.so', 'libgazebo_ros_imu_sensor.so', 'libhector_gazebo_ros_imu.so')
class ImuPlugin(Sensor):
    DEFAULT_TOPIC = 'imu'
    DEFAULT_RATE = 100.0
    ALWAYS_MEASURE = True       # differentiates velocity: keep the history whoever listens
    ERRORS = {
        'accel': dict(dims=3, gaussian_noise=ACCEL_SIGMA),
        'rate': dict(dims=3),
        'orientation': dict(dims=3),
    }
    PARAMS = [
        Param('gaussianNoise', float, None, unit='m/s^2 and rad/s', check='>=0',
              doc='thesis 2011: one sigma for accelerometer and gyroscope'),
        Param('rpyOffsets', 'vec3', (0.0, 0.0, 0.0), aliases=('rpyOffset',), unit='rad'),
        Param('xyzOffsets', 'vec3', (0.0, 0.0, 0.0), aliases=('xyzOffset',), unit='m',
              check=lambda v: not np.any(v),
              check_text='zero (an Imu message has no position: mount the IMU on a link '
                         'at that offset)'),
    ]

    def setup(self):
        from sensor_msgs.msg import Imu
        self.Imu = Imu
        self.output('main', Imu)
        p = self.p
        acc, rate = self.errors['accel'], self.errors['rate']
        if p.gaussianNoise is not None:              # 2011: one sigma for both
            acc.gaussian_noise[:] = p.gaussianNoise
            rate.gaussian_noise[:] = p.gaussianNoise
        elif 'rateGaussianNoise' not in p.given and self.timer.rate > 0:
            rate.gaussian_noise[:] = np.sqrt(GYRO_VARIANCE_PER_HZ * self.timer.rate)
        for e in (acc, rate):
            e.identity = False
        self.q_offset = quat_from_rpy(*p.rpyOffsets)
        self._last = None     # (t, linear velocity in the world)

    def measure(self, state, dt):
        lin = state.lin
        acc = np.zeros(3)
        if self._last is not None and state.t > self._last[0]:
            acc = (lin - self._last[1]) / (state.t - self._last[0])
        self._last = (state.t, np.array(lin, float))
        inv = state.pose.inverse()
        force = inv.rotate(acc - self.world.gravity)
        gyro = inv.rotate(np.asarray(state.ang, float))
        force = self.errors['accel'].apply(force)
        gyro = self.errors['rate'].apply(gyro)
        q = quat_multiply(self.q_offset, state.pose.q)
        o = self.errors['orientation']
        if not o.identity:
            q = quat_multiply(q, quat_from_rpy(*o.apply(np.zeros(3))))
        return quat_normalize(q), gyro, force

    @property
    def last(self):
        """(orientation xyzw, angular velocity, specific force) of the last sample."""
        return self.last_value

    def to_msg(self, value, stamp):
        q, gyro, force = value
        msg = self.Imu()
        msg.header.stamp = stamp
        msg.header.frame_id = self.frame_id
        o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        o.x, o.y, o.z, o.w = (float(v) for v in q)
        w.x, w.y, w.z = (float(v) for v in gyro)
        a.x, a.y, a.z = (float(v) for v in force)
        for cov, e in ((msg.orientation_covariance, self.errors['orientation']),
                       (msg.angular_velocity_covariance, self.errors['rate']),
                       (msg.linear_acceleration_covariance, self.errors['accel'])):
            var = e.variance
            cov[0], cov[4], cov[8] = float(var[0]), float(var[1]), float(var[2])
        return msg

    def reset(self):
        Sensor.reset(self)
        self._last = None
