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
from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Ambient']


@register('libgazebo_ros_ambient.so')
class Ambient(Sensor):
    DEFAULT_TOPIC = 'temperature'
    DEFAULT_RATE = 1.0
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
        p = self.p
        repeat = p.repeatPeriod if p.onChangeOnly else 0.0
        self.output('main', Temperature, on_change=p.onChangeOnly, repeat=repeat)
        self.hum_pub = self.output('humidity', RelativeHumidity, topic=p.humidityTopicName,
                                   on_change=p.onChangeOnly, repeat=repeat)

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
        return (float(t), float(h))

    def messages(self, value, stamp):
        t, h = value
        m = self.Temperature()
        m.header.stamp, m.header.frame_id = stamp, self.frame_id
        m.temperature = t
        m.variance = float(self.errors['temperature'].variance[0])
        mh = self.RelativeHumidity()
        mh.header.stamp, mh.header.frame_id = stamp, self.frame_id
        mh.relative_humidity = h / 100.0
        mh.variance = float(self.errors['humidity'].variance[0]) / 1e4
        return {'main': m, 'humidity': mh}
