"""The scenario file format (YAML) and its validation.

A scenario is checked completely before anything starts: every problem is reported as
``FILE:LINE: PATH: what was expected, got what`` (ScenarioError, never a traceback). The
schema is written down as data (ACTIONS, PREDICATE_KEYS, TOP, ...) so the README's table and
the validator cannot drift apart. ``load(path)`` returns a Scenario.
"""
import math
import os
import re

from .params import concrete, expand as _expand
from .yamlsrc import LDict, LList, ScenarioError, parse, read
from .yamlsrc import close_match as _close
from .yamlsrc import line_of as _line
from .yamlsrc import show as _show

__all__ = ['ScenarioError', 'Scenario', 'load', 'loads', 'ACTIONS', 'PREDICATE_KEYS',
           'IMAGE_KEYS', 'ENV_NAMES', 'MODES', 'validate', 'expand']

# environment value names (sim_world.environment; Environment.msg)
ENV_NAMES = ('latitude', 'longitude', 'elevation', 'heading', 'north_alpha',
             'magnetic_magnitude', 'magnetic_inclination', 'magnetic_declination',
             'temperature', 'indoor_temperature', 'humidity', 'pressure_offset',
             'sea_level_pressure', 'sea_level_temperature', 'temperature_gradient', 'daylight',
             'time_of_day', 'day_of_year')

MODES = ('eventually', 'always', 'never', 'count', 'rate')


# -- the schema ---------------------------------------------------------------------------
# field kinds: 'num', 'num>=0', 'num>0', 'int>=0', 'str', 'bool', 'vec3', 'vec2', 'nums',
# 'points' (list of vec3), 'pose', 'values' (env name -> number), 'dict', 'list', 'any',
# 'series' (list of [t, value]), a tuple of allowed strings
_POSE = 'pose'
ACTIONS = {
    # name: (required fields, optional fields, doc)
    'set_model_state': ({'model': 'str'}, {'position': 'vec3', 'rpy': 'vec3',
                                           'reference_frame': 'str'},
                        'teleport a model (position m, rpy rad; /gazebo/set_model_state)'),
    'move_model': ({'model': 'str', 'waypoints': 'points'},
                   {'speed': 'num>0', 'rpy': 'vec3', 'interval': 'num>0'},
                   'move through waypoints at speed m/s (poses set every interval s)'),
    'walk': ({'model': 'str', 'waypoints': 'points'},
             {'speed': 'num>0', 'step_frequency': 'num>0', 'bounce': 'num>=0',
              'height': 'num', 'rpy': 'vec3', 'interval': 'num>0', 'heading': 'bool'},
             'hand-held walk: waypoints at speed, vertical step bounce, facing the walk'),
    'rotate': ({'model': 'str', 'rpy': 'vec3'}, {'duration': 'num>=0', 'interval': 'num>0'},
               'turn a model to rpy (rad) over duration s'),
    'set_environment': ({'values': 'values'}, {'ramp': 'num>=0', 'interval': 'num>0'},
                        'set environment values, at once or as a linear ramp over ramp s'),
    'playback': ({'series': 'series'}, {'name': ENV_NAMES, 'topic': 'str', 'type': 'str',
                                        'field': 'str'},
                 'play a value series [[t, v], ...] into an environment value or a topic'),
    'charger': ({'plugged': 'bool'}, {'ns': 'str'}, 'plug/unplug the charger (<ns>/charger)'),
    'radio': ({'radio': ('wifi', 'bluetooth', 'cellular', 'nfc'), 'enabled': 'bool'},
              {'ns': 'str'}, 'switch a radio (<ns>/<radio>/enable)'),
    'press_button': ({'button': 'str'}, {'ns': 'str', 'duration': 'num>0'},
                     'press a hardware button (<ns>/press_button)'),
    'touch': ({'x': 'num', 'y': 'num'}, {'ns': 'str', 'duration': 'num>0',
                                         'pressure': 'num>=0', 'x_end': 'num', 'y_end': 'num'},
              'touch the display at a pixel (<ns>/inject_touch)'),
    'show_image': ({'file': 'str'}, {'ns': 'str', 'topic': 'str'},
                   'show an image file on a display (textvid load topic)'),
    'spawn_model': ({'name': 'str', 'file': 'str'}, {'position': 'vec3', 'rpy': 'vec3',
                                                     'namespace': 'str', 'args': 'dict'},
                    'spawn a URDF/xacro/SDF model'),
    'delete_model': ({'name': 'str'}, {}, 'delete a model'),
    'fault': ({'sensor': 'str', 'fault': ('none', 'drop', 'freeze', 'noise', 'no_fix')},
              {'model': 'str', 'value': 'num'},
              'inject a sensor fault (/gazebo/set_sensor_fault)'),
    'publish': ({'topic': 'str', 'type': 'str'}, {'msg': 'dict', 'latch': 'bool'},
                'publish one message (fields as a mapping)'),
    'log': ({'text': 'str'}, {}, 'write a line into the report and the recording'),
    'set_joints': ({'model': 'str', 'positions': 'joints'},
                   {'duration': 'num>=0', 'interval': 'num>0'},
                   'put joints at positions {joint: rad or m}, at rest, at once or moving '
                   'linearly over duration s (/gazebo/set_model_configuration)'),
    'joint_effort': ({'joint': 'str', 'effort': 'num'}, {'duration': 'num'},
                     'apply an effort (N m or N) to a joint (model::joint) for duration s '
                     '(default 1; < 0: until the end; /gazebo/apply_joint_effort)'),
    'trajectory': ({'controller': 'str', 'joints': 'names', 'points': 'list'}, {},
                   'send a trajectory_msgs/JointTrajectory to <controller>/command: points '
                   '[{positions: [..], time_from_start: s, velocities: [..]}]'),
    'door': ({'open': 'bool'}, {'model': 'str', 'joint': 'str', 'position': 'num'},
             "open or close a door on its hinge (default the office's east_door, joint "
             'hinge: open 1.5 rad, closed 0; /gazebo/set_model_configuration)'),
    'attach': ({'holder': 'str', 'held': 'str'}, {},
               'hold model::link held by model::link holder where they are now (a model '
               'alone: its root link; /gazebo/attach)'),
    'detach': ({'holder': 'str', 'held': 'str'}, {}, 'let go of what attach held '
               '(/gazebo/detach)'),
    'e_stop': ({'ns': 'str', 'active': 'bool'}, {'topic': 'str'},
               "a robot's e-stop active or released: std_msgs/Bool on <ns>/e_stop (topic: the "
               "plugin's eStopTopic, relative to ns or absolute; libgazebo_ros_control.so)"),
}
PREDICATE_KEYS = {
    'equals': 'any', 'near': 'any', 'tol': 'num>=0', 'gt': 'num', 'ge': 'num', 'lt': 'num',
    'le': 'num', 'between': 'nums', 'contains': 'str', 'not_equals': 'any', 'min': 'num',
    'max': 'num',
}
IMAGE_KEYS = {'barcode': 'str', 'region': 'nums', 'colour': 'nums', 'color': 'nums',
              'led': ('on', 'off'), 'threshold': 'num>=0'}
