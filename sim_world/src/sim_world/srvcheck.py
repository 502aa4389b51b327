"""Checks of the values a service request carries: the one place where every service of the
world (gazebo_api, world_services, /gazebo/reload_world) and of its plugins (Device.service)
checks numbers, durations, names and poses, and turns a refusal into an answer.

A check returns the value it accepts (a float, a Pose, ...) or raises ``BadRequest``, whose
message names the field and the value as it came (repr: nan, inf, -1e+300, 'no_such')::

    until = srvcheck.sim_time(req.until, 'until')
    # BadRequest: until must be a finite number in [0, 1e+09] s, got nan

``answers(Response, 'StepWorld')`` wraps a handler. A ``BadRequest`` it raises becomes the
answer ``success: false``, ``status_message`` 'StepWorld: <message>' (one line whatever the
request held), every other field at its default or as ``fill`` gives it, and exactly one log
line. Any other exception is answered the same way as 'StepWorld: internal error: <type>:
<message> (<file>:<line>)': a bug, but the node keeps serving and rospy writes no traceback
(tests look for the words 'internal error'). A response type without a ``success`` field
(std_srvs/Empty) is answered empty after the log line.

The bounds are far beyond any phone, room or scenario, and below where the physics engines
or the message types break (ODE aborts the process on a body spinning at 1e300 rad/s; a
genpy Time holds 4.29e9 s; a step_world to 1e300 s would hold every other service call of
the world forever): positions as ``sim_world.model.MAX_POSITION``.
"""
import functools
import math
import os

from .model import MAX_POSITION
from .spawn import one_line

__all__ = ['BadRequest', 'MAX_TIME', 'MAX_SPEED', 'MAX_SPIN', 'MAX_POSITION', 'MAX_SCALE',
           'MAX_EFFORT',
           'number', 'duration', 'sim_time', 'name', 'ros_namespace', 'choice', 'vector', 'pose', 'twist',
           'answers', 'refusal', 'one_line']

MAX_TIME = 1e9       # s: sim times and durations (31.7 years)
MAX_SPEED = 1e4      # m/s: a model's linear speed (each component)
MAX_SPIN = 1e4       # rad/s: a model's angular speed (each component)
MAX_SCALE = 1e6      # multipliers (a noise fault's sigma factor)
MAX_EFFORT = 1e6     # N or N m: an effort applied to a joint


class BadRequest(ValueError):
    """A request a service refuses: the message names the field and the bad value."""


def _fmt(v):
    return '%g' % v


def number(value, what, lo=None, hi=None, unit='', lo_open=False):
    """``value`` as a finite float within [lo, hi] (``lo_open``: (lo, hi]); BadRequest
    naming ``what`` and the value otherwise."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float('nan')
    ok = math.isfinite(v) and (lo is None or (v > lo if lo_open else v >= lo)) and \
        (hi is None or v <= hi)
    if not ok:
        if lo is None and hi is None:
            rng = ''
        elif hi is None:
            rng = ' %s %s' % ('>' if lo_open else '>=', _fmt(lo))
        elif lo is None:
            rng = ' <= %s' % _fmt(hi)
        else:
            rng = ' in %s%s, %s]' % ('(' if lo_open else '[', _fmt(lo), _fmt(hi))
        raise BadRequest('%s must be a finite number%s%s, got %r'
                         % (what, rng, ' ' + unit if unit else '', value))
    return v


def duration(value, what='duration'):
    """A duration in (0, MAX_TIME] s."""
    return number(value, what, 0.0, MAX_TIME, 's', lo_open=True)


def sim_time(value, what='time'):
    """A sim time in [0, MAX_TIME] s."""
    return number(value, what, 0.0, MAX_TIME, 's')


def name(value, what, known=None, kind=None):
    """A non-empty name; with ``known`` (a container) one of them: BadRequest 'no <kind>
    named 'x' (known: a, b)' otherwise."""
    if not isinstance(value, str) or not value:
        raise BadRequest('%s must be a name, got %r' % (what, value))
    if known is not None and value not in known:
        listed = sorted(known)
        more = ', ...' if len(listed) > 20 else ''
        raise BadRequest('no %s named %r (known: %s%s)'
                         % (kind or what, value, ', '.join(listed[:20]) or 'none', more))
    return value


