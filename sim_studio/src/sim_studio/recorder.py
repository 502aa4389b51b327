"""Recording kept by the studio's server: world-changing commands as the runner's own
timeline actions, and the scenario YAML they make (without ROS).

While recording is on, every world-changing command that was carried out becomes one
timeline entry at the sim time it happened, counted from the sim time recording started:
``set_pose`` -> ``set_model_state`` (several poses of one model at the same sim time, a
drag while the world is paused, are one action: the last pose), ``touch`` -> ``touch`` (display pixels),
``press_button`` -> ``press_button``, ``set_environment`` -> ``set_environment``,
``fault`` -> ``fault``. play, pause, step and reset are the studio's world controls, not
scenario actions: they are not recorded. The YAML is checked with testing_instance's
validator (``check``), the same checks as ``run_scenario --check``."""
import json
import re

__all__ = ['Recorder', 'check', 'MARGIN']

_PLAIN = re.compile(r'^[A-Za-z_/][A-Za-z0-9_./-]*$')
_KEYWORDS = ('true', 'false', 'yes', 'no', 'on', 'off', 'null', 'y', 'n', '~')
MARGIN = 1.0        # s of sim time the scenario runs after the last recorded action


def _num(v):
    """A number as YAML text: short, exact enough (1e-6)."""
    v = float(v)
    if v == int(v) and abs(v) < 1e15:
        return '%d' % v if v == 0 or abs(v) >= 1 else '%g' % v
    if abs(v) < 0.01:            # small values (a magnetic field in tesla): 7 digits
        mant, _, exp = ('%.7g' % v).partition('e')
        if '.' not in mant:
            mant += '.0'         # YAML 1.1 reads 1e-05 as a string, 1.0e-05 as a number
        return mant + ('e' + exp if exp else '')
    return ('%.6f' % v).rstrip('0').rstrip('.')


def _flow(value):
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, (int, float)):
        return _num(value)
    if isinstance(value, (list, tuple)):
        return '[%s]' % ', '.join(_flow(v) for v in value)
    if isinstance(value, dict):
        return '{%s}' % ', '.join('%s: %s' % (k, _flow(v)) for k, v in value.items())
    text = str(value)
    if _PLAIN.match(text) and text.lower() not in _KEYWORDS:
        return text
    return json.dumps(text)      # a JSON string is a YAML double-quoted scalar


class Recorder(object):
    def __init__(self, name='studio_recording', launch='office'):
        self.name = name
        self.launch = launch
        self.on = False
        self.t0 = 0.0
        self.actions = []        # [(at, action dict)] in the order carried out
        self.expects = []        # expectation entries (assert mode)

    def start(self, sim_time):
        """Recording on from ``sim_time`` (a new recording: the old actions go)."""
        self.on = True
        self.t0 = float(sim_time)
        self.actions = []
        self.expects = []

    def stop(self):
        self.on = False

    def add(self, cmd, sim_time, display_size=None):
        """Record Command ``cmd`` carried out at ``sim_time``; ``display_size``: (width,
        height) px of the touched display (touch). Returns the timeline entry or None."""
        if not self.on:
            return None
        f = cmd.fields
        if cmd.op == 'set_pose':
            a = {'action': 'set_model_state', 'model': f['model'], 'position': f['position'],
                 'rpy': f['rpy']}
        elif cmd.op == 'touch':
            w, h = display_size
            a = {'action': 'touch', 'ns': f['model'], 'x': round(f['x'] * w, 3),
                 'y': round(f['y'] * h, 3), 'duration': f['duration']}
        elif cmd.op == 'press_button':
            a = {'action': 'press_button', 'ns': f['model'], 'button': f['button'],
                 'duration': f['duration']}
        elif cmd.op == 'set_environment':
            a = {'action': 'set_environment', 'values': dict(sorted(f['values'].items()))}
        elif cmd.op == 'fault':
            a = {'action': 'fault', 'model': f['model'], 'sensor': f['sensor'],
                 'fault': f['fault']}
            if f['value']:
                a['value'] = f['value']
        else:
            return None
        return self.add_action(a, sim_time)

    def add_action(self, a, sim_time):
        """Record the runner's action ``a`` (a dict with ``action``) carried out at
        ``sim_time`` (an extension's op, e.g. a walk); the timeline entry, or None while
        recording is off."""
        if not self.on:
            return None
        at = max(0.0, round(float(sim_time) - self.t0, 3))
        last = self.actions[-1] if self.actions else None
        if last is not None and last['at'] == at and a['action'] == 'set_model_state' and \
                last['action'] == 'set_model_state' and last['model'] == a['model']:
            # a drag while the world is paused (or several poses in one step): the pose
            # at that sim time is the last one
            last.update(a)
            return last
        entry = dict({'id': 'a%d' % (len(self.actions) + 1), 'at': at}, **a)
        self.actions.append(entry)
        return entry

    def expect(self, f):
        """Add the expectation of an ``expect`` command's fields; returns its entry."""
        base = re.sub(r'\W+', '_', f['field']).strip('_') or 'value'
        check = {'equals': {'equals': f['target']},
                 'near': {'near': f['target'], 'tol': f['tol']},
                 'between': {'between': [f['lo'], f['hi']]}}[f['check']]
        e = {'topic': f['topic'], 'field': f['field'], f['mode']: check}
        if f['start'] is not None:
            e['window'] = [f['start'], f['end']]
        return self.add_expect(e, f['name'] or base)

    def add_expect(self, entry, name):
        """Add the runner's expectation ``entry`` (a dict without its name; an extension's,
        e.g. a decoded barcode) named ``name``, or ``name_2``... when that is taken;
        returns it with its name first."""
        names = {e['name'] for e in self.expects}
        unique, i = name, 1
        while unique in names:
            i += 1
            unique = '%s_%d' % (name, i)
        e = dict({'name': unique}, **entry)
        self.expects.append(e)
        return e

    def duration(self):
        last = max([e['at'] for e in self.actions] +
                   [e['window'][1] - MARGIN for e in self.expects if 'window' in e] or [0.0])
        return round(last + MARGIN, 3)

    def yaml(self):
        """The recording as a scenario file's text (the examples' flow style)."""
        lines = ['# recorded by the studio (rosrun mobile_device_sim studio): each action at',
                 '# the sim time it happened, counted from the start of the recording',
                 'name: %s' % self.name,
                 'description: recorded in the studio',
                 'real_time_factor: 0',
                 'duration: %s' % _num(self.duration()),
                 'world:',
                 '  launch: %s' % self.launch]
        if self.actions:
            lines.append('timeline:')
            lines += ['  - %s' % _flow(e) for e in self.actions]
        else:
            lines.append('timeline: []')
        if self.expects:
            lines.append('expect:')
            lines += ['  - %s' % _flow(e) for e in self.expects]
        else:
            lines.append('expect: []')
        return '\n'.join(lines) + '\n'


def check(text, path='studio.yaml'):
    """The validator's problems of scenario text, 'FILE:LINE: where: what' ([] = valid):
    testing_instance.scenario.format.loads, as run_scenario --check."""
    from testing_instance.scenario.format import ScenarioError, loads
    try:
        loads(text, path)
    except ScenarioError as e:
        return list(e.problems)
    return []
