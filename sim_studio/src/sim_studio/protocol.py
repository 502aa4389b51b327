"""The studio's versioned JSON command protocol (version 1), without ROS.

A command is one JSON object ``{"v": 1, "op": NAME, ...fields, "id": optional}``, sent on
the WebSocket ``/ws`` or as the body of ``POST /api/cmd``. ``parse`` turns its text into a
checked ``Command`` or raises ``ProtocolError`` whose message names the bad part; a command
that fails here changes nothing. The schema is data (``OPS``) so that the README's table and
the checks cannot drift apart."""
import json
import math

__all__ = ['VERSION', 'MAX_BYTES', 'OPS', 'WORLD_OPS', 'Command', 'ProtocolError', 'parse',
           'check', 'reply', 'error', 'register']

VERSION = 1
MAX_BYTES = 256 * 1024          # a command's text (a scenario to run included)

BUTTONS = ('power', 'volume_up', 'volume_down')
FAULTS = ('none', 'drop', 'freeze', 'noise', 'no_fix')
MODES = ('always', 'eventually')
CHECKS = ('equals', 'near', 'between')

# field kinds: 'str', 'num', 'num>0', 'num>=0', 'unit' (0..1), 'vec3', 'bool', 'values'
# (name -> number), 'list' (a JSON array), 'object' (a JSON object), 'int>=0', a tuple of
# allowed strings
OPS = {
    # op: (required fields, optional fields with defaults, changes the world, doc)
    'set_pose': ({'model': 'str', 'position': 'vec3'}, {'rpy': [0.0, 0.0, 0.0]}, True,
                 'teleport a model: position [x, y, z] m, rpy [roll, pitch, yaw] rad'),
    'touch': ({'x': 'unit', 'y': 'unit'}, {'model': 'mobile_device', 'duration': 0.1}, True,
              "touch a phone's display at (x, y) in 0..1 from its top left for duration s"),
    'press_button': ({'button': BUTTONS}, {'model': 'mobile_device', 'duration': 0.1}, True,
                     'press a hardware button for duration s'),
    'set_environment': ({'values': 'values'}, {}, True,
                        'set environment values (names of /gazebo/set_environment)'),
    'fault': ({'sensor': 'str', 'fault': FAULTS}, {'model': 'mobile_device', 'value': 0.0},
              True, 'inject a sensor fault (none clears it)'),
    'play': ({}, {}, True, 'run the world'),
    'pause': ({}, {}, True, 'pause the world'),
    'step': ({'until': 'num>=0'}, {}, True, 'run the world until sim time until s, then pause'),
    'reset': ({}, {}, True, 'reset the world (models back to their start poses)'),
    'record': ({'on': 'bool'}, {}, False, 'start (true) or stop (false) recording'),
    'control': ({'take': 'bool'}, {}, False, 'take (true) or let go of (false) control'),
    'scene': ({}, {}, False, 'the models and their poses (as GET /api/scene)'),
    'device': ({'on': 'bool'}, {}, False,
               "stream (true) or stop streaming (false) the phones' sensor values to this "
               'client; replies with the values now'),
    'check': ({'yaml': 'str'}, {}, False, "validate a scenario (run_scenario --check's errors)"),
    'expect': ({'topic': 'str', 'field': 'str', 'mode': MODES, 'check': CHECKS},
               {'target': None, 'tol': None, 'lo': None, 'hi': None, 'start': None,
                'end': None, 'name': None}, False,
               "add an expectation to the recording's scenario: field of topic, always or "
               'eventually, equals target, near target +- tol, or between lo and hi, in the '
               'window [start, end] s (default: the whole run)'),
    'run': ({'yaml': 'str'}, {}, False, 'run a scenario with run_scenario; its verdicts'),
}
#: ops that need control (they change the world or the recording)
WORLD_OPS = set(op for op, spec in OPS.items() if spec[2]) | {'record', 'run', 'expect'}
#: ops that take a model that must be in the world
MODEL_OPS = {'set_pose', 'touch', 'press_button', 'fault'}
#: op -> fn(fields) raising ProtocolError: checks across an op's fields (extensions' too)
FIELD_CHECKS = {}


class ProtocolError(ValueError):
    """A command that cannot be carried out; its message names what was wrong."""


class Command(object):
    def __init__(self, op, fields, cid=None):
        self.op = op
        self.fields = fields
        self.id = cid

    @property
    def changes_world(self):
        return OPS[self.op][2]

    def __getitem__(self, k):
        return self.fields[k]

    def __repr__(self):
        return 'Command(%r, %r)' % (self.op, self.fields)