def ros_namespace(value, what='robot_namespace'):
    """A namespace a plugin's topics and services can live in: empty (global) or a ROS
    name of letters, digits, _ and single slashes ('bad name!' or '~x' registers nothing
    with the master: every topic of the model would fail). Returned as given."""
    import rosgraph.names
    ns = (value or '').strip('/')
    if ns and not rosgraph.names.is_legal_name('/' + ns):
        raise BadRequest('%s must be a ROS name (letters, digits, _ and single /), got %r'
                         % (what, value))
    return value


def choice(value, what, choices):
    """One of ``choices`` (texts or numbers, e.g. an enum's values)."""
    if value not in choices:
        raise BadRequest('%s must be one of %s, got %r'
                         % (what, ', '.join(str(c) for c in choices), value))
    return value


def vector(values, what, limit, unit=''):
    """Three finite numbers each within +-``limit`` (a list of floats)."""
    vals = list(values)
    try:
        floats = [float(v) for v in vals]
    except (TypeError, ValueError):
        floats = [float('nan')]
    if len(floats) != 3 or not all(math.isfinite(v) and abs(v) <= limit for v in floats):
        raise BadRequest('%s must be three finite numbers within +-%s%s, got %r'
                         % (what, _fmt(limit), ' ' + unit if unit else '', vals))
    return floats


def pose(msg, what='pose'):
    """A sim_world Pose from a geometry_msgs/Pose: a finite position within MAX_POSITION m
    of the origin and a finite quaternion that can be normalised."""
    from .transforms import InvalidPose, Pose
    p, o = msg.position, msg.orientation
    xyz = [p.x, p.y, p.z]
    vector(xyz, what + ' position', MAX_POSITION, 'm')
    q = [o.x, o.y, o.z, o.w]
    try:
        return Pose(xyz, q)
    except InvalidPose as e:
        raise BadRequest('%s: %s' % (what, e))


def twist(msg, what='twist'):
    """(linear, angular) of a geometry_msgs/Twist, within MAX_SPEED m/s and MAX_SPIN
    rad/s per component."""
    lin = vector([msg.linear.x, msg.linear.y, msg.linear.z], what + ' linear', MAX_SPEED,
                 'm/s')
    ang = vector([msg.angular.x, msg.angular.y, msg.angular.z], what + ' angular', MAX_SPIN,
                 'rad/s')
    return lin, ang


def refusal(response, text, **fields):
    """An instance of ``response`` answering ``success: false`` with ``text`` (and
    ``fields``); an empty one for a type without a success field."""
    res = response()
    slots = getattr(response, '__slots__', ())
    if 'success' in slots:
        res.success = False
        if 'status_message' in slots:
            res.status_message = text
    for k, v in fields.items():
        setattr(res, k, v)
    return res


def _where(exc):
    """'file.py:line' of the innermost frame of ``exc``'s traceback."""
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    if tb is None:
        return '?'
    return '%s:%d' % (os.path.basename(tb.tb_frame.f_code.co_filename), tb.tb_lineno)


def _rospy_log(level):
    def log(text):
        import rospy
        getattr(rospy, 'log' + level)(text)
    return log


def answers(response, label, log='err', fill=None):
    """Decorator of a service handler: BadRequest (and any other exception) answered as
    ``success: false`` with '<label>: <message>' and logged once. ``log``: 'warn', 'err' (the
    rospy level) or a callable taking the line; ``fill(*args)``: the other fields of a
    refusal (e.g. step_world's sim_time), given the handler's arguments but the request."""
    logger = _rospy_log(log) if isinstance(log, str) else log

    def wrap(handler):
        @functools.wraps(handler)
        def handle(*args):
            try:
                return handler(*args)
            except BadRequest as e:
                text = '%s: %s' % (label, e)
            except Exception as e:  # noqa: BLE001 - a bug: one line, the node keeps serving
                text = '%s: internal error: %s: %s (%s)' % (label, type(e).__name__, e,
                                                            _where(e))
            text = one_line(text)
            try:
                extra = fill(*args[:-1]) if fill is not None else {}
            except Exception:  # noqa: BLE001 - the refusal goes out without them
                extra = {}
            logger(text)
            return refusal(response, text, **extra)
        handle.srvcheck_label = label
        return handle
    return wrap

