"""Ambient temperature and relative humidity of thesis section 3.3.11:
``libgazebo_ros_ambient.so``.

Both come from the world environment at the position of the report frame: the air
temperature (``env.air_temperature``: ``indoor_temperature`` inside an indoor volume, the
outdoor ``temperature`` elsewhere, degC) and ``humidity`` (%, published as a fraction
0..1). The testing instance changes them at run time through /gazebo/set_environment (the
thesis's external unit feeding generated or played-back values); the next sample reads the
new value.

Topics: ``temperature`` (sensor_msgs/Temperature, degC) and ``humidity``
(sensor_msgs/RelativeHumidity, fraction 0..1), each with its error model's variance.
Rate: Android's ambient temperature and humidity sensors are on-change sensors; here both
are sampled at ``updateRate`` (default 1 Hz of sim time) and published on every sample
(``onChangeOnly`` true: only when the rounded value changed, plus a repeat every
``repeatPeriod`` s) so that a late subscriber gets a value within a second.
Noise (``temperature*``, ``humidity*`` error model rows): default sigma 0.1 degC and 0.5 %
RH (typical phone sensor figures; the Android CDD gives none).
"""
import math

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Ambient']


@register('libgazebo_ros_ambient.so')
class Ambient(Sensor):
    DEFAULT_TOPIC = 'temperature'
    DEFAULT_RATE = 1.0
    PUBLISH_EVERY_TICK = False          # two topics: published here
    ERRORS = {'temperature': dict(dims=1, gaussian_noise=0.1),
              'humidity': dict(dims=1, gaussian_noise=0.5)}
    PARAMS = [
        Param('humidityTopicName', str, 'humidity', aliases=('humidity_topic',)),
        Param('onChangeOnly', bool, False, aliases=('on_change_only',),
              doc='publish only when the value (rounded to the resolution) changed'),
        Param('temperatureResolution', float, 0.1, unit='degC', check='>=0'),
        Param('humidityResolution', float, 1.0, unit='%', check='>=0'),
        Param('repeatPeriod', float, 10.0, unit='s', check='>=0',
              doc='onChangeOnly: republish an unchanged value after this long'),
    ]

    def setup(self):
        from sensor_msgs.msg import RelativeHumidity, Temperature
        self.Temperature, self.RelativeHumidity = Temperature, RelativeHumidity
        if self.pub is None:
            self.pub = self._make_pub(self.topic, Temperature)
        self.hum_pub = self.advertise(self.p.humidityTopicName, RelativeHumidity)
        self._sent = {}

    @staticmethod
    def _round(v, res):
        return round(v / res) * res if res > 0 else v

    def measure(self, state, dt):
        env = self.env
        t = self.errors['temperature'].apply(env.air_temperature(state.pose.p))
        h = self.errors['humidity'].apply(env.get('humidity'))
        h = min(100.0, max(0.0, h))
        p = self.p
        t, h = self._round(t, p.temperatureResolution), self._round(h, p.humidityResolution)
        value = (float(t), float(h))
        self._publish(state.t, value)
        return value

    def _due(self, key, v, now):
        if not self.p.onChangeOnly:
            return True
        last = self._sent.get(key)
        return last is None or last[0] != v or (self.p.repeatPeriod > 0 and
                                                 now - last[1] >= self.p.repeatPeriod - 1e-9)

    def _publish(self, now, value):
        t, h = value
        if self.fault == 'drop':
            return
        stamp = None
        if (self.pub.wanted() or self.force) and self._due('t', t, now):
            stamp = self.stamp()
            m = self.Temperature()
            m.header.stamp, m.header.frame_id = stamp, self.frame_id
            m.temperature = t
            m.variance = float(self.errors['temperature'].variance[0])
            self.pub.publish(m)
            self.last_msg = m
            self._sent['t'] = (t, now)
        if (self.hum_pub.wanted() or self.force) and self._due('h', h, now):
            m = self.RelativeHumidity()
            m.header.stamp, m.header.frame_id = stamp or self.stamp(), self.frame_id
            m.relative_humidity = h / 100.0
            m.variance = float(self.errors['humidity'].variance[0]) / 1e4
            self.hum_pub.publish(m)
            self._sent['h'] = (h, now)

    def reset(self):
        Sensor.reset(self)
        self._sent = {}
