"""Sweeps: expand scenario files into concrete runs, run them (a local farm or a Ray
cluster), and summarise where it breaks (issue 21).

    run_scenario FILE... --sweep [--jobs N | --cluster ADDRESS|auto] [--set NAME=VALUE]
        [--max-runs N] [--out DIR] [--junit DIR] [--json FILE] [--record DIR] [--shard I/N]

Every concrete run is one ``run_scenario FILE --set NAME=VALUE... --seed N`` process with its
own master port; that command, printed for each failing run, reproduces it alone.

Folder layout (local farm and cluster alike): ``--junit DIR``: DIR/<run>.xml per run and
DIR/sweep.xml (one test case per run, named after its parameter values); ``--record DIR``:
DIR/<run>.bag; ``--out DIR``: DIR/summary.txt, DIR/summary.json, DIR/sweep.xml and
DIR/logs/<run>.txt (each run's report).
"""
import json
import os
import re
import shlex
import sys
import time
import xml.etree.ElementTree as ET

from ..scenario import params as P
from ..scenario import format as S
from ..scenario.format import ScenarioError

__all__ = ['Run', 'plan', 'run_local', 'summarise', 'write_outputs', 'main', 'NODE',
           'verdict_lines', 'run_command']

NODE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..',
                                    '..', 'nodes', 'run_scenario'))   # testing_instance/nodes
EXIT_PASS, EXIT_FAIL, EXIT_ERROR = 0, 1, 2
STATUS = {EXIT_PASS: 'PASS', EXIT_FAIL: 'FAIL'}
_VERDICT = re.compile(r'^(PASS|FAIL|ERROR) (\w+): ', re.M)


def _safe(text):
    return re.sub(r'[^A-Za-z0-9_.=+-]+', '_', text).strip('_')


class Run(object):
    """One concrete run: a scenario file with parameter values and a seed."""

    def __init__(self, path, scenario, variant, seed, seed_override=None):
        self.path = path
        self.scenario = scenario
        self.variant = variant
        self.values = variant.values
        self.seed = seed
        self.seed_override = seed_override

    @property
    def label(self):
        return self.variant.label

    @property
    def name(self):
        """The run's name: scenario[heading=30,seed=2]."""
        return '%s[%s]' % (self.scenario, self.label) if self.values else self.scenario

    @property
    def id(self):
        """A file name for the run's outputs: scenario-heading=30-seed=2."""
        return _safe(self.scenario + ''.join('-%s=%s' % (k, P.format_value(v))
                                             for k, v in self.values.items()))

    def args(self):
        out = []
        for k, v in self.values.items():
            out += ['--set', '%s=%s' % (k, P.format_value(v))]
        return out + ['--seed', str(self.seed)]

    def reproduce(self):
        return 'rosrun mobile_device_sim run_scenario %s' % ' '.join(
            shlex.quote(x) for x in [os.path.relpath(self.path)] + self.args())


def plan(files, sweep=True, sets=(), max_runs=None, seed=None):
    """The concrete runs of the files (all problems raised as one ScenarioError)."""
    runs, problems = [], []
    for path in files:
        try:
            data = P.load_raw(path)
            params = P.declared(data, path) if isinstance(data, dict) else {}
            pinned = P.parse_set(sets, params, path) if sets else {}
            variants = S.expand(data, path, pinned, max_runs, sweep=sweep)
        except ScenarioError as e:
            problems += e.problems
            continue
        name = data.get('name') if isinstance(data.get('name'), str) else \
            os.path.splitext(os.path.basename(path))[0]
        for v in variants:
            s = seed
            if s is None:
                s = P.concrete(data, path, v.values).get('seed', 0)
            runs.append(Run(path, name, v, int(s), seed))
            runs[-1].order = len(runs) - 1
    if problems:
        raise ScenarioError(problems)
    return runs


