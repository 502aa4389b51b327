"""Scenario parameters and sweeps (issue 21).

A scenario may declare named parameters with defaults and reference them as ``${name}``
anywhere in the file (positions, rpy, environment values, seeds, world/xacro args,
expectation thresholds). A value that is exactly ``${...}`` takes the parameter's type
(number, bool, list, string); ``${...}`` inside a longer string is replaced by the value's
text. The braces may hold a small arithmetic expression over the parameters:
``${radians(heading) + 1.5708}``, ``${(338.5 - heading) % 360}`` (+ - * / // % **, and
the functions in FUNCTIONS).

A ``sweep:`` block gives the distributions of some parameters (OpenSCENARIO 1.x's
deterministic and stochastic parameter value distributions)::

    parameters: {heading: 0, seed: 4, noise: 0.0}
    sweep:
      max_runs: 20000                 # optional: raise the limit (default 10000)
      cartesian:                      # every combination (the default for a plain mapping)
        heading: {range: [0, 330, 30]}        # start, stop (inclusive), step
        seed: [1, 2]                          # a value set
      # zip: {a: [1, 2], b: [10, 20]}         # element by element (same lengths)
      # noise: {uniform: [0, 0.1], count: 5, seed: 7}     # stochastic draws, reproducible
      # noise: {normal: [0, 0.05], count: 5, seed: 7}     # (round: digits, default 6)
      # seed: {randint: [0, 1000], count: 5, seed: 1}

``cartesian`` and ``zip`` take a mapping of parameter -> distribution, or a list of nested
blocks (each a mapping, a ``cartesian:`` or a ``zip:``). Every problem is reported as
``FILE:LINE: where: what`` before anything starts: an unknown ``${name}``, an expression
that cannot be evaluated, a type that does not fit once substituted (the scenario validator
then runs on every concrete run), an empty distribution, zipped lists of different lengths,
a sweep larger than the limit (with the count).
"""
import ast
import itertools
import math
import operator
import random
import re

import yaml

from .yamlsrc import LDict, LList, ScenarioError
from .yamlsrc import close_match as _close
from .yamlsrc import line_of as _line
from .yamlsrc import read as load_raw  # noqa: F401 - the parsed file with line numbers
from .yamlsrc import show as _show

__all__ = ['MAX_RUNS', 'FUNCTIONS', 'declared', 'concrete', 'expand', 'parse_set',
           'format_value', 'run_label', 'Variant']

MAX_RUNS = 10000
FUNCTIONS = {
    'radians': math.radians, 'degrees': math.degrees, 'sin': math.sin, 'cos': math.cos,
    'tan': math.tan, 'atan2': math.atan2, 'sqrt': math.sqrt, 'abs': abs, 'min': min,
    'max': max, 'round': round, 'int': int, 'float': float, 'str': str,
}
CONSTANTS = {'pi': math.pi}
_REF = re.compile(r'\$\{([^{}]*)\}')
_NAME = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*$')
_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod,
           ast.Pow: operator.pow}
_UNOPS = {ast.USub: operator.neg, ast.UAdd: operator.pos}
KEYS = ('parameters', 'sweep')
DISTRIBUTIONS = ('values', 'range', 'uniform', 'normal', 'randint')


class _Unknown(Exception):
    pass


def format_value(v):
    """The text of a parameter value in run names and --set arguments (round-trips)."""
    if isinstance(v, bool):
        return 'true' if v else 'false'
    if isinstance(v, float):
        if v == int(v) and abs(v) < 1e15:
            return '%d.0' % v
        return repr(v)
    if isinstance(v, (list, tuple)):
        return '[%s]' % ','.join(format_value(x) for x in v)
    return str(v)


def run_label(values):
    """'heading=30,seed=2' of the swept values (in their order)."""
    return ','.join('%s=%s' % (k, format_value(v)) for k, v in values.items())