def _finite(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _kind(kind, v, where):
    """The value checked against ``kind`` (numbers as float), or ProtocolError."""
    if isinstance(kind, tuple):
        if v not in kind:
            raise ProtocolError('%s: expected one of %s, got %s' % (where, ', '.join(kind),
                                                                   json.dumps(v)))
        return v
    if kind == 'str':
        if not isinstance(v, str) or not v:
            raise ProtocolError('%s: expected a non-empty string, got %s' % (where, json.dumps(v)))
        return v
    if kind == 'bool':
        if not isinstance(v, bool):
            raise ProtocolError('%s: expected true or false, got %s' % (where, json.dumps(v)))
        return v
    if kind == 'vec3':
        if not (isinstance(v, list) and len(v) == 3 and all(_finite(x) for x in v)):
            raise ProtocolError('%s: expected [x, y, z] of three finite numbers, got %s'
                                % (where, _show(v)))
        return [float(x) for x in v]
    if kind == 'list':
        if not isinstance(v, list):
            raise ProtocolError('%s: expected a JSON array, got %s' % (where, _show(v)))
        return v
    if kind == 'object':
        if not isinstance(v, dict):
            raise ProtocolError('%s: expected a JSON object, got %s' % (where, _show(v)))
        return v
    if kind == 'int>=0':
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise ProtocolError('%s: expected a whole number >= 0, got %s' % (where, _show(v)))
        return v
    if kind == 'values':
        if not isinstance(v, dict) or not v or not all(
                isinstance(k, str) and _finite(x) for k, x in v.items()):
            raise ProtocolError('%s: expected a mapping of names to finite numbers, got %s'
                                % (where, _show(v)))
        return {k: float(x) for k, x in v.items()}
    if not _finite(v):
        raise ProtocolError('%s: expected a finite number, got %s' % (where, _show(v)))
    v = float(v)
    if kind == 'num>0' and not v > 0:
        raise ProtocolError('%s: expected a number > 0, got %g' % (where, v))
    if kind == 'num>=0' and not v >= 0:
        raise ProtocolError('%s: expected a number >= 0, got %g' % (where, v))
    if kind == 'unit' and not 0.0 <= v <= 1.0:
        raise ProtocolError('%s: expected a number in 0..1 (of the display, from its top '
                            'left), got %g' % (where, v))
    return v


def _show(v):
    try:
        text = json.dumps(v, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(v)
    return text if len(text) <= 80 else text[:77] + '...'


_OPT_KINDS = {'rpy': 'vec3', 'model': 'str', 'duration': 'num>0', 'value': 'num>=0',
              'target': 'num', 'tol': 'num>=0', 'lo': 'num', 'hi': 'num', 'start': 'num>=0',
              'end': 'num>0', 'name': 'str'}


def _check_expect(f):
    """The fields an expectation's check needs, and a window that is one."""
    need = {'equals': ('target',), 'near': ('target', 'tol'), 'between': ('lo', 'hi')}
    for k in need[f['check']]:
        if f[k] is None:
            raise ProtocolError('expect: %s needs the field %s' % (f['check'], k))
    if f['check'] == 'between' and f['lo'] > f['hi']:
        raise ProtocolError('expect: between needs lo <= hi, got %g > %g' % (f['lo'], f['hi']))
    if (f['start'] is None) != (f['end'] is None):
        raise ProtocolError('expect: a window needs both start and end')
    if f['start'] is not None and not f['start'] < f['end']:
        raise ProtocolError('expect: the window needs start < end, got [%g, %g]'
                            % (f['start'], f['end']))


def check(obj, models=None):
    """A decoded command (a dict) as a Command; ``models``: the names of the world's models
    (None: not checked). ProtocolError names the first problem."""
    if not isinstance(obj, dict):
        raise ProtocolError('expected a JSON object {"v": 1, "op": ...}, got %s' % _show(obj))
    if obj.get('v') != VERSION or isinstance(obj.get('v'), bool):
        raise ProtocolError('v: expected protocol version %d, got %s'
                            % (VERSION, _show(obj.get('v'))))
    cid = obj.get('id')
    if cid is not None and not isinstance(cid, (str, int)):
        raise ProtocolError('id: expected a string or a number, got %s' % _show(cid))
    op = obj.get('op')
    if op not in OPS:
        raise ProtocolError('op: unknown op %s; expected one of %s'
                            % (_show(op), ', '.join(sorted(OPS))))
    req, opt, _world, _doc = OPS[op]
    allowed = set(req) | set(opt) | {'v', 'op', 'id'}
    extra = sorted(k for k in obj if k not in allowed)
    if extra:
        raise ProtocolError('%s: unknown field %s; expected %s' % (
            op, ', '.join(map(str, extra)), ', '.join(sorted(set(req) | set(opt))) or 'none'))
    fields = {}
    for k, kind in req.items():
        if k not in obj:
            raise ProtocolError('%s: missing field %s' % (op, k))
        fields[k] = _kind(kind, obj[k], '%s.%s' % (op, k))
    for k, default in opt.items():
        fields[k] = _kind(_OPT_KINDS[k], obj[k], '%s.%s' % (op, k)) if k in obj else default
    if op == 'expect':
        _check_expect(fields)
    if op in FIELD_CHECKS:
        FIELD_CHECKS[op](fields)
    if models is not None and op in MODEL_OPS and fields['model'] not in models:
        raise ProtocolError('%s.model: no model %s in the world (models: %s)'
                            % (op, _show(fields['model']), ', '.join(sorted(models))))
    return Command(op, fields, cid)


def register(op, required, optional, changes_world, doc, kinds=None, needs_control=None,
             takes_model=False, field_check=None):
    """Add an op to the protocol (an extension's, sim_studio.extensions): its required fields
    {name: kind}, its optional fields {name: default} with their kinds in ``kinds`` {name:
    kind} (a name the core already knows keeps its kind), whether it changes the world,
    its one-line doc. ``needs_control`` (default: ``changes_world``) puts it under control;
    ``takes_model``: its ``model`` field must name a model in the world; ``field_check``:
    fn(fields) raising ProtocolError for checks across fields. An op that exists is an
    error (two extensions would shadow each other)."""
    if op in OPS:
        raise ValueError('studio protocol: op %s is defined twice' % op)
    kinds = dict(kinds or {})
    for k in optional:
        if k not in kinds and k not in _OPT_KINDS:
            raise ValueError('studio protocol: %s.%s has no kind' % (op, k))
        if k in kinds and k in _OPT_KINDS and kinds[k] != _OPT_KINDS[k]:
            raise ValueError('studio protocol: %s.%s: kind %r, but %s is %r for every op'
                             % (op, k, kinds[k], k, _OPT_KINDS[k]))
    _OPT_KINDS.update(kinds)
    OPS[op] = (dict(required), dict(optional), bool(changes_world), doc)
    if changes_world if needs_control is None else needs_control:
        WORLD_OPS.add(op)
    if takes_model:
        MODEL_OPS.add(op)
    if field_check is not None:
        FIELD_CHECKS[op] = field_check


def parse(text, models=None):
    """A command from its JSON text (str or bytes): size, JSON (NaN and Infinity refused),
    then ``check``."""
    if isinstance(text, (bytes, bytearray)):
        if len(text) > MAX_BYTES:
            raise ProtocolError('message of %d bytes is larger than %d' % (len(text), MAX_BYTES))
        try:
            text = text.decode('utf-8')
        except UnicodeDecodeError:
            raise ProtocolError('message is not UTF-8 text')
    if len(text) > MAX_BYTES:
        raise ProtocolError('message of %d characters is larger than %d' % (len(text),
                                                                            MAX_BYTES))

    def no_constant(name):
        raise ProtocolError('%s is not a number JSON allows' % name)
    try:
        obj = json.loads(text, parse_constant=no_constant)
    except ProtocolError:
        raise
    except ValueError as e:
        raise ProtocolError('not JSON: %s' % e)
    return check(obj, models)


def reply(cmd, **fields):
    """The answer to ``cmd`` (a Command, or None)."""
    out = {'v': VERSION, 'type': 'reply', 'ok': True}
    if cmd is not None:
        out['op'] = cmd.op
        if cmd.id is not None:
            out['id'] = cmd.id
    out.update(fields)
    return out


def error(text, cmd=None, raw=None):
    """The error answer: to ``cmd``, or to an unparsed message (its id if it had one)."""
    out = {'v': VERSION, 'type': 'reply', 'ok': False, 'error': text}
    if cmd is not None:
        out['op'] = cmd.op
        if cmd.id is not None:
            out['id'] = cmd.id
    elif isinstance(raw, dict):
        if isinstance(raw.get('id'), (str, int)):
            out['id'] = raw['id']
        if isinstance(raw.get('op'), str):
            out['op'] = raw['op']
    return out
