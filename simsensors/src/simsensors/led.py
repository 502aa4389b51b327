"""Notification LEDs of thesis section 3.4.1: ``libgazebo_ros_led.so``.

One plugin = one LED on one link (``bodyName``; default the phone's ``mobile_led`` link
beside the earpiece, else the ``<gazebo reference>`` link or the model root). Commanded on
``led`` (mobile_device_sim/LedCommand) like Android's ``Notification.setLights(argb,
onMs, offMs)``: lit ``on_ms``, dark ``off_ms``, repeating on the sim-time clock from the
tick the command is taken (the first phase is lit); ``off_ms`` 0 = steady; ``argb`` 0 (no
colour) or ``on_ms`` 0 = off. ``color`` is an alternative to ``argb``: a name of Android's
``Color.parseColor`` ("red", "green", "blue", "yellow", "cyan", "magenta", "white",
"gray", ...) or ``#rrggbb`` / ``#aarrggbb`` (alpha ignored, as by phone LEDs).

While lit, the renderer draws the link's visuals unlit (emissive) in the LED's colour, so
every camera in the world sees the colour whatever the lighting; while dark, the link shows
its material. The battery sees ``power`` W while lit (``Sensor.power('led', W)``).
``led/state`` (std_msgs/ColorRGBA, latched, published on every change: r, g, b 0..1 and
a = 1 while lit; all 0 while dark) tells what the LED shows now. Blink edges fall on the
plugin's ticks (``updateRate``, default 100 Hz: 10 ms resolution).

Bad input (unknown colour name, negative on_ms/off_ms): one error line naming it; the LED
keeps its last good state.
"""
import math
from collections import deque

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.device import Actuator

__all__ = ['Led', 'LedPattern', 'parse_color', 'argb_rgb', 'ANDROID_COLORS']

#: the names Android's Color.parseColor knows (0xRRGGBB)
ANDROID_COLORS = {
    'black': 0x000000, 'darkgray': 0x444444, 'gray': 0x888888, 'lightgray': 0xcccccc,
    'white': 0xffffff, 'red': 0xff0000, 'green': 0x00ff00, 'blue': 0x0000ff,
    'yellow': 0xffff00, 'cyan': 0x00ffff, 'magenta': 0xff00ff, 'aqua': 0x00ffff,
    'fuchsia': 0xff00ff, 'darkgrey': 0x444444, 'grey': 0x888888, 'lightgrey': 0xcccccc,
    'lime': 0x00ff00, 'maroon': 0x800000, 'navy': 0x000080, 'olive': 0x808000,
    'purple': 0x800080, 'silver': 0xc0c0c0, 'teal': 0x008080,
}


def argb_rgb(argb):
    """(r, g, b) 0..1 of 0xAARRGGBB (alpha ignored)."""
    argb = int(argb) & 0xffffffff
    return ((argb >> 16) & 0xff) / 255.0, ((argb >> 8) & 0xff) / 255.0, (argb & 0xff) / 255.0


def parse_color(text):
    """0xRRGGBB of a colour name (Android's Color.parseColor names) or '#rrggbb' /
    '#aarrggbb'; raises ValueError naming the text."""
    t = text.strip().lower()
    if t.startswith('#'):
        h = t[1:]
        if len(h) in (6, 8) and all(c in '0123456789abcdef' for c in h):
            return int(h[-6:], 16)
        raise ValueError('colour %r is not #rrggbb or #aarrggbb' % text)
    if t in ANDROID_COLORS:
        return ANDROID_COLORS[t]
    raise ValueError('unknown colour %r (a name like red, green, blue, yellow, white, or '
                     '#rrggbb)' % text)


