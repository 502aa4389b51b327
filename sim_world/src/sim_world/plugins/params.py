"""Plugin parameters declared once, parsed in one place, with one error wording.

A plugin lists its parameters as ``Param`` rows::

    PARAMS = [
        Param('updateRate', float, 10.0, aliases=('update_rate',), unit='Hz', check='>=0'),
        Param('direction', ('omni', '+x', '-x', '+z', '-z'), 'omni'),
        Param('xyzOffsets', 'vec3', (0, 0, 0), unit='m'),
    ]

``parse_params(spec, rows, label, log)`` reads each from the plugin element (then the enclosing
sensor element, then SDF paths), converts and checks it. A bad value is reported as one line::

    plugin libgazebo_ros_gps.so of model mobile_device: updateRate must be a number >= 0, got '-1'

and the parameter keeps its default, so the plugin (and the model) still load with every
other parameter. Rows are plain data: the README tables are generated from the same rows
(``describe``).
"""
import math

import numpy as np

from ..model import _local

__all__ = ['Param', 'ParamValues', 'parse_params', 'parse_all', 'convert', 'describe',
           'ParamError', 'find_text', 'find_texts', 'bad_value']


class ParamError(ValueError):
    """A value that does not fit its row: the message is the 'must be ...' part."""


class Param(object):
    """One parameter row.

    type: float | int | bool | str | 'vec3' | 'floats' | a tuple of allowed strings | a
    callable taking the text and returning the value (raising ValueError when it does not
    fit, with a message saying what it must be).
    check: None | '>=0' | '>0' | (lo, hi) inclusive | callable(value) -> bool (then
    ``check_text`` says what the value must be).
    path: further places to look, as tuples of local tag names below the sensor element
    (SDF nesting, e.g. ('camera', 'horizontal_fov')).
    """

    __slots__ = ('name', 'type', 'default', 'aliases', 'unit', 'check', 'doc', 'paths',
                 'check_text')

    def __init__(self, name, type=float, default=None, aliases=(), unit='', check=None,
                 doc='', paths=(), check_text=None):
        self.name = name
        self.type = type
        self.default = default
        self.aliases = tuple(aliases)
        self.unit = unit
        self.check = check
        self.doc = doc
        self.paths = tuple(tuple(p) for p in paths)
        self.check_text = check_text

    @property
    def names(self):
        return (self.name,) + self.aliases

    def what(self):
        """'a number >= 0', 'one of omni, +x', ... for the error line."""
        t = self.type
        if isinstance(t, tuple):
            base = 'one of ' + ', '.join(t)
        elif t is float:
            base = 'a number'
        elif t is int:
            base = 'a whole number'
        elif t is bool:
            base = 'true or false'
        elif t == 'vec3':
            base = 'three numbers'
        elif t == 'floats':
            base = 'a list of numbers'
        elif t is str:
            base = 'a text'
        else:
            base = getattr(t, 'what', 'a valid value')
        c = self.check
        if self.check_text:
            return '%s %s' % (base, self.check_text)
        if c == '>=0':
            return base + ' >= 0'
        if c == '>0':
            return base + ' > 0'
        if isinstance(c, tuple):
            return '%s in [%g, %g]' % (base, c[0], c[1])
        return base

    def __repr__(self):
        return 'Param(%s)' % self.name


def _finite(v):
    return np.all(np.isfinite(np.asarray(v, float)))


