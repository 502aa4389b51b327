"""Expectation semantics, pure (no ROS): feed (sim time, message) pairs, get a verdict.

Modes (each over a window [start, end] of sim time, inclusive):
  eventually  passes at the first message whose value satisfies the predicate;
              fails at the window's end otherwise.
  always      fails at the first message that does not satisfy it; passes at the end if at
              least one message came (no message at all is a failure: nothing was checked).
  never       fails at the first message that satisfies it; passes at the end.
  count       the number of messages in the window satisfies the predicate (min/max/equals..).
  rate        messages per second of sim time in the window ((n-1) / (t_last - t_first))
              satisfies the predicate.
Predicates: equals (with tol for numbers), not_equals, near + tol, gt, ge, lt, le,
between [lo, hi], min/max (like ge/le), contains (strings, lists); on images
(sensor_msgs/Image): barcode (a QR/barcode with this data decodes), region [x, y, w, h] with
colour [r, g, b] (+ tol, mean colour per channel), region with led on/off (mean brightness
above/below threshold, default 128). Several keys in one predicate must all hold.
Vectors (geometry_msgs Vector3/Point/Quaternion, lists) compare element-wise with tol.
"""
import math
import re

__all__ = ['Predicate', 'Expectation', 'Verdict', 'get_field', 'FieldError', 'to_value',
           'describe']


class FieldError(Exception):
    pass


_TOKEN = re.compile(r'([A-Za-z_][A-Za-z0-9_]*)|\[(-?\d+|[A-Za-z_][A-Za-z0-9_/:-]*)\]')
#: the arrays that name the elements of their sibling arrays (sensor_msgs/JointState's name,
#: gazebo's ModelStates/LinkStates name, a trajectory's joint_names)
NAME_ARRAYS = ('name', 'joint_names')


def _by_name(holder, array, label, done):
    """The index of ``label`` in the names array beside ``array`` in ``holder``."""
    for key in NAME_ARRAYS:
        names = holder.get(key) if isinstance(holder, dict) else getattr(holder, key, None)
        if isinstance(names, (list, tuple)) and key != array:
            if label not in names:
                raise FieldError('%s: no %r in %s (%s)' % (
                    done, label, key, ', '.join(map(str, names)) or 'empty'))
            return list(names).index(label)
    raise FieldError('%s[%s]: %s has no name array (%s) to look %r up in'
                     % (done, label, done.rsplit('.', 1)[0] if '.' in done else 'the message',
                        ' or '.join(NAME_ARRAYS), label))


def get_field(msg, path):
    """Value at a dotted path with indexes ('linear_acceleration.z', 'values[3].value');
    '' or None gives the message itself. An index may be a name, looked up in the names
    array beside that array (``position[joint2]`` on a sensor_msgs/JointState: the
    position of the joint named joint2 in ``name``, wherever it is in this message;
    ``pose[mobile_device].position.z`` on /gazebo/model_states). FieldError names the
    missing part."""
    if not path:
        return msg
    v = msg
    holder = None
    pos = 0
    done = ''
    for part in path.split('.'):
        toks = _TOKEN.findall(part)
        if not toks or ''.join(n or '[%s]' % i for n, i in toks) != part:
            raise FieldError('bad field path %r (expected names with [index] or [name], '
                             'joined by dots)' % path)
        last_name = None
        for name, idx in toks:
            if name:
                holder, last_name = v, name
                if isinstance(v, dict):
                    if name not in v:
                        raise FieldError('%s has no field %r' % (done or 'the message', name))
                    v = v[name]
                else:
                    slots = getattr(v, '__slots__', None)
                    if not hasattr(v, name) or (slots is not None and name not in slots
                                                and name not in ('secs', 'nsecs')):
                        fields = ', '.join(slots) if slots else ''
                        raise FieldError('%s has no field %r%s' % (
                            done or 'the message', name,
                            ' (fields: %s)' % fields if fields else ''))
                    v = getattr(v, name)
                done = done + ('.' if done else '') + name
            else:
                if not re.match(r'-?\d+$', idx):
                    if last_name is None:
                        raise FieldError('%s[%s]: a name index goes after an array field'
                                         % (done or 'the message', idx))
                    i = _by_name(holder, last_name, idx, done)
                    last_name = None
                else:
                    i = int(idx)
                try:
                    v = v[i]
                except (IndexError, TypeError, KeyError):
                    raise FieldError('%s has no element [%s]' % (done or 'the message', idx))
                done += '[%s]' % idx
        pos += 1
    return v


