"""The magnetometer / compass of thesis section 3.3.4: ``libgazebo_ros_magnetic.so``,
hector's ``libhector_gazebo_ros_magnetic.so``.

The world's magnetic field (``env.magnetic_field_world()``: the World Magnetic Model at the
world's location, or the world file's magnitude/inclination/declination; horizontal part
towards magnetic north = true north turned east by the declination, north at ``north_alpha``
from the world x axis) in the report frame (Android's device frame on the phone), in tesla.
The plugin's own hector parameters ``magnitude`` (T), ``declination``, ``inclination`` (deg)
and ``referenceHeading`` (deg, north counter-clockwise from the world x axis as in
hector's formula, i.e. the world's ``north_alpha``) override
the world's values one by one. Error model: hector's ``offset`` (the hard-iron offset, T,
one number or three), ``drift``, ``driftFrequency``, ``gaussianNoise`` (default 0.5 uT per
axis, the Android CDD 7.3.2 figure), ``scaleError`` (soft iron, per axis).
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Magnetometer', 'CDD_SIGMA', 'field_vector']

#: Android CDD 7.3.2: standard deviation per axis (SHOULD) 0.5 microtesla
CDD_SIGMA = 0.5e-6


def field_vector(magnitude, inclination_deg, declination_deg, north_alpha_deg):
    """World-frame field (T): horizontal magnitude*cos(inc) towards magnetic north (true
    north at north_alpha CCW from world x, turned east by the declination), vertical part
    magnitude*sin(inc) downwards."""
    a = math.radians(north_alpha_deg)
    north = np.array([math.cos(a), math.sin(a), 0.0])
    east = np.array([math.sin(a), -math.cos(a), 0.0])
    inc, dec = math.radians(inclination_deg), math.radians(declination_deg)
    h = magnitude * math.cos(inc)
    return h * (math.cos(dec) * north + math.sin(dec) * east) + \
        np.array([0.0, 0.0, -magnitude * math.sin(inc)])


@register('libgazebo_ros_magnetic.so', 'libhector_gazebo_ros_magnetic.so')
class Magnetometer(Sensor):
    DEFAULT_TOPIC = 'magnetic'
    DEFAULT_RATE = 50.0
    _field = None                  # (environment, world-frame field) cached
    ERRORS = {'': dict(dims=3, gaussian_noise=CDD_SIGMA)}
    PARAMS = [
        Param('magnitude', float, None, unit='T', check=(0.0, 1e-2),
              doc="total field (default the world's; Earth: 25e-6..65e-6)"),
        Param('declination', float, None, unit='deg', check=(-180.0, 180.0),
              doc="magnetic north east of true north (default the world's)"),
        Param('inclination', float, None, unit='deg', check=(-90.0, 90.0),
              doc="dip below the horizon (default the world's)"),
        Param('referenceHeading', float, None, aliases=('reference_heading',), unit='deg',
              check=(-360.0, 360.0),
              doc="hector: angle of north counter-clockwise from the world x axis, like "
                  "north_alpha (default the world's north_alpha)"),
    ]

    def setup(self):
        from sensor_msgs.msg import MagneticField
        self.MagneticField = MagneticField
        self.output('main', MagneticField)
        p = self.p
        self.own = any(v is not None for v in (p.magnitude, p.declination, p.inclination,
                                                p.referenceHeading))

    def field_world(self):
        """The world-frame field (T), recomputed only when the environment changes."""
        env = self.env
        cached = self._field
        if cached is not None and cached[0] is env:
            return cached[1]
        if self._forget not in env.on_change:
            env.on_change.append(self._forget)
        f = self._field_world(env)
        self._field = (env, f)
        return f

    def _forget(self, name=None, value=None):
        self._field = None

    def shutdown(self):
        env = self.env
        if self._forget in env.on_change:
            env.on_change.remove(self._forget)
        Sensor.shutdown(self)

    def _field_world(self, env):
        if not self.own:
            return env.magnetic_field_world()
        p = self.p
        f, inc, dec = env.magnetic_elements()
        alpha = env.get('north_alpha') if p.referenceHeading is None \
            else p.referenceHeading
        return field_vector(f if p.magnitude is None else p.magnitude,
                            inc if p.inclination is None else p.inclination,
                            dec if p.declination is None else p.declination, alpha)

    def measure(self, state, dt):
        b = self.to_frame(self.field_world(), state)
        return np.asarray(self.errors[''].apply(b), float)

    def to_msg(self, value, stamp):
        m = self.MagneticField()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z = (float(v) for v in value)
        var = self.errors[''].variance
        m.magnetic_field_covariance = [float(var[0]), 0.0, 0.0, 0.0, float(var[1]), 0.0,
                                       0.0, 0.0, float(var[2])]
        return m
