"""The vibration motor of thesis section 3.4.3: ``libgazebo_ros_vibration.so``.

The thesis: "a little force can be applied on the simulated devices ... for not
accelerating the body in a single direction, one could choose a diagonal force direction
that alternates every few milliseconds". Commanded on ``vibrate``
(mobile_device_sim/Vibration) like Android's ``VibrationEffect``: segment i lasts
``timings[i]`` s at ``amplitudes[i]`` (0..1; a one-shot is one timing and one amplitude),
``repeat`` -1 plays it once, else repeats from that index until the next command (an empty
command stops the motor).

The force: ``peakForce`` N (default 0.5 N, about 3.9 m/s^2 on the 129 g phone) x the
amplitude along ``direction`` (in the frame of ``bodyName``; default (1, 1, 0): diagonal
across the phone's plane), a square wave of ``period`` s (default 7 ms, 143 Hz, a phone
ERM motor's range) in the phase of cos: + for a quarter period, - for a half, + ...; its
integral over each half period is zero and the amplitude changes only at half-period
boundaries, so the body's velocity returns to zero every half period: zero mean force, no
drift, and the vibration stops without leaving the phone moving. The force of each physics
step is the square wave's mean over that step (exact impulses whatever the step size), queued
at every tick (``updateRate``, default 100 Hz) for the next two tick periods through the
engine's ``apply_wrench`` (the engines apply it step by step; the world does not run a
plugin pass every step).

Why 7 ms and not 5: the phone's IMU differentiates its velocity over its 10 ms period; a
5 ms square wave holds exactly two periods in that window, cancels and would be invisible to
the accelerometer. With 7 ms the 10 ms window holds a partial period and the accelerometer
sees up to 0.3 x the force: the variance rises while the motor runs.

Whether the motor runs now: ``vibration/state`` (std_msgs/Float32, latched, published on
every change: the amplitude 0..1 it runs at, 0 when it stands still; ``stateTopicName``),
what a command on ``vibrate`` only asks for. The battery sees ``power`` W x amplitude while
it runs. Bad input (timings and amplitudes of
different length, a negative or NaN timing, an amplitude outside 0..1, a bad repeat index):
one error line naming it; the motor keeps doing what it did.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.device import Actuator

__all__ = ['Vibration', 'Waveform', 'square_impulse', 'step_forces']


class Waveform(object):
    """VibrationEffect timings/amplitudes/repeat: ``amplitude(dt)`` dt s after the start."""

    def __init__(self, timings=(), amplitudes=(), repeat=-1):
        timings = [float(x) for x in timings]
        amplitudes = [float(x) for x in amplitudes]
        if len(timings) != len(amplitudes):
            raise ValueError('timings (%d) and amplitudes (%d) must be lists of the same '
                             'length' % (len(timings), len(amplitudes)))
        for t in timings:
            if not (math.isfinite(t) and t >= 0):
                raise ValueError('timings must be >= 0 s, got %r' % t)
        for a in amplitudes:
            if not (math.isfinite(a) and 0.0 <= a <= 1.0):
                raise ValueError('amplitudes must be in 0..1, got %r' % a)
        repeat = int(repeat)
        if not (repeat == -1 or 0 <= repeat < len(timings)):
            raise ValueError('repeat must be -1 or an index of timings (0..%d), got %d'
                             % (len(timings) - 1, repeat))
        if repeat >= 0 and sum(timings[repeat:]) <= 0:
            raise ValueError('the repeated part of the waveform must last > 0 s')
        self.timings, self.amplitudes, self.repeat = timings, amplitudes, repeat
        self.ends = np.cumsum(timings) if timings else np.zeros(0)
        self.total = float(self.ends[-1]) if timings else 0.0

    @property
    def silent(self):
        return not any(a > 0 and t > 0 for t, a in zip(self.timings, self.amplitudes))

    def amplitude(self, dt):
        if not self.timings or dt < 0:
            return 0.0
        if dt >= self.total:
            if self.repeat < 0:
                return 0.0
            start = self.total - sum(self.timings[self.repeat:])
            dt = start + math.fmod(dt - start, self.total - start)
        i = int(np.searchsorted(self.ends, dt, side='right'))
        return self.amplitudes[min(i, len(self.amplitudes) - 1)]

    def finished(self, dt):
        return self.repeat < 0 and dt >= self.total


def _primitive(u, period, amplitude):
    """G(u) = integral from 0 to u of amplitude(k) x the cos-phase square wave: every whole
    half period integrates to zero, so G is the triangle of the current half period k
    (sign + for even k) scaled by its amplitude."""
    u = np.atleast_1d(np.asarray(u, float))
    half = period / 2.0
    k = np.floor(u / half + 1e-9)
    x = u - k * half
    tri = np.where(x <= period / 4.0, x, half - x)
    sign = np.where(k % 2 == 0, 1.0, -1.0)
    ks, inv = np.unique(k, return_inverse=True)
    amp = np.array([amplitude(kk * half) for kk in ks])[inv]
    return amp * sign * tri


def square_impulse(u0, u1, period, amplitude):
    """Integral over [u0, u1] (s after the start) of amplitude(k) x the cos-phase square
    wave of ``period`` (+ for the first quarter, - for the next half, + ...); the amplitude
    of half period k is ``amplitude(k * period / 2)``."""
    g = _primitive([u0, u1], period, amplitude)
    return float(g[1] - g[0])


def step_forces(u0, n, dt, period, amplitude):
    """Mean square-wave value (times the amplitude) over each of n steps of dt from u0."""
    g = _primitive(u0 + dt * np.arange(n + 1), period, amplitude)
    return np.diff(g) / dt


@register('libgazebo_ros_vibration.so', 'libvibration.so')
class Vibration(Actuator):
    DEFAULT_TOPIC = 'vibrate'
    DEFAULT_RATE = 100.0
    PARAMS = [
        Param('peakForce', float, 0.5, aliases=('peak_force',), unit='N', check='>=0',
              doc='force at amplitude 1'),
        Param('period', float, 0.007, unit='s', check='>0',
              doc='period of the alternating force (143 Hz)'),
        Param('direction', 'vec3', (1.0, 1.0, 0.0),
              check=lambda v: bool(np.linalg.norm(v) > 0), check_text='a non-zero vector',
              doc='force direction in the body frame (diagonal across the phone)'),
        Param('power', float, 0.1, unit='W', check='>=0', doc='draw at amplitude 1'),
        Param('stateTopicName', str, 'vibration/state', aliases=('state_topic',),
              doc='std_msgs/Float32 of the amplitude the motor runs at now (0: still), '
                  'latched, on change'),
    ]

    def setup(self):
        p = self.p
        self.dir = np.asarray(p.direction, float) / np.linalg.norm(p.direction)
        self.wave = None
        self.t0 = 0.0
        self.key = ('vibration', self.spec.name or self.spec.filename)
        self.amplitude_now = 0.0
        self.queued = None            # the last rows queued (world frame, N), for tests
        from std_msgs.msg import Float32
        self.Float32 = Float32
        self.output('state', Float32, topic=p.stateTopicName, latch=True, noisy=False,
                    on_change=True)
        self._show(0.0)
        from mobile_device_sim.msg import Vibration as VibrationMsg
        self.subscribe(self.topic, VibrationMsg,
                       lambda m: self.vibrate(m.timings, m.amplitudes, m.repeat))

    # -- commands ----------------------------------------------------------------------------
    def vibrate(self, timings, amplitudes, repeat=-1):
        """A new effect (from any thread), started at the next tick. False (and one error
        line) for bad input: the motor keeps its effect."""
        try:
            wave = Waveform(timings, amplitudes, repeat)
        except (ValueError, TypeError) as e:
            self.log_error('%s: vibrate: %s; the motor keeps its last state' % (self.label, e))
            return False
        self.queue(wave)
        return True

    def one_shot(self, duration, amplitude=1.0):
        return self.vibrate([duration], [amplitude], -1)

    def cancel(self):
        return self.vibrate([], [], -1)

    def _amp(self, u):
        return self.wave.amplitude(u) if self.wave is not None else 0.0

    # -- schedule -------------------------------------------------------------------------------
    def act(self, sim_time, commands):
        wave = commands[-1] if commands else None      # the last command of the tick wins
        if wave is not None:
            self.wave, self.t0 = (None if wave.silent else wave), sim_time
            if self.wave is None:
                self._stop()
                return
        if self.wave is None:
            return
        u = sim_time - self.t0
        # amplitudes are sampled at half-period boundaries: the effect is over once the
        # half period after its end has passed
        half = self.p.period / 2.0
        if self.wave.finished(u) and self.wave.finished(math.floor(u / half + 1e-9) * half):
            self.wave = None
            self._stop()
            return
        dt = self.world.step_size
        rate = self.timer.rate
        n = int(math.ceil((2.0 / rate if rate > 0 else 2 * dt) / dt)) + 1
        s = step_forces(u, n, dt, self.p.period, self._amp)
        body = self.state(sim_time).body_pose
        f_world = body.rotate(self.dir * self.p.peakForce)
        rows = s[:, None] * f_world[None, :]
        self.queued = rows
        self.world.apply_wrench(self.model.name, rows, key=self.key)
        a = self._amp(math.floor(u / half + 1e-9) * half)
        self.amplitude_now = a
        self.last_value = a
        self.power('vibration', self.p.power * a)
        self._show(a)

    def _show(self, a):
        """``vibration/state``: the amplitude now (published when it changes)."""
        self.emit('state', self.Float32(data=float(a)))

    def _stop(self):
        self.amplitude_now = 0.0
        self.last_value = 0.0
        self.queued = None
        self.world.clear_wrench(self.model.name, self.key)
        self.power('vibration', 0.0)
        self._show(0.0)

    def reset(self):
        Actuator.reset(self)
        self.wave = None
        self._stop()

    def shutdown(self):
        self.world.clear_wrench(self.model.name, self.key)
        Actuator.shutdown(self)
