"""The proximity sensor of thesis section 3.3.7: ``libgazebo_ros_proximity.so``.

"Raytracing from a point on the surface of the mobile device in a specified direction": one
ray from the sensor's link (``bodyName``, on the phone ``mobile_proximity_sensor`` beside the
earpiece) along that link's +z (out of the screen), cast through the world's collision
geometry (``world.raycast``), ignoring the phone's own model. sensor_msgs/Range with
radiation type INFRARED.

Two kinds, as the thesis says (``mode``):

* ``binary`` (default, like most Android phones, whose proximity sensor reports only "near"
  or "far"): ``range`` is ``maxRange`` (0.05 m, Android's 5 cm) when nothing is within
  ``maxRange``, and ``nearValue`` (0 m) when something is;
* ``distance``: the distance to the first object hit, in ``minRange``..``maxRange``;
  ``maxRange`` when nothing is hit (perturbed by the error model: hector's
  ``gaussianNoise``, ``offset`` ... in m; default none, Android CDD 7.3.8 asks only for 1 bit).

Android's ``SensorEvent.values[0]`` is in cm: multiply ``range`` by 100.

Published on change, and repeated every ``repeatPeriod`` s of sim time (default 1 s) while
nothing changes; the sensor samples at ``updateRate`` (default 10 Hz of sim time).
"""
import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['Proximity', 'proximity_value']


def proximity_value(distance, mode='binary', max_range=0.05, min_range=0.0, near_value=0.0):
    """The reported range for the distance to the first hit (None: nothing hit)."""
    if mode == 'binary':
        return near_value if distance is not None and distance <= max_range else max_range
    if distance is None or distance > max_range:
        return max_range
    return max(min_range, distance)


@register('libgazebo_ros_proximity.so', 'libgazebo_ros_proximity_sensor.so')
class Proximity(Sensor):
    DEFAULT_TOPIC = 'proximity'
    DEFAULT_RATE = 10.0
    ERRORS = {'': dict(dims=1)}
    PARAMS = [
        Param('mode', ('binary', 'distance'), 'binary'),
        Param('maxRange', float, 0.05, aliases=('max_range', 'rangeMax'), unit='m', check='>0'),
        Param('minRange', float, 0.0, aliases=('min_range', 'rangeMin'), unit='m', check='>=0'),
        Param('nearValue', float, 0.0, aliases=('near_value',), unit='m', check='>=0',
              doc='binary mode: range reported while something is near'),
        Param('fieldOfView', float, 0.1, aliases=('field_of_view', 'fov'), unit='rad',
              check='>=0', doc='for the Range message (one ray is cast)'),
        Param('repeatPeriod', float, 1.0, aliases=('repeat_period',), unit='s', check='>=0',
              doc='republish an unchanged value after this long (0: only on change)'),
        Param('direction', 'vec3', (0.0, 0.0, 1.0),
              doc='ray direction in the body link frame (default +z, out of the screen)'),
    ]

    def setup(self):
        from sensor_msgs.msg import Range
        self.Range = Range
        # published on change, and again every repeatPeriod s while nothing changes
        self.output('main', Range, on_change=True, repeat=self.p.repeatPeriod)
        d = np.asarray(self.p.direction, float)
        n = np.linalg.norm(d)
        if not n > 1e-9:
            self.log_error('%s: direction must be a non-zero vector, got %s; using +z'
                           % (self.label, list(d)))
            d, n = np.array([0.0, 0.0, 1.0]), 1.0
        self.direction = d / n
        if self.p.minRange >= self.p.maxRange:
            self.log_error('%s: minRange must be below maxRange (%g), got %g; using 0'
                           % (self.label, self.p.maxRange, self.p.minRange))
            self.p.minRange = 0.0
        self.hit = None

    def cast(self, state):
        """Distance (m) to the first thing along the ray, or None."""
        origin = state.body_pose.p
        direction = state.body_pose.rotate(self.direction)
        self.hit = self.world.raycast(origin, direction, self.p.maxRange * 4 + 0.1,
                           ignore=(self.model.name,))
        return None if self.hit is None else float(self.hit.distance)

    def measure(self, state, dt):
        p = self.p
        d = self.cast(state)
        if p.mode == 'distance' and d is not None and d <= p.maxRange:
            d = float(self.errors[''].apply(np.array([d]))[0])
        return proximity_value(d, p.mode, p.maxRange, p.minRange, p.nearValue)

    def to_msg(self, value, stamp):
        m = self.Range()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.radiation_type = self.Range.INFRARED
        m.field_of_view = self.p.fieldOfView
        m.min_range = self.p.minRange if self.p.mode == 'distance' else self.p.nearValue
        m.max_range = self.p.maxRange
        m.range = value
        return m
