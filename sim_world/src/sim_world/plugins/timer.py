"""One update timer in sim time for every plugin (hector_gazebo_plugins' UpdateTimer).

``UpdateTimer(rate=10)`` fires at sim times offset, offset + 1/rate, ... A rate of 0 fires
every world step. ``set_rate`` applies at once: the next firing is one new period after the
last one (or now, when that is already past), not after the old period has run out.
``reset(now)`` restarts the schedule at ``now``.
"""
import math

__all__ = ['UpdateTimer']

EPS = 1e-9


class UpdateTimer(object):
    def __init__(self, rate=0.0, period=None, offset=0.0):
        if period is not None and period > 0:
            rate = 1.0 / period
        self.rate = float(rate)
        self.offset = float(offset)
        self.next_time = self.offset
        self.last_time = None
        self.last_dt = self.period       # sim time between the last two firings

    @property
    def period(self):
        return 1.0 / self.rate if self.rate > 0 else 0.0

    def due(self, t):
        """True when the timer fires at sim time t (then advances by whole periods, so the
        rate in sim time is exact)."""
        if self.rate <= 0:
            if t + EPS < self.offset:
                return False
            self._fired(t)
            return True
        if t + EPS < self.next_time:
            return False
        period = 1.0 / self.rate
        self.next_time += period
        if self.next_time <= t + EPS:      # far behind (a reset, a rate change, a pause)
            self.next_time = t + period
        self._fired(t)
        return True

    def _fired(self, t):
        self.last_dt = self.period if self.last_time is None else max(0.0, t - self.last_time)
        self.last_time = t

    def set_rate(self, rate, now):
        """New rate in Hz (0: every step), effective immediately."""
        rate = float(rate)
        if not (math.isfinite(rate) and rate >= 0):
            raise ValueError('rate must be a number >= 0 Hz, got %r' % rate)
        self.rate = rate
        if rate <= 0:
            self.next_time = now
            return
        base = self.last_time if self.last_time is not None else now
        self.next_time = max(base + 1.0 / rate, now)

    def reset(self, now=0.0):
        self.next_time = now + self.offset
        self.last_time = None
        self.last_dt = self.period

    def next_due(self, now):
        """Sim time of the next firing (now for rate 0)."""
        if self.rate <= 0:
            return max(now, self.offset)
        return self.next_time
