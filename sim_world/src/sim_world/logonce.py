"""One error line per distinct cause: a bad command repeated 100 times, a missing ray caster
asked at every sample, an unimplemented plugin in every model: each is said once.

``once = LogOnce(logger)``; ``once.error(text)`` logs ``text`` the first time only (key:
the text, or ``key=``); ``once.warning``/``once.info`` alike; each returns True when it
logged (``logger=`` another logger for this line). ``once.forget(key)`` lets a cause be said again (it went away and came back).
"""
import logging

__all__ = ['LogOnce']


class LogOnce(object):
    def __init__(self, logger=None):
        self.logger = logger or logging.getLogger('sim_world')
        self.seen = set()

    def log(self, level, text, key=None, logger=None):
        k = text if key is None else key
        if k in self.seen:
            return False
        self.seen.add(k)
        (logger or self.logger).log(level, '%s', text)
        return True

    def error(self, text, key=None, logger=None):
        return self.log(logging.ERROR, text, key, logger)

    def warning(self, text, key=None, logger=None):
        return self.log(logging.WARNING, text, key, logger)

    def info(self, text, key=None, logger=None):
        return self.log(logging.INFO, text, key, logger)

    def forget(self, key):
        self.seen.discard(key)