CONDITION_KEYS = dict(PREDICATE_KEYS, topic='str', field='str', reach='dict',
                      **IMAGE_KEYS)
TOP = {
    'name': 'str', 'description': 'str', 'world': 'dict', 'seed': 'int>=0',
    'real_time_factor': 'num>=0', 'duration': 'num>0', 'timeout': 'num>0',
    'slice': 'num>0', 'pipeline': 'bool', 'apps': 'list', 'timeline': 'list',
    'expect': 'list', 'record': 'list', 'phones': 'list',
}
WORLD = {'launch': 'str', 'attach': 'bool', 'physics': ('ode', 'bullet'), 'args': 'dict',
         'max_step_size': 'num>0'}
PHONE = {'ns': 'str', 'position': 'vec3', 'rpy': 'vec3', 'args': 'dict'}
APP = {'name': 'str', 'script': 'str', 'node': 'str', 'args': 'list', 'params': 'dict'}
EXPECT = dict({m: 'dict' for m in MODES}, name='str', topic='str', field='str',
              window='nums', after='str')
EVENT = {'at': 'num>=0', 'when': 'dict', 'after': 'str', 'delay': 'num>=0', 'id': 'str',
         'action': tuple(sorted(ACTIONS))}


class Scenario(object):
    """A validated scenario: attributes mirror the top-level keys with defaults filled in."""

    def __init__(self, data, path):
        self.path = path
        self.dir = os.path.dirname(os.path.abspath(path)) if path else os.getcwd()
        self.data = data
        self.name = data.get('name') or os.path.splitext(os.path.basename(path or 'x'))[0]
        self.description = data.get('description', '')
        self.world = dict(data.get('world') or {})
        self.seed = data.get('seed', 0)
        self.real_time_factor = float(data.get('real_time_factor', 0.0))
        self.duration = float(data['duration'])
        self.timeout = float(data.get('timeout', 300.0))
        self.slice = float(data.get('slice', 0.05))
        self.pipeline = bool(data.get('pipeline', False))
        self.apps = list(data.get('apps') or [])
        self.phones = list(data.get('phones') or [{'ns': 'mobile_device'}])
        self.timeline = list(data.get('timeline') or [])
        self.expect = list(data.get('expect') or [])
        self.record = list(data.get('record') or [])
        self.params = dict(getattr(data, 'param_values', None) or {})
        for i, e in enumerate(self.timeline):
            e.setdefault('id', 'event%d' % i)
        for i, e in enumerate(self.expect):
            e.setdefault('name', 'expect%d' % i)

    def resolve(self, p):
        """A path relative to the scenario file's folder (package:// and absolute kept;
        pybullet_data://PATH: a file of pybullet's data package, e.g. its robots)."""
        if p.startswith('pybullet_data://'):
            import pybullet_data
            return os.path.join(pybullet_data.getDataPath(), p[len('pybullet_data://'):])
        if p.startswith('package://') or p.startswith('file://') or os.path.isabs(p):
            return p
        return os.path.normpath(os.path.join(self.dir, p))