# -- expressions ---------------------------------------------------------------------------
def _eval(expr, values):
    tree = ast.parse(expr.strip(), mode='eval')

    def ev(n):
        if isinstance(n, ast.Expression):
            return ev(n.body)
        if isinstance(n, ast.Constant) and isinstance(n.value, (int, float, str, bool)):
            return n.value
        if isinstance(n, ast.Name):
            if n.id in values:
                return values[n.id]
            if n.id in CONSTANTS:
                return CONSTANTS[n.id]
            raise _Unknown(n.id)
        if isinstance(n, ast.BinOp) and type(n.op) in _BINOPS:
            return _BINOPS[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp) and type(n.op) in _UNOPS:
            return _UNOPS[type(n.op)](ev(n.operand))
        if isinstance(n, (ast.List, ast.Tuple)):
            return [ev(e) for e in n.elts]
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and not n.keywords \
                and n.func.id in FUNCTIONS:
            return FUNCTIONS[n.func.id](*[ev(a) for a in n.args])
        raise ValueError('only numbers, parameters, + - * / // %% **, ( ) and the '
                         'functions %s are allowed' % ', '.join(sorted(FUNCTIONS)))
    v = ev(tree)
    if isinstance(v, float) and not math.isfinite(v):
        raise ValueError('the result is %r' % v)
    return v


def _subst_str(s, values, err):
    """The value of a string with ${...} references (err(text) reports a problem)."""
    m = _REF.fullmatch(s.strip())
    refs = list(_REF.finditer(s))
    if not refs:
        if '${' in s:
            err('unclosed ${ in %s' % _show(s))
        return s

    def one(expr):
        try:
            return _eval(expr, values)
        except _Unknown as e:
            err('unknown parameter %r in %s%s; declared: %s' % (
                str(e), _show(s), _close(str(e), values), ', '.join(sorted(values)) or
                'none (add a parameters: block)'))
        except SyntaxError:
            err('cannot read the expression ${%s}' % expr)
        except (ValueError, TypeError, ArithmeticError) as e:
            err('cannot evaluate ${%s}: %s' % (expr, e))
        return None
    if m:
        return one(m.group(1))
    out = []
    pos = 0
    for r in refs:
        out.append(s[pos:r.start()])
        v = one(r.group(1))
        out.append('' if v is None else format_value(v) if not isinstance(v, str) else v)
        pos = r.end()
    out.append(s[pos:])
    return ''.join(out)


def _substitute(obj, values, err, where, line):
    """A copy of obj with every ${...} replaced; LDict/LList keep their line numbers."""
    if isinstance(obj, dict):
        d = LDict()
        d.line = getattr(obj, 'line', line)
        d.key_lines = dict(getattr(obj, 'key_lines', None) or {})
        for k, v in obj.items():
            d[k] = _substitute(v, values, err, '%s.%s' % (where, k) if where else str(k),
                               _line(obj, k, line))
        return d
    if isinstance(obj, list):
        lst = LList(_substitute(v, values, err, '%s[%d]' % (where, i), _line(obj, i, line))
                    for i, v in enumerate(obj))
        lst.line = getattr(obj, 'line', line)
        lst.item_lines = list(getattr(obj, 'item_lines', None) or [])
        return lst
    if isinstance(obj, str) and '${' in obj:
        return _subst_str(obj, values, lambda text: err(line, where, text))
    return obj


# -- declarations -----------------------------------------------------------------------------
class _Problems(object):
    def __init__(self, path):
        self.path = path
        self.items = []

    def err(self, line, where, text):
        self.items.append('%s:%d: %s: %s' % (self.path, line, where, text))

    def check(self):
        if self.items:
            raise ScenarioError(self.items)


def declared(data, path='<scenario>', problems=None):
    """{name: default} of the parameters: block (problems reported with file:line)."""
    p = problems or _Problems(path)
    block = data.get('parameters') if isinstance(data, dict) else None
    out = {}
    if block is None:
        if problems is None:
            p.check()
        return out
    line = _line(data, 'parameters')
    if not isinstance(block, dict):
        p.err(line, 'parameters', 'expected a mapping of name: default value, got %s'
              % _show(block))
    else:
        for k, v in block.items():
            kl = _line(block, k, line)
            if not isinstance(k, str) or not _NAME.match(k):
                p.err(kl, 'parameters.%s' % k, 'a parameter name is a word (letters, digits, '
                      '_; not starting with a digit), got %r' % (k,))
            elif k in FUNCTIONS or k in CONSTANTS:
                p.err(kl, 'parameters.%s' % k, 'the name %r is taken by a function or '
                      'constant of the expressions' % k)
            elif v is None or isinstance(v, dict):
                p.err(kl, 'parameters.%s' % k, 'expected a default value (a number, string, '
                      'true/false or a list), got %s' % _show(v))
            elif isinstance(v, str) and '${' in v:
                p.err(kl, 'parameters.%s' % k, 'a default cannot reference parameters')
            else:
                out[k] = v
    if problems is None:
        p.check()
    return out