class LedPattern(object):
    """What the LED does: colour (r, g, b 0..1 or None = off), on and off times (s)."""

    def __init__(self, rgb=None, on=0.0, off=0.0):
        self.rgb = None if rgb is None or not any(rgb) or on <= 0 else tuple(rgb)
        self.on, self.off = float(on), float(off)

    @classmethod
    def from_command(cls, argb=0, on_ms=0, off_ms=0, color=''):
        """The pattern of a LedCommand's fields; ValueError naming what is wrong."""
        for name, v in (('on_ms', on_ms), ('off_ms', off_ms)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError('%s must be >= 0 ms, got %r' % (name, v))
        rgb = argb_rgb(parse_color(color) if color and color.strip() else argb)
        return cls(rgb, on_ms / 1000.0, off_ms / 1000.0)

    def color_at(self, dt):
        """Colour shown ``dt`` s after the pattern started (None = dark)."""
        if self.rgb is None:
            return None
        if self.off <= 0:
            return self.rgb
        phase = math.fmod(max(0.0, dt) + 1e-9, self.on + self.off)
        return self.rgb if phase < self.on else None


@register('libgazebo_ros_led.so', 'libled.so')
class Led(Actuator):
    DEFAULT_TOPIC = 'led'
    DEFAULT_RATE = 100.0
    PARAMS = [
        Param('power', float, 0.02, unit='W', check='>=0', doc='draw while lit'),
        Param('stateTopicName', str, 'led/state', aliases=('state_topic',),
              doc='std_msgs/ColorRGBA of what the LED shows, latched, on change'),
        Param('color', str, '', doc='initial colour (name or #rrggbb; empty: off)'),
        Param('onMs', float, 0.0, aliases=('on_ms',), unit='ms', check='>=0'),
        Param('offMs', float, 0.0, aliases=('off_ms',), unit='ms', check='>=0'),
    ]

    def setup(self):
        from std_msgs.msg import ColorRGBA
        self.ColorRGBA = ColorRGBA
        p = self.p
        if p.bodyName is None and self.spec.link is None and 'mobile_led' in self.model.links:
            self.body = 'mobile_led'
        self.pattern = LedPattern()
        self.t0 = self.world.sim_time
        self.shown = None
        self.transitions = deque(maxlen=1000)       # (t, rgb or None)
        self.state_pub = self.output('state', ColorRGBA, topic=p.stateTopicName, latch=True)
        if p.color:
            self.command(color=p.color, on_ms=p.onMs or 1, off_ms=p.offMs)
        from mobile_device_sim.msg import LedCommand
        self.subscribe(self.topic, LedCommand, self._on_msg)

    # -- commands ------------------------------------------------------------------------------
    def _on_msg(self, m):
        self.command(m.argb, m.on_ms, m.off_ms, m.color)

    def command(self, argb=0, on_ms=0, off_ms=0, color=''):
        """A new pattern (from any thread), taken at the next tick. False (and one error
        line) for bad input: the LED keeps its pattern."""
        try:
            pat = LedPattern.from_command(argb, on_ms, off_ms, color)
        except ValueError as e:
            self.log_error('%s: led command: %s; the LED keeps its last state'
                           % (self.label, e))
            return False
        self.queue(pat)
        return True

    # -- schedule ------------------------------------------------------------------------------
    def act(self, sim_time, commands):
        if commands:                     # the last command of the tick wins
            self.pattern, self.t0 = commands[-1], sim_time
        rgb = self.pattern.color_at(sim_time - self.t0)
        self.last_value = rgb
        if rgb != self.shown or not self.transitions:
            self._show(rgb, sim_time)

    def _show(self, rgb, t):
        self.shown = rgb
        self.transitions.append((t, rgb))
        self.paint_link(rgb)
        self.power('led', self.p.power if rgb is not None else 0.0)
        m = self.ColorRGBA()
        if rgb is not None:
            m.r, m.g, m.b, m.a = rgb[0], rgb[1], rgb[2], 1.0
        self.last_msg = m
        self.emit('state', m)

    def renderer_created(self, renderer):
        self.paint_link(self.shown)

    def reset(self):
        Actuator.reset(self)
        self.t0 = self.world.sim_time