def load(path, values=None):
    return _from_data(read(path), path, values)


def loads(text, path='<scenario>', values=None):
    return _from_data(parse(text, path), path, values)


def _from_data(data, path, values):
    data = concrete(data, path, values)   # parameters: / sweep: / ${name} (issue 21)
    problems = validate(data, path)
    if problems:
        raise ScenarioError(problems)
    return Scenario(data, path)


def expand(data, path='<scenario>', sets=None, max_runs=None, sweep=True):
    """The concrete runs of a scenario's sweep (params.expand), each substituted and
    validated: every problem raised as ScenarioError with file:line."""
    return _expand(data, path, sets, max_runs, check=validate, sweep=sweep)


# -- validation ---------------------------------------------------------------------------
def _is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check_kind(kind, v):
    """None when v fits kind, else the text of what was expected."""
    if isinstance(kind, tuple):
        return None if v in kind else 'one of %s' % ', '.join(kind)
    if kind == 'any':
        return None
    if kind == 'num':
        return None if _is_num(v) else 'a number'
    if kind == 'num>=0':
        return None if _is_num(v) and v >= 0 else 'a number >= 0'
    if kind == 'num>0':
        return None if _is_num(v) and v > 0 else 'a number > 0'
    if kind == 'int>=0':
        return None if isinstance(v, int) and not isinstance(v, bool) and v >= 0 \
            else 'a whole number >= 0'
    if kind == 'str':
        return None if isinstance(v, str) and v else 'a non-empty string'
    if kind == 'bool':
        return None if isinstance(v, bool) else 'true or false'
    if kind == 'vec3':
        return None if isinstance(v, list) and len(v) == 3 and all(map(_is_num, v)) \
            else 'a list of 3 numbers'
    if kind == 'nums':
        return None if isinstance(v, list) and v and all(map(_is_num, v)) \
            else 'a list of numbers'
    if kind == 'points':
        return None if isinstance(v, list) and v and all(
            isinstance(p, list) and len(p) == 3 and all(map(_is_num, p)) for p in v) \
            else 'a list of [x, y, z] points'
    if kind == 'series':
        return None if isinstance(v, list) and v and all(
            isinstance(p, list) and len(p) == 2 and all(map(_is_num, p)) for p in v) \
            else 'a list of [t, value] pairs'
    if kind == 'values':
        if not isinstance(v, dict) or not v:
            return 'a mapping of environment names to numbers'
        for k, x in v.items():
            if k not in ENV_NAMES:
                return 'environment names (%s), not %r' % (', '.join(ENV_NAMES), k)
            if not _is_num(x):
                return 'a number for %s' % k
        return None
    if kind == 'joints':
        if not isinstance(v, dict) or not v:
            return 'a mapping of joint names to positions'
        for k, x in v.items():
            if not isinstance(k, str) or not k:
                return 'joint names as keys, not %r' % (k,)
            if not _is_num(x):
                return 'a number for joint %s' % k
        return None
    if kind == 'names':
        return None if isinstance(v, list) and v and all(
            isinstance(x, str) and x for x in v) else 'a list of names'
    if kind == 'dict':
        return None if isinstance(v, dict) else 'a mapping'
    if kind == 'list':
        return None if isinstance(v, list) else 'a list'
    raise AssertionError(kind)