def to_value(v):
    """Plain Python value of a field: numbers, strings, lists; Vector3-likes -> [x, y, z];
    rospy Time/Duration -> seconds."""
    if hasattr(v, 'to_sec') and hasattr(v, 'secs'):
        return v.to_sec()
    if hasattr(v, '__slots__') and all(hasattr(v, a) for a in ('x', 'y', 'z')):
        out = [v.x, v.y, v.z]
        if hasattr(v, 'w'):
            out.append(v.w)
        return out
    if isinstance(v, bytes):
        return list(v)
    if isinstance(v, tuple):
        return list(v)
    return v


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _close(a, b, tol):
    if _num(a) and _num(b):
        return abs(a - b) <= tol
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, tol) for x, y in zip(a, b))
    return a == b


def _fmt(v):
    if isinstance(v, float):
        return '%.6g' % v
    if isinstance(v, list):
        if len(v) > 8:
            return '[%s, ... (%d)]' % (', '.join(_fmt(x) for x in v[:4]), len(v))
        return '[%s]' % ', '.join(_fmt(x) for x in v)
    if isinstance(v, str):
        return repr(v if len(v) <= 60 else v[:57] + '...')
    return str(v)


class Predicate(object):
    """A condition on one value (see the module doc). ``test(value) -> bool``;
    ``describe()`` the expected text; ``measure(value)`` the actual text."""

    def __init__(self, spec):
        self.spec = dict(spec or {})
        self.tol = float(self.spec.get('tol', 0.0))
        self.is_image = any(k in self.spec for k in ('barcode', 'region'))

    def describe(self):
        s = self.spec
        parts = []
        if 'equals' in s:
            parts.append('== %s' % _fmt(s['equals']) + (' +- %s' % _fmt(self.tol)
                                                        if self.tol else ''))
        if 'near' in s:
            parts.append('%s +- %s' % (_fmt(s['near']), _fmt(self.tol)))
        if 'not_equals' in s:
            parts.append('!= %s' % _fmt(s['not_equals']))
        for k, op in (('gt', '>'), ('ge', '>='), ('lt', '<'), ('le', '<='), ('min', '>='),
                      ('max', '<=')):
            if k in s:
                parts.append('%s %s' % (op, _fmt(s[k])))
        if 'between' in s:
            parts.append('in [%s, %s]' % (_fmt(s['between'][0]), _fmt(s['between'][1])))
        if 'contains' in s:
            parts.append('contains %s' % _fmt(s['contains']))
        if 'barcode' in s:
            parts.append('barcode %s decoded' % _fmt(s['barcode']))
        if 'region' in s:
            reg = 'region %s' % _fmt(s['region'])
            c = s.get('colour', s.get('color'))
            if c is not None:
                parts.append('%s mean colour %s +- %s' % (reg, _fmt(c), _fmt(self.tol or 0)))
            if 'led' in s:
                parts.append('%s LED %s (brightness %s %s)' % (
                    reg, s['led'], '>=' if s['led'] == 'on' else '<',
                    _fmt(s.get('threshold', 128))))
        return ' and '.join(parts) or 'any value'

    # image measures ------------------------------------------------------------------------
    def _image(self, msg):
        from simvid.imageconv import image_to_rgb
        return image_to_rgb(msg)

    def _region_mean(self, rgb):
        import numpy as np
        x, y, w, h = (int(v) for v in self.spec['region'])
        roi = rgb[max(y, 0):y + h, max(x, 0):x + w]
        if roi.size == 0:
            raise FieldError('region %s lies outside the %dx%d image'
                             % (self.spec['region'], rgb.shape[1], rgb.shape[0]))
        return [float(v) for v in roi.reshape(-1, roi.shape[-1])[:, :3].mean(axis=0)]

    def image_facts(self, msg):
        """Measured facts of an image message: {'barcodes': [...], 'mean': [r, g, b]}."""
        facts = {}
        if 'barcode' in self.spec:
            from simvid import barcode
            try:
                found = barcode.decode(self._image(msg), 'rgb8')
                facts['barcodes'] = [d for _t, d in found]
                facts['barcode_texts'] = [barcode.format_barcode(t, d) for t, d in found]
            except Exception as e:  # noqa: BLE001 - zbar missing or bad image: report it
                raise FieldError('cannot decode barcodes: %s' % e)
        if 'region' in self.spec:
            facts['mean'] = self._region_mean(self._image(msg))
        return facts

    def test(self, value):
        s = self.spec
        if self.is_image:
            facts = value
            if 'barcode' in s and s['barcode'] not in facts.get('barcodes', []) + \
                    facts.get('barcode_texts', []):
                return False
            if 'region' in s:
                mean = facts['mean']
                c = s.get('colour', s.get('color'))
                if c is not None and not _close(mean, [float(x) for x in c], self.tol or 0):
                    return False
                if 'led' in s:
                    b = sum(mean) / 3.0
                    on = b >= float(s.get('threshold', 128))
                    if on != (s['led'] == 'on'):
                        return False
            return True
        v = to_value(value)
        if 'equals' in s and not _close(v, to_value(s['equals']), self.tol):
            return False
        if 'near' in s and not _close(v, to_value(s['near']), self.tol):
            return False
        if 'not_equals' in s and _close(v, to_value(s['not_equals']), self.tol):
            return False
        try:
            for k, ok in (('gt', lambda a, b: a > b), ('ge', lambda a, b: a >= b),
                          ('min', lambda a, b: a >= b), ('lt', lambda a, b: a < b),
                          ('le', lambda a, b: a <= b), ('max', lambda a, b: a <= b)):
                if k in s and not ok(v, s[k]):
                    return False
            if 'between' in s and not (s['between'][0] <= v <= s['between'][1]):
                return False
        except TypeError:
            return False
        if 'contains' in s:
            try:
                if s['contains'] not in v:
                    return False
            except TypeError:
                return False
        return True

    def measure(self, value):
        if self.is_image:
            parts = []
            if 'barcodes' in value:
                parts.append('barcodes %s' % _fmt(list(value['barcodes'])))
            if 'mean' in value:
                parts.append('mean colour %s' % _fmt([round(x, 1) for x in value['mean']]))
            return ', '.join(parts)
        return _fmt(to_value(value))