def run_command(run, junit=None, record=None, rtf=None, python=None, report=None):
    cmd = [python or sys.executable, NODE, os.path.abspath(run.path)] + run.args()
    if rtf is not None:
        cmd += ['--real-time-factor', str(rtf)]
    if report:
        cmd += ['--report', report]
    if junit:
        cmd += ['--junit', junit]
    if record:
        cmd += ['--record', record]
    return cmd


def run_env():
    env = dict(os.environ)
    env.pop('ROS_MASTER_URI', None)      # each run starts its own master on a free port
    env.setdefault('ROS_HOSTNAME', 'localhost')
    return env


def verdict_lines(text):
    """The PASS/FAIL/ERROR lines of a run's output."""
    return [ln for ln in text.splitlines() if ln.split(' ', 1)[0] in ('PASS', 'FAIL', 'ERROR')]


def result(run, rc, text, wall, node='local', attempts=1):
    status = STATUS.get(rc, 'ERROR')
    return {'run': run, 'name': run.name, 'id': run.id, 'file': run.path,
            'scenario': run.scenario, 'values': dict(run.values), 'seed': run.seed,
            'status': status, 'exit_code': rc, 'wall': round(wall, 3), 'node': node,
            'attempts': attempts, 'retried': attempts > 1, 'output': text,
            'verdicts': [{'name': m.group(2), 'status': m.group(1)}
                         for m in _VERDICT.finditer(text)],
            'lines': verdict_lines(text), 'reproduce': run.reproduce()}


class Layout(object):
    """Where a sweep's files go (the same for a local farm and a cluster)."""

    def __init__(self, junit=None, record=None, out=None, json_path=None, report=None):
        self.junit, self.record, self.out, self.json = junit, record, out, json_path
        self.report = report
        for d in (junit, record, out, report):
            if d:
                os.makedirs(d, exist_ok=True)

    def junit_of(self, run):
        return os.path.join(self.junit, run.id + '.xml') if self.junit else None

    def bag_of(self, run):
        return os.path.join(self.record, run.id + '.bag') if self.record else None

    def report_of(self, run):
        """``--report DIR``: DIR/<run>/index.html per run, DIR/index.html for the sweep."""
        return os.path.join(self.report, run.id) if self.report else None

    def write_index(self, results, wall, out):
        """The farm index page over the runs' reports (nothing without --report)."""
        if not self.report:
            return
        from ..report import write_farm_index
        write_farm_index(self.report, [dict(name=r['name'], status=r['status'], wall=r['wall'],
                                            report=self.report_of(r['run'])) for r in results],
                         wall, out)

    def log_of(self, run):
        if not self.out:
            return None
        os.makedirs(os.path.join(self.out, 'logs'), exist_ok=True)
        return os.path.join(self.out, 'logs', run.id + '.txt')


def run_local(runs, jobs, layout, rtf=None, out=print, warm=True):
    """The runs ``jobs`` at a time (testing_instance.farm.warm.Pool: warm worlds; ``warm=False``
    each in its own run_scenario process and master)."""
    from .warm import Pool
    results = []

    def done(r, rc, text, wall):
        res = result(r, rc, text, wall)
        finished(res, layout, out)
        results.append(res)
    items = [(r, run_command(r, layout.junit_of(r), layout.bag_of(r), rtf,
                             report=layout.report_of(r))[2:]) for r in runs]
    pool = Pool(jobs, warm=warm, env=run_env())
    pool.run(items, done)
    for note in pool.notes:           # a worker's last run's app it had to SIGKILL
        out(note)
    return results


def finished(res, layout, out):
    """Print a finished run's verdict lines and keep its report."""
    log = layout.log_of(res['run'])
    if log:
        with open(log, 'w') as f:
            f.write(res['output'])
    out('%s %s%s' % (res['status'], res['name'], ' (attempt %d)' % res['attempts']
                     if res['retried'] else ''))
    if res['status'] != 'PASS':
        for ln in res['lines'] or res['output'].splitlines()[-5:]:
            out('    ' + ln)