def convert(row, text):
    """The value of ``text`` for ``row``; raises ParamError (message: what it must be)."""
    t = row.type
    s = text.strip()
    try:
        if isinstance(t, tuple):
            if s not in t:
                raise ValueError
            v = s
        elif t is float:
            v = float(s)
            if not math.isfinite(v):
                raise ValueError
        elif t is int:
            f = float(s)
            if not math.isfinite(f) or f != int(f):
                raise ValueError
            v = int(f)
        elif t is bool:
            low = s.lower()
            if low in ('1', 'true', 'yes', 'on'):
                v = True
            elif low in ('0', 'false', 'no', 'off'):
                v = False
            else:
                raise ValueError
        elif t == 'vec3':
            v = np.array([float(x) for x in s.replace(',', ' ').split()])
            if v.shape != (3,) or not _finite(v):
                raise ValueError
        elif t == 'floats':
            v = np.array([float(x) for x in s.replace(',', ' ').split()])
            if not _finite(v):
                raise ValueError
        elif t is str:
            v = s
        else:
            v = t(s)
    except (TypeError, ValueError):
        raise ParamError(row.what())
    c = row.check
    ok = True
    if c is None:
        pass
    elif c == '>=0':
        ok = np.all(np.asarray(v, float) >= 0)
    elif c == '>0':
        ok = np.all(np.asarray(v, float) > 0)
    elif isinstance(c, tuple):
        a = np.asarray(v, float)
        ok = np.all(a >= c[0]) and np.all(a <= c[1])
    elif callable(c):
        ok = bool(c(v))
    if not ok:
        raise ParamError(row.what())
    return v


class ParamValues(object):
    """Parsed values as attributes (``p.updateRate``); ``given`` holds the names that came
    from the model (not defaults)."""

    def __init__(self):
        self.given = set()

    def __getitem__(self, name):
        return getattr(self, name)

    def __contains__(self, name):
        return hasattr(self, name)


def find_elements(spec, row):
    """Every element naming ``row`` with a non-blank text, in the order they count: the
    plugin element, the sensor element, then the row's SDF paths below the sensor."""
    out = []
    for parent in (spec.element, spec.sensor):
        if parent is None:
            continue
        for n in row.names:
            for child in parent:
                if _local(child.tag) == n and child.text is not None and child.text.strip():
                    out.append(child)
    for path in row.paths:
        cur = spec.sensor
        for name in path:
            if cur is None:
                break
            cur = next((c for c in cur if _local(c.tag) == name), None)
        if cur is not None and cur.text is not None and cur.text.strip():
            out.append(cur)
    return out


def find_texts(spec, row):
    """Texts of every element naming ``row``, in the order they count (find_elements)."""
    return [e.text for e in find_elements(spec, row)]


def find_text(spec, row):
    """Text of the first element naming ``row`` (see find_texts), or None."""
    texts = find_texts(spec, row)
    return texts[0] if texts else None


def parse_all(spec, row, label, log=None):
    """Every value given for ``row`` (find_texts order), each bad one an error line (as
    parse_params) and left out: for a parameter the plugin and its sensor may both set
    (the camera's rate: the slowest wins)."""
    vals = []
    for text in find_texts(spec, row):
        try:
            vals.append(convert(row, text))
        except ParamError as e:
            if log is not None:
                log.error('%s', _bad(label, row, e, text))
    return vals


def bad_value(label, row, e, text):
    """The one wording of a bad parameter."""
    return '%s: %s must be %s, got %r' % (label, row.name, e, text.strip())


_bad = bad_value


def parse_params(spec, rows, label, log=None):
    """ParamValues for ``rows`` read from ``spec`` (a PluginSpec). ``label`` is
    'plugin <file> of model <m>'. Each bad value: one error line (via ``log.error``) and
    the default. Returns (values, [error lines])."""
    vals = ParamValues()
    errors = []
    for row in rows:
        text = find_text(spec, row)
        v = row.default
        if isinstance(v, (list, tuple)) and row.type in ('vec3', 'floats'):
            v = np.asarray(v, float)
        if text is not None:
            try:
                v = convert(row, text)
                vals.given.add(row.name)
            except ParamError as e:
                line = _bad(label, row, e, text)
                errors.append(line)
                if log is not None:
                    log.error('%s', line)
        setattr(vals, row.name, v)
    return vals, errors


def describe(rows):
    """Markdown table rows (name | aliases | default | unit | must be) for a README."""
    out = ['| parameter | also | default | unit | must be |', '|---|---|---|---|---|']
    for r in rows:
        d = r.default
        if isinstance(d, np.ndarray):
            d = ' '.join('%g' % x for x in d)
        out.append('| `%s` | %s | %s | %s | %s |' % (
            r.name, ', '.join('`%s`' % a for a in r.aliases), '' if d is None else d,
            r.unit, r.what()))
    return '\n'.join(out)