class _V(object):
    def __init__(self, path):
        self.path = path
        self.problems = []

    def err(self, line, where, text):
        self.problems.append('%s:%d: %s: %s' % (self.path, line, where, text))

    def fields(self, obj, where, allowed, required=(), parent_line=0):
        """Check a mapping against {key: kind}; returns False when obj is no mapping."""
        if not isinstance(obj, dict):
            self.err(_line(obj, default=parent_line), where,
                     'expected a mapping, got %s' % _show(obj))
            return False
        for k in required:
            if k not in obj:
                self.err(_line(obj, default=parent_line), where,
                         'missing %r (expected %s)' % (k, _kind_text(allowed[k])))
        for k, v in obj.items():
            if k not in allowed:
                self.err(_line(obj, k, parent_line), '%s.%s' % (where, k),
                         'unknown key%s; expected one of %s' % (
                             _close(k, allowed), ', '.join(sorted(allowed))))
                continue
            bad = _check_kind(allowed[k], v)
            if bad:
                self.err(_line(obj, k, parent_line), '%s.%s' % (where, k),
                         'expected %s, got %s' % (bad, _show(v)))
        return True


def _kind_text(kind):
    if isinstance(kind, tuple):
        return 'one of %s' % ', '.join(kind)
    return {'num': 'a number', 'num>=0': 'a number >= 0', 'num>0': 'a number > 0',
            'str': 'a string', 'bool': 'true or false', 'vec3': '[x, y, z]',
            'points': 'a list of [x, y, z]', 'series': 'a list of [t, value]',
            'values': 'a mapping name: number', 'nums': 'a list of numbers',
            'int>=0': 'a whole number', 'joints': 'a mapping joint: position',
            'names': 'a list of names'}.get(kind, kind)


def validate(data, path='<scenario>'):
    """All problems of a parsed scenario as 'FILE:LINE: where: text' lines ([] = valid)."""
    v = _V(path)
    if not isinstance(data, dict):
        v.err(_line(data, default=1), 'scenario', 'expected a mapping with duration, timeline '
              'and expect, got %s' % _show(data))
        return v.problems
    v.fields(data, 'scenario', TOP, required=('duration',))
    duration = data.get('duration') if _is_num(data.get('duration')) else None
    if isinstance(data.get('world'), dict):
        v.fields(data['world'], 'world', WORLD, parent_line=_line(data, 'world'))
    for i, ph in enumerate(data.get('phones') or [] if isinstance(data.get('phones'), list)
                           else []):
        v.fields(ph, 'phones[%d]' % i, PHONE, required=('ns',),
                 parent_line=_line(data['phones'], i))
    apps = data.get('apps') if isinstance(data.get('apps'), list) else []
    for i, app in enumerate(apps):
        where = 'apps[%d]' % i
        if v.fields(app, where, APP, parent_line=_line(apps, i)):
            if ('script' in app) == ('node' in app):
                v.err(_line(app, default=_line(apps, i)), where,
                      'expected exactly one of script (a file beside the scenario) or node '
                      '(pkg/type)')
    ids = set()
    timeline = data.get('timeline') if isinstance(data.get('timeline'), list) else []
    for i, ev in enumerate(timeline):
        where = 'timeline[%d]' % i
        line = _line(timeline, i)
        if not isinstance(ev, dict):
            v.err(line, where, 'expected a mapping with at/when and action, got %s' % _show(ev))
            continue
        if isinstance(ev.get('id'), str):
            ids.add(ev['id'])
    for i, ev in enumerate(timeline):
        if isinstance(ev, dict):
            _validate_event(v, ev, 'timeline[%d]' % i, _line(timeline, i), duration, ids)
    exps = data.get('expect') if isinstance(data.get('expect'), list) else []
    names = set()
    for i, ex in enumerate(exps):
        _validate_expect(v, ex, 'expect[%d]' % i, _line(exps, i), duration, ids, names)
    rec = data.get('record') if isinstance(data.get('record'), list) else []
    for i, t in enumerate(rec):
        if not isinstance(t, str) or not t:
            v.err(_line(rec, i), 'record[%d]' % i, 'expected a topic name, got %s' % _show(t))
    return v.problems