def parse_set(items, params, path='<scenario>'):
    """{name: value} of --set NAME=VALUE arguments (values read as YAML: 30, 1.5, true,
    [1, 2], text); a name not declared is an error."""
    out = {}
    problems = []
    for it in items or ():
        name, eq, text = it.partition('=')
        name = name.strip()
        if not eq or not name:
            problems.append('%s: --set %s: expected NAME=VALUE' % (path, it))
            continue
        if name not in params:
            problems.append('%s: --set %s: no parameter %r%s; declared: %s' % (
                path, it, name, _close(name, params), ', '.join(sorted(params)) or 'none'))
            continue
        try:
            v = yaml.safe_load(text) if text.strip() else ''
        except yaml.YAMLError:
            v = text
        if isinstance(v, dict) or v is None:
            v = text
        out[name] = v
    if problems:
        raise ScenarioError(problems)
    return out


def concrete(data, path='<scenario>', values=None):
    """The scenario data with every ${...} substituted (parameters: and sweep: removed):
    the defaults, overridden by ``values`` ({name: value}). Raises ScenarioError."""
    if not isinstance(data, dict):
        return data
    p = _Problems(path)
    params = declared(data, path, p)
    for k in values or {}:
        if k not in params and 'parameters' in data:
            p.err(_line(data, 'parameters'), 'parameters', 'no parameter %r%s (declared: %s)'
                  % (k, _close(k, params), ', '.join(sorted(params))))
    params.update(values or {})
    body = LDict()
    body.line = getattr(data, 'line', 1)
    body.key_lines = {k: v for k, v in (getattr(data, 'key_lines', None) or {}).items()
                      if k not in KEYS}
    for k, v in data.items():
        if k not in KEYS:
            body[k] = v
    if 'sweep' in data and 'parameters' not in data:
        p.err(_line(data, 'sweep'), 'sweep', 'a sweep needs a parameters: block (name: '
              'default) for the parameters it varies')
    out = _substitute(body, params, p.err, '', body.line)
    p.check()
    out.param_values = params
    return out


# -- sweeps -------------------------------------------------------------------------------
class _Node(object):
    """names: the parameters it sets; count: its number of combinations; rows(): them."""

    def __init__(self, names, count, rows):
        self.names = names
        self.count = count
        self.rows = rows


