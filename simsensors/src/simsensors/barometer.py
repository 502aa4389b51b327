"""The barometer / altitude sensor of thesis sections 3.3.5 and 3.3.11:
``libgazebo_ros_air_pressure.so`` (also ``libhector_gazebo_ros_baro.so``).

Air pressure (Pa) at the height of the report frame from the ICAO standard atmosphere at
the world's elevation + z (``env.pressure_at``: 101325 Pa, 288.15 K, -0.0065 K/m, exponent
5.2559; about -11 Pa per metre at the office's 519 m), plus the weather's
``pressure_offset`` of the environment (changeable at run time through
/gazebo/set_environment). Two noise models (``noiseModel``):

- ``gaussian`` (default): the shared error model, ``gaussianNoise`` (default 1 Pa, a phone
  barometer's RMS noise; the Android CDD 7.3.5 gives no figure), ``offset``, ``drift``...
- ``step``: the thesis's "random step function capped by an absolute maximum": the error
  holds a value for an exponentially distributed time (mean ``stepInterval`` s) and then
  jumps to a new value drawn uniformly in [-``stepMaximum``, +``stepMaximum``] Pa.

Topics: ``pressure`` (sensor_msgs/FluidPressure, Pa, variance from the noise model) and
``altitude`` (std_msgs/Float64, m above sea level from the measured pressure by the inverse
of the standard atmosphere, as Android's SensorManager.getAltitude does).
"""
import math

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Barometer', 'altitude_from_pressure', 'StepNoise']

SIGMA_PA = 1.0


def altitude_from_pressure(p, p0=101325.0, t0=288.15, lapse=-0.0065):
    """Height (m) of pressure p in the standard atmosphere (Android getAltitude with the
    ICAO exponent)."""
    if p <= 0:
        return float('nan')
    expo = 9.80665 * 0.0289644 / (8.31446 * -lapse) if lapse else None
    if expo is None:
        return -8.31446 * t0 / (9.80665 * 0.0289644) * math.log(p / p0)
    return t0 / -lapse * (1.0 - (p / p0) ** (1.0 / expo))


class StepNoise(object):
    """A random step function capped by an absolute maximum (thesis 3.3.5). Two draws per
    step whatever happens, so the sequence depends only on the seed and the tick count."""

    def __init__(self, maximum, interval, rng):
        self.maximum, self.interval, self.rng = float(maximum), float(interval), rng
        self.value = 0.0
        self.reset()

    def reset(self):
        self.value = float(self.rng.uniform(-self.maximum, self.maximum))

    def step(self, dt):
        u, v = self.rng.random(), self.rng.uniform(-self.maximum, self.maximum)
        p_jump = 1.0 if self.interval <= 0 else 1.0 - math.exp(-max(dt, 0.0) / self.interval)
        if u < p_jump:
            self.value = float(v)
        return self.value

    @property
    def variance(self):
        return self.maximum ** 2 / 3.0          # of the uniform distribution


@register('libgazebo_ros_air_pressure.so', 'libhector_gazebo_ros_baro.so')
class Barometer(Sensor):
    DEFAULT_TOPIC = 'pressure'
    DEFAULT_RATE = 10.0
    ERRORS = {'': dict(dims=1, gaussian_noise=SIGMA_PA)}
    PARAMS = [
        Param('noiseModel', ('gaussian', 'step'), 'gaussian', aliases=('noise_model',),
              doc='gaussian: the error model rows; step: the thesis step function'),
        Param('stepMaximum', float, 12.0, aliases=('step_maximum',), unit='Pa', check='>=0',
              doc='step model: absolute maximum of the error (12 Pa ~ 1 m)'),
        Param('stepInterval', float, 2.0, aliases=('step_interval',), unit='s', check='>=0',
              doc='step model: mean time between steps'),
        Param('altitudeTopicName', str, 'altitude', aliases=('altitude_topic',),
              doc='std_msgs/Float64 altitude (m) from the measured pressure ("": none)'),
    ]

    def setup(self):
        from sensor_msgs.msg import FluidPressure
        from std_msgs.msg import Float64
        self.FluidPressure, self.Float64 = FluidPressure, Float64
        self.output('main', FluidPressure)
        self.alt_pub = self.output('altitude', Float64, topic=self.p.altitudeTopicName) \
            if self.p.altitudeTopicName else None
        self.step_noise = StepNoise(self.p.stepMaximum, self.p.stepInterval, self.rng) \
            if self.p.noiseModel == 'step' else None

    @property
    def variance(self):
        if self.step_noise is not None:
            return self.step_noise.variance
        return float(self.errors[''].variance[0])

    def has_noise(self):
        if self.step_noise is not None:
            return self.step_noise.maximum > 0
        return Sensor.has_noise(self)

    def tick(self, sim_time, dt):
        if self.step_noise is not None:
            self.step_noise.step(dt)

    def altitude(self, pressure):
        """m above sea level of a measured pressure: the standard atmosphere's inverse (the
        weather's offset shows as an altitude error, as on a real phone)."""
        env = self.env
        return altitude_from_pressure(pressure, env.get('sea_level_pressure'),
                                      env.get('sea_level_temperature'),
                                      env.get('temperature_gradient'))

    def messages(self, value, stamp):
        out = {'main': lambda: self.to_msg(value, stamp)}
        if self.alt_pub is not None:
            self.last_altitude = self.altitude(value)
            out['altitude'] = self.Float64(data=self.last_altitude)
        return out

    def measure(self, state, dt):
        p = self.env.pressure_at(float(state.pose.p[2]))
        if self.step_noise is not None:
            return p + self.step_noise.value * self.noise_scale
        return float(self.errors[''].apply(p))

    def to_msg(self, value, stamp):
        m = self.FluidPressure()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.fluid_pressure = float(value)
        m.variance = self.variance
        return m

    last_altitude = None

    def reset(self):
        Sensor.reset(self)
        if self.step_noise is not None:
            self.step_noise.reset()
