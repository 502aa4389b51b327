"""One line per distinct cause, the one "log once" of the repository: a bad command
repeated 100 times, a broken GL context at every frame, an unimplemented plugin in every
model, a console refusing the same command: each is said once.

``once = LogOnce(logger)`` (anything with logging's ``error``/``warning``/``info``
methods: a ``logging.Logger``, the world's rospy-backed logger) or ``LogOnce(say=f)`` (a
callable taking the finished line: ``rospy.logerr``, ``list.append``). ``once.error(text)``
logs ``text`` the first time only (key: the text, or ``key=``); ``once.warning``/
``once.info`` alike; ``once(text)`` is ``once.error(text)``; each returns True when it
logged (``logger=``: another logger for this line).

``until_changed=True``: a problem is said again once a different one (or ``ok()``: it went
away) came in between, for a stream (frames, clouds, joystick messages) whose problem may
come back. ``reset()``/``ok()`` forget what was said.
"""
import logging

__all__ = ['LogOnce']

_METHOD = {logging.ERROR: 'error', logging.WARNING: 'warning', logging.INFO: 'info'}


class LogOnce(object):
    def __init__(self, logger=None, say=None, until_changed=False):
        self.logger = logger or logging.getLogger('sim_world')
        self.say = say
        self.until_changed = until_changed
        self.seen = set()
        self.last = None

    def log(self, level, text, key=None, logger=None):
        k = text if key is None else key
        if self.until_changed:
            if k == self.last:
                return False
            self.last = k
        elif k in self.seen:
            return False
        self.seen.add(k)
        if self.say is not None and logger is None:
            self.say(text)
        else:
            getattr(logger or self.logger, _METHOD[level])('%s', text)
        return True

    def __call__(self, text, key=None):
        return self.log(logging.ERROR, text, key)

    def error(self, text, key=None, logger=None):
        return self.log(logging.ERROR, text, key, logger)

    def warning(self, text, key=None, logger=None):
        return self.log(logging.WARNING, text, key, logger)

    def info(self, text, key=None, logger=None):
        return self.log(logging.INFO, text, key, logger)

    def reset(self):
        """Forget everything said: the next problem is said again."""
        self.seen.clear()
        self.last = None

    ok = reset
    problem = __call__