def _num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _leaf(p, name, dist, where, line, limit):
    def bad(text):
        p.err(line, where, text)
        return None
    if isinstance(dist, list):
        if not dist:
            return bad('empty value set (expected at least one value)')
        vals = list(dist)
        return _Node([name], len(vals), lambda: [(v,) for v in vals])
    if not isinstance(dist, dict):
        return bad('expected a list of values or a distribution ({%s}), got %s' % (
            ', '.join(DISTRIBUTIONS), _show(dist)))
    kinds = [k for k in DISTRIBUTIONS if k in dist]
    if len(kinds) != 1:
        return bad('expected exactly one of %s%s' % (', '.join(DISTRIBUTIONS), ', got %s' % (
            ' and '.join(kinds)) if kinds else ', got %s' % _show(dict(dist))))
    kind = kinds[0]
    allowed = {kind}
    if kind in ('uniform', 'normal', 'randint'):
        allowed |= {'count', 'seed', 'round'}
    for k in dist:
        if k not in allowed:
            p.err(_line(dist, k, line), '%s.%s' % (where, k), 'unknown key%s; expected %s' % (
                _close(k, allowed), ', '.join(sorted(allowed))))
    arg = dist[kind]
    al = _line(dist, kind, line)
    if kind == 'values':
        if not isinstance(arg, list) or not arg:
            return bad('empty value set (expected a non-empty list)') if isinstance(
                arg, list) else bad('values: expected a list, got %s' % _show(arg))
        vals = list(arg)
        return _Node([name], len(vals), lambda: [(v,) for v in vals])
    if kind == 'range':
        if not isinstance(arg, list) or len(arg) != 3 or not all(map(_num, arg)):
            p.err(al, where + '.range', 'expected [start, stop, step] (numbers), got %s'
                  % _show(arg))
            return None
        start, stop, step = arg
        if step == 0:
            p.err(al, where + '.range', 'the step is 0')
            return None
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n <= 0:
            p.err(al, where + '.range', 'empty distribution: from %s to %s by %s gives no '
                  'value' % (start, stop, step))
            return None
        if n > limit:
            p.err(al, where + '.range', 'expands to %d values, more than the limit of %d '
                  '(raise it with --max-runs N or sweep.max_runs)' % (n, limit))
            return None
        ints = all(isinstance(x, int) for x in arg)

        def rows():
            out = []
            for i in range(n):
                v = start + i * step
                out.append((v if ints else round(v, 9),))
            return out
        return _Node([name], n, rows)
    # stochastic
    ok = isinstance(arg, list) and len(arg) == 2 and all(map(_num, arg))
    if not ok:
        p.err(al, '%s.%s' % (where, kind), 'expected %s, got %s' % (
            {'normal': '[mean, standard deviation]'}.get(kind, '[low, high]'), _show(arg)))
        return None
    count, seed, digits = dist.get('count'), dist.get('seed'), dist.get('round', 6)
    good = True
    if not (isinstance(count, int) and not isinstance(count, bool)):
        p.err(_line(dist, 'count', line), where + '.count', 'a %s distribution needs count: '
              'the number of draws (a whole number > 0), got %s' % (kind, _show(count)))
        good = False
    elif count <= 0:
        p.err(_line(dist, 'count', line), where + '.count', 'empty distribution: count %d'
              % count)
        good = False
    elif count > limit:
        p.err(_line(dist, 'count', line), where + '.count', '%d draws, more than the limit '
              'of %d (raise it with --max-runs N or sweep.max_runs)' % (count, limit))
        good = False
    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        p.err(_line(dist, 'seed', line), where + '.seed', 'a %s distribution needs seed: a '
              'whole number >= 0 (the same seed gives the same draws), got %s' % (
                  kind, _show(seed)))
        good = False
    if not (isinstance(digits, int) and not isinstance(digits, bool) and 0 <= digits <= 15):
        p.err(_line(dist, 'round', line), where + '.round', 'expected a number of decimal '
              'digits 0..15, got %s' % _show(digits))
        good = False
    a, b = arg
    if kind == 'normal' and b < 0:
        p.err(al, where + '.normal', 'the standard deviation is negative (%s)' % b)
        good = False
    if kind in ('uniform', 'randint') and b < a:
        p.err(al, '%s.%s' % (where, kind), 'empty distribution: low %s > high %s' % (a, b))
        good = False
    if kind == 'randint' and not all(isinstance(x, int) for x in arg):
        p.err(al, where + '.randint', 'expected whole numbers [low, high], got %s' % _show(arg))
        good = False
    if not good:
        return None

    def draws():
        rng = random.Random(seed)
        out = []
        for _ in range(count):
            if kind == 'uniform':
                v = round(rng.uniform(a, b), digits)
            elif kind == 'normal':
                v = round(rng.normalvariate(a, b), digits)
            else:
                v = rng.randint(a, b)
            out.append((v,))
        return out
    return _Node([name], count, draws)


def _combine(p, how, children, where, line, limit):
    names = []
    for c in children:
        for n in c.names:
            if n in names:
                p.err(line, where, 'parameter %r is swept twice' % n)
                return None
            names.append(n)
    if how == 'zip':
        counts = [c.count for c in children]
        if len(set(counts)) > 1:
            p.err(line, where, 'zip needs distributions of the same length, got %s' % ', '.join(
                '%s: %d' % ('/'.join(c.names), c.count) for c in children))
            return None
        n = counts[0] if counts else 0
        return _Node(names, n, lambda: [sum(r, ()) for r in zip(*[c.rows() for c in children])])
    n = 1
    for c in children:
        n *= c.count
    return _Node(names, n, lambda: [sum(r, ()) for r in itertools.product(
        *[c.rows() for c in children])])


def _block(p, obj, params, where, line, limit, how='cartesian'):
    """A mapping {param: dist} or {cartesian|zip: ...} or a list of such blocks."""
    if isinstance(obj, list):
        if not obj:
            p.err(line, where, 'empty list of blocks')
            return None
        kids = [_block(p, b, params, '%s[%d]' % (where, i), _line(obj, i, line), limit)
                for i, b in enumerate(obj)]
        if any(k is None for k in kids):
            return None
        return _combine(p, how, kids, where, line, limit)
    if not isinstance(obj, dict) or not obj:
        p.err(line, where, 'expected a mapping of parameter: distribution (or cartesian: / '
              'zip:), got %s' % _show(obj))
        return None
    combos = [k for k in ('cartesian', 'zip') if k in obj]
    if combos:
        if len(obj) != 1:
            p.err(line, where, 'a %s: block stands alone in its mapping (nest the others in '
                  'it), got keys %s' % (combos[0], ', '.join(map(str, obj))))
            return None
        k = combos[0]
        return _block(p, obj[k], params, '%s.%s' % (where, k), _line(obj, k, line), limit,
                      how=k)
    kids = []
    for name, dist in obj.items():
        nl = _line(obj, name, line)
        if name not in params:
            p.err(nl, '%s.%s' % (where, name), 'unknown parameter%s; declared in '
                  'parameters: %s' % (_close(name, params), ', '.join(sorted(params)) or
                                      'none'))
            kids.append(None)
            continue
        kids.append(_leaf(p, name, dist, '%s.%s' % (where, name), nl, limit))
    if any(k is None for k in kids):
        return None
    return _combine(p, how, kids, where, line, limit)