def _pct(k, n):
    return 100.0 * k / n if n else 0.0


def summarise(results, wall=None, mode='local'):
    """The summary as a JSON-able dict (runs in plan order)."""
    results = sorted(results, key=lambda r: getattr(r['run'], 'order', 0))
    n = len(results)
    count = {s: sum(1 for r in results if r['status'] == s) for s in ('PASS', 'FAIL', 'ERROR')}
    per = {}
    for r in results:
        for k, v in r['values'].items():
            d = per.setdefault(k, {}).setdefault(P.format_value(v), {'runs': 0, 'passed': 0})
            d['runs'] += 1
            d['passed'] += r['status'] == 'PASS'
    for k, vals in per.items():
        for v, d in vals.items():
            d['pass_rate'] = round(d['passed'] / d['runs'], 4)
    runs = [{k: v for k, v in r.items() if k not in ('run', 'output')} for r in results]
    return {'runs': runs, 'total': n, 'passed': count['PASS'], 'failed': count['FAIL'],
            'errors': count['ERROR'], 'pass_rate': round(count['PASS'] / n, 4) if n else 0.0,
            'per_parameter': per, 'retried': [r['name'] for r in results if r['retried']],
            'nodes': sorted({r['node'] for r in results}), 'mode': mode,
            'wall': round(wall, 3) if wall is not None else None}


def text(summary):
    """The summary table a person reads."""
    out = []
    runs = summary['runs']
    w = max([len(r['name']) for r in runs] + [3])
    out.append('%-*s %-6s %8s %-10s %s' % (w, 'run', 'result', 'wall s', 'node', 'expectations'))
    for r in runs:
        npass = sum(1 for v in r['verdicts'] if v['status'] == 'PASS')
        out.append('%-*s %-6s %8.1f %-10s %d/%d passed%s' % (
            w, r['name'], r['status'], r['wall'], r['node'][:10], npass, len(r['verdicts']),
            ' (retried: %d attempts)' % r['attempts'] if r['retried'] else ''))
    out.append('')
    out.append('%d runs: %d passed, %d failed, %d errors; pass rate %.1f %%%s' % (
        summary['total'], summary['passed'], summary['failed'], summary['errors'],
        100.0 * summary['pass_rate'], ' (%d nodes)' % len(summary['nodes'])
        if summary['mode'] == 'cluster' else ''))
    if summary['per_parameter']:
        out.append('pass rate per parameter value:')
        for k, vals in summary['per_parameter'].items():
            cells = ['%s: %d/%d (%.0f %%)' % (v, d['passed'], d['runs'],
                                              100.0 * d['pass_rate']) for v, d in vals.items()]
            out.append('  %s  %s' % (k, '   '.join(cells)))
    bad = [r for r in runs if r['status'] != 'PASS']
    if bad:
        out.append('failing runs (each command reproduces one alone):')
        for r in bad:
            out.append('  %s %s' % (r['status'], r['name']))
            out.append('    ' + r['reproduce'])
            for ln in r['lines']:
                if not ln.startswith('PASS'):
                    out.append('      ' + ln)
    if summary['retried']:
        out.append('retried after a node died (counted once): %s' % ', '.join(
            summary['retried']))
    else:
        out.append('retried: none')
    if summary.get('wall'):
        out.append('%d runs in %.1f s wall (%.1f runs/minute)' % (
            summary['total'], summary['wall'], 60.0 * summary['total'] / summary['wall']))
    return out