class Verdict(object):
    def __init__(self, name, passed, expected, actual, t, error=False):
        self.name, self.passed, self.expected, self.actual, self.t = \
            name, passed, expected, actual, t
        self.error = error

    @property
    def status(self):
        return 'ERROR' if self.error else ('PASS' if self.passed else 'FAIL')

    def line(self):
        return '%s %s: expected %s; actual %s; at t=%s' % (
            self.status, self.name, self.expected, self.actual,
            '%.3f s' % self.t if self.t is not None else '-')

    def __repr__(self):
        return '<Verdict %s>' % self.line()


def describe(spec):
    return Predicate(spec).describe()


class Expectation(object):
    """One expectation of a scenario. ``feed(t, msg)`` with sim time t (s) in the order of
    t; ``finish(t_end)`` closes it. ``verdict`` is set as soon as it is decided."""

    def __init__(self, spec, duration=math.inf):
        self.spec = spec
        self.name = spec.get('name', 'expectation')
        self.topic = spec.get('topic')
        self.field = spec.get('field')
        self.mode = next(m for m in ('eventually', 'always', 'never', 'count', 'rate')
                         if m in spec)
        self.pred = Predicate(spec[self.mode])
        w = spec.get('window')
        self.rel_window = tuple(w) if w else (0.0, duration)
        self.after = spec.get('after')
        self.offset = None if self.after else 0.0   # the trigger time of 'after'
        self.verdict = None
        self.n = 0
        self.t_first = self.t_last = None
        self.last_actual = None
        self.last_seen_any = None

    # window in absolute sim time (None until an 'after' event happened)
    @property
    def window(self):
        if self.offset is None:
            return None
        return (self.offset + self.rel_window[0], self.offset + self.rel_window[1])

    def start(self, t_event):
        """The 'after' event happened at t_event: the window is relative to it now."""
        if self.offset is None:
            self.offset = float(t_event)

    def begin(self, t0):
        """The scenario's sim time 0 is the world's ``t0`` (an attached world that has run
        before: not 0): a window without ``after`` is relative to it, as the timeline is."""
        if not self.after:
            self.offset = float(t0)

    def expected_text(self):
        where = '%s%s' % (self.topic, '.' + self.field if self.field else '')
        if self.window is not None:
            w = self.window
        else:
            w = self.rel_window
        win = '[%.3f, %.3f] s' % (w[0], w[1]) + (' after %s' % self.after if self.after
                                                 else '')
        if self.mode in ('count', 'rate'):
            what = 'messages' if self.mode == 'count' else 'Hz'
            return '%s of %s %s in %s' % (what, where, self.pred.describe(), win)
        return '%s %s %s in %s' % (self.mode, where, self.pred.describe(), win)

    def _decide(self, passed, actual, t):
        if self.verdict is None:
            self.verdict = Verdict(self.name, passed, self.expected_text(), actual, t)

    def error(self, text, t=None):
        if self.verdict is None:
            self.verdict = Verdict(self.name, False, self.expected_text(), text, t,
                                   error=True)

    def value_of(self, msg):
        if self.pred.is_image:
            return self.pred.image_facts(get_field(msg, self.field))
        return get_field(msg, self.field)

    def feed(self, t, msg):
        """One message at sim time t. FieldError -> the expectation is an error."""
        if self.verdict is not None:
            return
        w = self.window
        if w is None or t < w[0] - 1e-9 or t > w[1] + 1e-9:
            return
        if self.mode in ('count', 'rate'):
            if self.field:
                try:
                    get_field(msg, self.field)
                except FieldError as e:
                    self.error(str(e), t)
                    return
            self.n += 1
            if self.t_first is None:
                self.t_first = t
            self.t_last = t
            return
        try:
            value = self.value_of(msg)
        except FieldError as e:
            self.error(str(e), t)
            return
        ok = self.pred.test(value)
        actual = self.pred.measure(value)
        self.n += 1
        self.last_actual = actual
        self.t_last = t
        if self.mode == 'eventually' and ok:
            self._decide(True, actual, t)
        elif self.mode == 'always' and not ok:
            self._decide(False, actual, t)
        elif self.mode == 'never' and ok:
            self._decide(False, actual, t)

    def finish(self, t_end):
        """Close at sim time t_end (the scenario's end): decide what is still open."""
        if self.verdict is not None:
            return self.verdict
        w = self.window
        if w is None:
            self.error('the event %r never happened' % self.after, None)
            return self.verdict
        if t_end + 1e-9 < w[1]:
            self.error('the scenario ended at %.3f s, before the window closed' % t_end, t_end)
            return self.verdict
        if self.mode == 'count':
            self._decide(self.pred.test(self.n), '%d messages' % self.n, w[1])
        elif self.mode == 'rate':
            if self.n >= 2 and self.t_last > self.t_first:
                rate = (self.n - 1) / (self.t_last - self.t_first)
                self._decide(self.pred.test(rate), '%.4g Hz (%d messages)' % (rate, self.n),
                             w[1])
            else:
                self._decide(self.pred.test(0.0), '%d messages in the window, rate 0' % self.n,
                             w[1])
        elif self.n == 0:
            seen = ' (messages came only outside the window)' if self.last_seen_any else ''
            self._decide(self.mode == 'never', 'no message in the window%s' % seen, w[1])
        elif self.mode == 'eventually':
            self._decide(False, 'last %s (%d messages, none matched)'
                         % (self.last_actual, self.n), self.t_last)
        else:  # always / never held
            self._decide(True, 'last %s (%d messages)' % (self.last_actual, self.n),
                         self.t_last)
        return self.verdict

    def saw(self, t):
        self.last_seen_any = t