class Variant(object):
    """One concrete run of a sweep: values = the swept parameters (ordered), all = every
    parameter's value."""

    def __init__(self, index, values, all_values):
        self.index = index
        self.values = values
        self.all = all_values

    @property
    def label(self):
        return run_label(self.values)

    def __repr__(self):
        return 'Variant(%d, %s)' % (self.index, self.label)


def expand(data, path='<scenario>', sets=None, max_runs=None, check=None, sweep=True):
    """The concrete runs of a scenario's sweep (a list of Variant; one, with the defaults,
    when there is no sweep). ``sets``: {name: value} pinned by --set. With ``check`` (a
    validator, scenario.validate: scenario.expand passes it) each concrete run is
    substituted and validated; every problem is raised as ScenarioError with file:line,
    before anything starts."""
    p = _Problems(path)
    params = declared(data, path, p)
    sets = dict(sets or {})
    for k in sets:
        if k not in params:
            p.err(0, '--set', 'no parameter %r%s; declared: %s' % (
                k, _close(k, params), ', '.join(sorted(params)) or 'none'))
    sweep = data.get('sweep') if isinstance(data, dict) and sweep else None
    limit = MAX_RUNS if max_runs is None else int(max_runs)
    if isinstance(sweep, dict) and 'max_runs' in sweep and max_runs is None:
        mr = sweep['max_runs']
        if isinstance(mr, int) and not isinstance(mr, bool) and mr > 0:
            limit = mr
        else:
            p.err(_line(sweep, 'max_runs'), 'sweep.max_runs', 'expected a whole number > 0, '
                  'got %s' % _show(mr))
    node = None
    if sweep is not None:
        sl = _line(data, 'sweep')
        body = sweep
        if isinstance(sweep, dict) and 'max_runs' in sweep:
            body = LDict((k, v) for k, v in sweep.items() if k != 'max_runs')
            body.line = getattr(sweep, 'line', sl)
            body.key_lines = getattr(sweep, 'key_lines', None)
        if isinstance(body, dict) and not body:
            p.err(sl, 'sweep', 'empty sweep (expected parameter: distribution entries)')
        else:
            node = _block(p, body, params, 'sweep', sl, limit)
        if node is not None and node.count > limit:
            p.err(sl, 'sweep', 'expands to %d runs, more than the limit of %d (raise it with '
                  '--max-runs N or sweep.max_runs: N)' % (node.count, limit))
            node = None
        if node is not None and node.count == 0:
            p.err(sl, 'sweep', 'empty distribution: the sweep gives no run')
            node = None
    p.check()
    variants, seen = [], set()
    rows = node.rows() if node is not None else [()]
    names = node.names if node is not None else []
    for row in rows:
        values = dict(zip(names, row))
        values.update({k: v for k, v in sets.items()})
        key = repr(sorted(values.items(), key=lambda kv: kv[0]))
        if key in seen:
            continue
        seen.add(key)
        # the swept names first (in their order), then pinned ones
        ordered = {k: values[k] for k in names}
        ordered.update({k: v for k, v in sets.items() if k not in ordered})
        allv = dict(params)
        allv.update(ordered)
        variants.append(Variant(len(variants), ordered, allv))
    if check:
        problems, seen_p = [], set()
        for v in variants:
            try:
                c = concrete(data, path, v.values)
            except ScenarioError as e:
                errs = e.problems
            else:
                errs = check(c, path)
            for e in errs:
                if e not in seen_p:
                    seen_p.add(e)
                    problems.append(e + (' (run %s)' % v.label if v.values else ''))
            if len(problems) >= 20:
                problems.append('%s: (stopped after 20 problems)' % path)
                break
        if problems:
            raise ScenarioError(problems)
    return variants