def _validate_event(v, ev, where, line, duration, ids):
    action = ev.get('action')
    if action is None:
        v.err(_line(ev, default=line), where, 'missing action (expected one of %s)'
              % ', '.join(sorted(ACTIONS)))
        return
    if action not in ACTIONS:
        v.err(_line(ev, 'action', line), where + '.action', 'unknown action %r%s; expected '
              'one of %s' % (action, _close(action, ACTIONS), ', '.join(sorted(ACTIONS))))
        return
    req, opt, _doc = ACTIONS[action]
    allowed = dict(EVENT, **req)
    allowed.update(opt)
    v.fields(ev, where, allowed, required=tuple(req), parent_line=line)
    triggers = [k for k in ('at', 'when', 'after') if k in ev]
    if len(triggers) != 1:
        v.err(_line(ev, default=line), where, 'expected exactly one trigger: at (sim time s), '
              'when (a condition) or after (an event id)%s' % (
                  ', got %s' % ' and '.join(triggers) if triggers else ''))
    at = ev.get('at')
    if _is_num(at) and duration is not None and at > duration:
        v.err(_line(ev, 'at', line), where + '.at', 'expected a sim time within the scenario '
              '(0 .. duration %g s), got %g' % (duration, at))
    if 'after' in ev and ev['after'] not in ids:
        v.err(_line(ev, 'after', line), where + '.after', 'expected the id of a timeline '
              'event (%s), got %r' % (', '.join(sorted(ids)) or 'none defined', ev['after']))
    if isinstance(ev.get('when'), dict):
        _validate_condition(v, ev['when'], where + '.when', _line(ev, 'when', line))
    if action == 'trajectory' and isinstance(ev.get('points'), list):
        _validate_points(v, ev, where, line)
    if action == 'e_stop':
        for k in ('ns', 'topic'):
            if isinstance(ev.get(k), str) and ev[k] and not _ROS_NAME.match(ev[k]):
                v.err(_line(ev, k, line), '%s.%s' % (where, k), 'expected a ROS name '
                      '(letters, digits, _ and /, not starting with a digit), got %s'
                      % _show(ev[k]))
    if action == 'playback':
        if ('name' in ev) == ('topic' in ev):
            v.err(_line(ev, default=line), where, 'expected exactly one of name (an '
                  'environment value) or topic (with type and field)')
        if 'topic' in ev and not ('type' in ev and 'field' in ev):
            v.err(_line(ev, default=line), where, 'a topic playback needs type and field')


#: a ROS graph name (global or relative; ROS's own rule, without ~)
_ROS_NAME = re.compile(r'^(/|/?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*/?)$')

TRAJECTORY_POINT = {'positions': 'nums', 'time_from_start': 'num>=0', 'velocities': 'nums',
                    'accelerations': 'nums', 'effort': 'nums'}


def _validate_points(v, ev, where, line):
    """A trajectory's points: mappings with positions (one per joint) and a
    time_from_start later than the point before."""
    pts = ev['points']
    pline = _line(ev, 'points', line)
    if not pts:
        v.err(pline, where + '.points', 'expected at least one point')
    n = len(ev['joints']) if isinstance(ev.get('joints'), list) else None
    last = None
    for i, pt in enumerate(pts):
        pw = '%s.points[%d]' % (where, i)
        if not v.fields(pt, pw, TRAJECTORY_POINT, required=('positions', 'time_from_start'),
                        parent_line=_line(pts, i, pline)):
            continue
        pl = _line(pt, default=_line(pts, i, pline))
        for k in ('positions', 'velocities', 'accelerations', 'effort'):
            if n is not None and isinstance(pt.get(k), list) and len(pt[k]) != n:
                v.err(_line(pt, k, pl), '%s.%s' % (pw, k), 'expected %d values (one per '
                      'joint of joints), got %d' % (n, len(pt[k])))
        t = pt.get('time_from_start')
        if _is_num(t):
            if last is not None and t <= last:
                v.err(_line(pt, 'time_from_start', pl), pw + '.time_from_start',
                      'expected a time after the point before (%g s), got %g' % (last, t))
            last = t