def junit(summary, path):
    """One test suite, one test case per concrete run named after its parameter values."""
    suite = ET.Element('testsuite', name='sweep', tests=str(summary['total']),
                       failures=str(summary['failed']), errors=str(summary['errors']),
                       time='%.3f' % sum(r['wall'] for r in summary['runs']))
    for r in summary['runs']:
        tc = ET.SubElement(suite, 'testcase', classname='sweep.%s' % r['scenario'],
                           name=P.run_label(r['values']) or r['scenario'],
                           time='%.3f' % r['wall'])
        msg = '\n'.join(ln for ln in r['lines'] if not ln.startswith('PASS'))
        body = msg + '\nreproduce: ' + r['reproduce']
        if r['status'] == 'FAIL':
            ET.SubElement(tc, 'failure', message=msg.split('\n')[0]).text = body
        elif r['status'] == 'ERROR':
            ET.SubElement(tc, 'error', message=(msg or 'error').split('\n')[0]).text = body
        ET.SubElement(tc, 'system-out').text = '\n'.join(r['lines'])
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    ET.ElementTree(suite).write(path, encoding='utf-8', xml_declaration=True)


def write_outputs(summary, layout):
    lines = text(summary)
    if layout.out:
        with open(os.path.join(layout.out, 'summary.txt'), 'w') as f:
            f.write('\n'.join(lines) + '\n')
        with open(os.path.join(layout.out, 'summary.json'), 'w') as f:
            json.dump(summary, f, indent=1, sort_keys=True)
        junit(summary, os.path.join(layout.out, 'sweep.xml'))
    if layout.junit:
        junit(summary, os.path.join(layout.junit, 'sweep.xml'))
    if layout.json:
        d = os.path.dirname(os.path.abspath(layout.json))
        os.makedirs(d, exist_ok=True)
        with open(layout.json, 'w') as f:
            json.dump(summary, f, indent=1, sort_keys=True)
    return lines


def shard(items, spec):
    """``--shard I/N``: every N-th item from the I-th (0-based), in the order given (the
    farm sorts its files first; a sweep keeps its plan order)."""
    try:
        i, n = (int(x) for x in spec.split('/'))
        if not 0 <= i < n:
            raise ValueError
    except ValueError:
        raise SystemExit('--shard must be I/N with 0 <= I < N, got %r' % spec)
    return [x for k, x in enumerate(items) if k % n == i]


def main(files, a, out=print, remote=None):
    """run_scenario --sweep / --cluster: plan, run, summarise. Exit: the worst run's.
    ``remote``: with --cluster, the function that runs the plan on the cluster
    (``cluster.run_cluster``, given by the command line; a RuntimeError from it is one
    ERROR line, exit 2); this module does not import the cluster module."""
    try:
        runs = plan(files, sweep=a.sweep, sets=a.set or (), max_runs=a.max_runs, seed=a.seed)
    except ScenarioError as e:
        out('ERROR the sweep cannot start:')
        for p in e.problems:
            out('  ' + p)
        return EXIT_ERROR
    if a.shard:
        runs = shard(runs, a.shard)
    if not runs:
        out('ERROR no runs')
        return EXIT_ERROR
    layout = Layout(a.junit, a.record, getattr(a, 'out', None), getattr(a, 'json', None),
                    getattr(a, 'report', None))
    t0 = time.monotonic()
    if a.cluster:
        try:
            results = remote(runs, a.cluster, layout, rtf=a.rtf, cpus=a.cpus_per_run, out=out)
        except RuntimeError as e:      # cluster.ClusterError: unreachable, no Ray, ...
            out('ERROR %s' % e)
            return EXIT_ERROR
        mode = 'cluster'
    else:
        out('%d runs, %d at a time' % (len(runs), max(1, a.jobs)))
        results = run_local(runs, max(1, a.jobs), layout, rtf=a.rtf, out=out,
                            warm=not getattr(a, 'cold', False))
        mode = 'local'
    summary = summarise(results, time.monotonic() - t0, mode)
    out('')
    for ln in write_outputs(summary, layout):
        out(ln)
    layout.write_index(results, time.monotonic() - t0, out)
    return max([EXIT_PASS] + [r['exit_code'] if r['exit_code'] in (0, 1) else EXIT_ERROR
                              for r in summary['runs']])
