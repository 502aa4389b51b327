"""The thermal display of thesis section 3.4.4: ``libgazebo_ros_thermal_display.so``.

A Peltier element on the back of the phone (the AffectPhone of thesis 3.3.15) heats or
cools it to the commanded temperature (std_msgs/Float64, degC, on
``thermal_display/temperature``), with a first-order lag of ``timeConstant`` s (default 3):
after one time constant 63 % of a step is reached, exactly on the sim-time clock
(T += (T_cmd - T)(1 - exp(-dt/tau)) each tick). It starts and rests at
``neutralTemperature`` (33 degC, skin).

The thesis's visualisation: the back turns red when heated, blue when cooled. The renderer
draws the link (``bodyName``; default the phone's ``mobile_back`` plate, else the
``<gazebo reference>`` link or the model root) unlit in its material colour at the neutral
temperature, blended towards red up to ``hotTemperature`` (43 degC, fully red) and towards
blue down to ``coldTemperature`` (23 degC, fully blue).

``thermal_display/state`` (sensor_msgs/Temperature, degC, every tick while subscribed) is
the back's temperature now. The battery sees ``powerPerKelvin`` W per K away from neutral.
Bad input (NaN, infinite, or outside ``minTemperature``..``maxTemperature``, default
0..60 degC): one error line naming it; the display keeps its last target.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.device import Actuator

__all__ = ['ThermalDisplay', 'thermal_color', 'first_order']

RED = np.array([1.0, 0.0, 0.0])
BLUE = np.array([0.0, 0.2, 1.0])


def first_order(temp, target, dt, tau):
    """The temperature ``dt`` s later (exact first-order step response)."""
    if tau <= 0:
        return target
    return target + (temp - target) * math.exp(-dt / tau)


def thermal_color(temp, neutral_rgb, neutral=33.0, hot=43.0, cold=23.0):
    """(r, g, b) 0..1: neutral_rgb at ``neutral``, towards red up to ``hot``, towards blue
    down to ``cold``."""
    base = np.asarray(neutral_rgb, float)[:3]
    if temp >= neutral:
        k = min(1.0, (temp - neutral) / max(hot - neutral, 1e-9))
        c = base + (RED - base) * k
    else:
        k = min(1.0, (neutral - temp) / max(neutral - cold, 1e-9))
        c = base + (BLUE - base) * k
    return tuple(float(v) for v in np.clip(c, 0.0, 1.0))


@register('libgazebo_ros_thermal_display.so', 'libthermal_display.so')
class ThermalDisplay(Actuator):
    DEFAULT_TOPIC = 'thermal_display/temperature'
    DEFAULT_RATE = 10.0
    PARAMS = [
        Param('timeConstant', float, 3.0, aliases=('time_constant', 'tau'), unit='s',
              check='>=0', doc='first-order lag of the back temperature'),
        Param('neutralTemperature', float, 33.0, aliases=('neutral_temperature',),
              unit='degC', doc='start and rest temperature (skin), shown in the material colour'),
        Param('hotTemperature', float, 43.0, aliases=('hot_temperature',), unit='degC',
              doc='fully red from here'),
        Param('coldTemperature', float, 23.0, aliases=('cold_temperature',), unit='degC',
              doc='fully blue from here'),
        Param('minTemperature', float, 0.0, unit='degC', doc='lowest command accepted'),
        Param('maxTemperature', float, 60.0, unit='degC', doc='highest command accepted'),
        Param('powerPerKelvin', float, 0.05, aliases=('power_per_kelvin',), unit='W/K',
              check='>=0', doc='Peltier draw per K away from neutral'),
        Param('stateTopicName', str, 'thermal_display/state', aliases=('state_topic',),
              doc='sensor_msgs/Temperature of the back now'),
    ]

    def setup(self):
        from sensor_msgs.msg import Temperature
        from std_msgs.msg import Float64
        self.Temperature = Temperature
        p = self.p
        if p.bodyName is None and self.spec.link is None and 'mobile_back' in self.model.links:
            self.body = 'mobile_back'
        self.neutral_rgb = (0.05, 0.05, 0.05)
        for v in self.model.links[self.body].visuals:
            self.neutral_rgb = tuple(v.material.rgba[:3])
            break
        self.temperature = self.target = p.neutralTemperature
        self._last_t = self.world.sim_time
        self.output('main', Temperature, topic=p.stateTopicName)
        self.subscribe(self.topic, Float64, lambda m: self.command(m.data))

    def command(self, degc):
        """New target temperature (from any thread), taken at the next tick. False (and
        one error line) for bad input: the display keeps its last target."""
        p = self.p
        try:
            t = float(degc)
        except (TypeError, ValueError):
            t = float('nan')
        if not (math.isfinite(t) and p.minTemperature <= t <= p.maxTemperature):
            self.log_error('%s: thermal_display/temperature must be a number of degC in '
                           '%g..%g, got %r; the display keeps %g degC as its target'
                           % (self.label, p.minTemperature, p.maxTemperature, degc,
                              self.target))
            return False
        self.queue(t)
        return True

    def color(self):
        p = self.p
        return thermal_color(self.temperature, self.neutral_rgb, p.neutralTemperature,
                             p.hotTemperature, p.coldTemperature)

    def act(self, t, commands):
        step = max(0.0, t - self._last_t)
        self._last_t = t
        self.temperature = first_order(self.temperature, self.target, step,
                                       self.p.timeConstant)
        if commands:                     # the last command of the tick wins
            self.target = commands[-1]
        self.paint_link(self.color())
        self.power('thermal_display', self.p.powerPerKelvin
                   * abs(self.temperature - self.p.neutralTemperature))
        self.last_value = temp = self.temperature
        self.emit('main', lambda: self.to_msg(temp, self.stamp()))

    def to_msg(self, value, stamp):
        m = self.Temperature()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.temperature = float(value)
        m.variance = 0.0
        return m

    def renderer_created(self, renderer):
        self.paint_link(self.color())

    def reset(self):
        Actuator.reset(self)
        self.temperature = self.target = self.p.neutralTemperature
        self._last_t = self.world.sim_time
