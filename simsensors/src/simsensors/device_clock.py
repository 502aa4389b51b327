"""The device clock of thesis section 3.3.9: ``libgazebo_ros_device_clock.so``.

The phone's own clock runs on sim time with a drift and an offset::

    device time = t_set + (sim time - sim time at t_set) * (1 + driftPpm * 1e-6)

(at start t_set = ``offset`` + the sim time, i.e. device time = sim time x (1 + drift) +
offset). The service ``set_device_time`` (mobile_device_sim/SetDeviceTime) sets it from
outside, as the thesis asks (an NTP/NITZ/GPS synchronisation, or a test that needs the
phone's clock at a given date); the clock runs on at its drift from there. A time before
1970 (negative) is refused with success false.

Topic: ``time_reference`` (sensor_msgs/TimeReference: header.stamp = sim time, time_ref =
device time, source = the plugin's name), default 1 Hz of sim time.
"""
import math

from sim_world import srvcheck
from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['DeviceClock', 'MAX_DEVICE_TIME']

MAX_DEVICE_TIME = 2.0 ** 32 - 1     # s: the latest time a ROS time message holds (2106)


@register('libgazebo_ros_device_clock.so')
class DeviceClock(Sensor):
    DEFAULT_TOPIC = 'time_reference'
    DEFAULT_RATE = 1.0
    PARAMS = [
        Param('driftPpm', float, 0.0, aliases=('drift_ppm', 'drift'), unit='ppm',
              check=(-1e5, 1e5), doc='rate error of the device clock (a quartz: ~20 ppm)'),
        Param('offset', float, 0.0, aliases=('timeOffset', 'time_offset'), unit='s',
              check='>=0', doc='device time at sim time 0 (s since 1970; 0: the clock '
                               'starts at the epoch like the sim time)'),
        Param('source', str, None, doc='TimeReference.source (default the plugin name)'),
        Param('serviceName', str, 'set_device_time', aliases=('service_name',)),
    ]

    def setup(self):
        from sensor_msgs.msg import TimeReference
        self.TimeReference = TimeReference
        self.output('main', TimeReference)
        self.source = self.p.source or self.spec.name or 'device_clock'
        self._anchor = (0.0, float(self.p.offset))
        if self.p.serviceName:
            from mobile_device_sim.srv import SetDeviceTime
            self.service(self.p.serviceName, SetDeviceTime, self._srv)

    @property
    def rate_factor(self):
        return 1.0 + self.p.driftPpm * 1e-6

    def device_time(self, sim_time=None):
        t = self.world.sim_time if sim_time is None else sim_time
        t0, d0 = self._anchor
        return d0 + (t - t0) * self.rate_factor

    def set_device_time(self, device_time, sim_time=None):
        """Set the clock to ``device_time`` (s) now; returns (success, status_message)."""
        try:
            # up to what a ROS time holds (TimeReference.time_ref: unsigned 32-bit seconds)
            d = srvcheck.number(device_time, 'device_time', 0, MAX_DEVICE_TIME,
                                's since 1970')
        except srvcheck.BadRequest as e:
            msg = '%s: %s' % (self.label, e)
            self.log_error(msg)
            return False, msg
        t = self.world.sim_time if sim_time is None else sim_time
        self._anchor = (float(t), d)
        return True, 'device time set to %.9f s at sim time %.6f s' % (d, t)

    def _srv(self, req):
        from mobile_device_sim.srv import SetDeviceTimeResponse
        ok, msg = self.set_device_time(req.device_time.to_sec())
        return SetDeviceTimeResponse(success=ok, status_message=msg)

    def measure(self, state, dt):
        return self.device_time(state.t)

    def to_msg(self, value, stamp):
        import rospy
        m = self.TimeReference()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        sec = int(math.floor(value))
        nsec = int(round((value - sec) * 1e9))
        if nsec >= 1000000000:
            sec, nsec = sec + 1, nsec - 1000000000
        m.time_ref = rospy.Time(sec, nsec)
        m.source = self.source
        return m

    def reset(self):
        Sensor.reset(self)
        self._anchor = (0.0, float(self.p.offset))