def _validate_condition(v, cond, where, line):
    if not v.fields(cond, where, CONDITION_KEYS, parent_line=line):
        return
    if 'reach' in cond:
        r = cond['reach']
        v.fields(r, where + '.reach', {'model': 'str', 'position': 'vec3',
                                       'tolerance': 'num>0'},
                 required=('model', 'position'), parent_line=_line(cond, 'reach', line))
        return
    if 'topic' not in cond:
        v.err(_line(cond, default=line), where, 'expected topic (with a predicate) or reach')
    _validate_predicate(v, cond, where, line, skip=('topic', 'field'))


def _validate_predicate(v, pred, where, line, skip=()):
    keys = [k for k in pred if k not in skip]
    if not keys:
        v.err(_line(pred, default=line), where, 'expected a predicate (%s)' %
              ', '.join(sorted(set(PREDICATE_KEYS) | set(IMAGE_KEYS))))
    if 'tol' in pred and not any(k in pred for k in ('near', 'equals', 'not_equals',
                                                      'colour', 'color')):
        v.err(_line(pred, 'tol', line), where + '.tol', 'tol goes with near, equals or '
              'colour')
    if 'between' in pred and (not isinstance(pred['between'], list)
                              or len(pred['between']) != 2):
        v.err(_line(pred, 'between', line), where + '.between', 'expected [low, high]')
    if 'region' in pred and (not isinstance(pred['region'], list) or len(pred['region']) != 4):
        v.err(_line(pred, 'region', line), where + '.region',
              'expected [x, y, width, height] in pixels')
    for ck in ('colour', 'color'):
        if ck in pred:
            if 'region' not in pred:
                v.err(_line(pred, ck, line), where + '.' + ck, 'a colour needs a region')
            if not isinstance(pred[ck], list) or len(pred[ck]) != 3:
                v.err(_line(pred, ck, line), where + '.' + ck, 'expected [r, g, b] (0..255)')
    if 'led' in pred and 'region' not in pred:
        v.err(_line(pred, 'led', line), where + '.led', 'an LED check needs a region')


def _validate_expect(v, ex, where, line, duration, ids, names):
    if not v.fields(ex, where, EXPECT, parent_line=line):
        return
    line = _line(ex, default=line)
    if 'topic' not in ex:
        v.err(line, where, 'missing topic (expected a topic name)')
    modes = [m for m in MODES if m in ex]
    if len(modes) != 1:
        v.err(line, where, 'expected exactly one of %s%s' % (
            ', '.join(MODES), ', got %s' % ' and '.join(modes) if modes else ''))
    name = ex.get('name')
    if name is not None and name in names:
        v.err(_line(ex, 'name', line), where + '.name', 'expectation name %r used twice' % name)
    names.add(name)
    for m in modes:
        pred = ex[m]
        if isinstance(pred, dict):
            allowed = PREDICATE_KEYS if m in ('count', 'rate') else dict(PREDICATE_KEYS,
                                                                          **IMAGE_KEYS)
            if v.fields(pred, where + '.' + m, allowed, parent_line=_line(ex, m, line)):
                _validate_predicate(v, pred, where + '.' + m, _line(ex, m, line))
    w = ex.get('window')
    if isinstance(w, list) and all(map(_is_num, w)):
        wl = _line(ex, 'window', line)
        if len(w) != 2:
            v.err(wl, where + '.window', 'expected [start, end] in s of sim time')
        elif w[0] < 0 or w[1] <= w[0]:
            v.err(wl, where + '.window', 'expected 0 <= start < end, got [%g, %g]' % tuple(w))
        elif duration is not None and 'after' not in ex and w[1] > duration + 1e-9:
            v.err(wl, where + '.window', 'the window ends at %g s, after the scenario '
                  '(duration %g s)' % (w[1], duration))
    if 'after' in ex and ex['after'] not in ids:
        v.err(_line(ex, 'after', line), where + '.after', 'expected the id of a timeline event '
              '(%s), got %r' % (', '.join(sorted(ids)) or 'none defined', ex['after']))
