"""Scenario parameters and sweeps (testing_instance.scenario.params, .sweep): substitution, every
kind of distribution, reproducible stochastic draws, the summary, and every bad input's
message with file and line. Synthetic files only; no roscore."""
import json
import os
import types
import xml.etree.ElementTree as ET

import pytest

from testing_instance.scenario import params as P
from testing_instance.scenario import format as scenario
from testing_instance.farm import sweep
from testing_instance.scenario.format import ScenarioError

EX = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(
    __file__)))), 'testing_instance', 'examples')

BODY = """duration: 3.0
phones:
  - {ns: mobile_device, position: [0, '${y}', 1], rpy: [0, 0, '${radians(heading)}']}
timeline:
  - {at: 0.5, action: set_environment, values: {temperature: '${temp}'}}
expect:
  - {name: e, topic: /x, field: data, always: {near: '${(338.5 - heading) % 360}', tol: 8}}
"""


def write(tmp_path, text, name='s.yaml'):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def problems(fn, *a, **kw):
    with pytest.raises(ScenarioError) as e:
        fn(*a, **kw)
    return e.value.problems


def expand_text(tmp_path, text, **kw):
    path = write(tmp_path, text)
    return scenario.expand(P.load_raw(path), path, **kw)


def test_defaults_and_substitution_keep_types(tmp_path):
    path = write(tmp_path, 'parameters: {heading: 90, y: 2.5, temp: 21, s: 7, who: bob}\n'
                 'seed: ${s}\nname: run_${who}_${heading}\n' + BODY)
    sc = scenario.load(path)
    assert sc.seed == 7 and isinstance(sc.seed, int)
    assert sc.name == 'run_bob_90'
    assert sc.phones[0]['position'] == [0, 2.5, 1]
    assert sc.phones[0]['rpy'][2] == pytest.approx(1.5707963, abs=1e-6)
    assert sc.timeline[0]['values'] == {'temperature': 21}
    assert sc.expect[0]['always']['near'] == pytest.approx(248.5)
    assert sc.params == {'heading': 90, 'y': 2.5, 'temp': 21, 's': 7, 'who': 'bob'}
    # values override the defaults
    sc2 = scenario.load(path, values={'heading': 0, 'temp': -5})
    assert sc2.expect[0]['always']['near'] == pytest.approx(338.5)
    assert sc2.timeline[0]['values'] == {'temperature': -5}
    assert sc2.name == 'run_bob_0'


def test_value_sets_ranges_and_cartesian(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY
    vs = expand_text(tmp_path, base + 'sweep:\n  heading: {range: [0, 330, 30]}\n'
                     '  temp: [10, 30]\n')
    assert len(vs) == 24
    assert [v.values for v in vs[:3]] == [{'heading': 0, 'temp': 10}, {'heading': 0, 'temp': 30},
                                          {'heading': 30, 'temp': 10}]
    assert vs[-1].values == {'heading': 330, 'temp': 30}
    assert vs[-1].all == {'heading': 330, 'temp': 30, 'y': 0}
    assert vs[5].label == 'heading=60,temp=30'
    # a float range includes its stop despite rounding; values set
    vs = expand_text(tmp_path, base + 'sweep:\n  y: {range: [0.0, 0.3, 0.1]}\n'
                     '  heading: {values: [0, 90]}\n')
    assert [v.values['y'] for v in vs[::2]] == [0.0, 0.1, 0.2, 0.3]
    # descending range
    vs = expand_text(tmp_path, base + 'sweep: {heading: {range: [90, 0, -45]}}\n')
    assert [v.values['heading'] for v in vs] == [90, 45, 0]


def test_zip_and_nested_combinations(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY
    vs = expand_text(tmp_path, base + 'sweep:\n  zip: {heading: [0, 90, 180], y: [1, 2, 3]}\n')
    assert [(v.values['heading'], v.values['y']) for v in vs] == [(0, 1), (90, 2), (180, 3)]
    vs = expand_text(tmp_path, base + 'sweep:\n  cartesian:\n'
                     '    - zip: {heading: [0, 90], y: [1, 2]}\n    - temp: [5, 6, 7]\n')
    assert len(vs) == 6
    assert vs[0].values == {'heading': 0, 'y': 1, 'temp': 5}
    assert vs[5].values == {'heading': 90, 'y': 2, 'temp': 7}


def test_stochastic_draws_are_reproducible_by_seed(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY

    def draws(dist):
        return [v.values for v in expand_text(tmp_path, base + 'sweep:\n' + dist)]
    u = '  heading: {uniform: [0, 360], count: 5, seed: 3}\n'
    a, b = draws(u), draws(u)
    assert a == b and len(a) == 5
    assert all(0 <= v['heading'] <= 360 for v in a)
    assert len({v['heading'] for v in a}) == 5
    assert draws(u.replace('seed: 3', 'seed: 4')) != a
    n = draws('  temp: {normal: [20, 2], count: 200, seed: 1, round: 3}\n')
    xs = [v['temp'] for v in n]
    assert 19 < sum(xs) / len(xs) < 21 and min(xs) < 18 and max(xs) > 22
    assert all(round(x, 3) == x for x in xs)
    r = draws('  y: {randint: [0, 3], count: 20, seed: 9}\n')
    assert {v['y'] for v in r} <= {0, 1, 2, 3} and all(isinstance(v['y'], int) for v in r)
    assert r == draws('  y: {randint: [0, 3], count: 20, seed: 9}\n')


def test_set_pins_a_parameter_and_parses_types(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY
    assert P.parse_set(['heading=30', 'y=1.5', 'temp=x'], {'heading': 0, 'y': 0, 'temp': 0}) \
        == {'heading': 30, 'y': 1.5, 'temp': 'x'}
    vs = expand_text(tmp_path, base + 'sweep: {heading: [0, 90], temp: [1, 2]}\n',
                     sets={'temp': 2})
    assert [v.values for v in vs] == [{'heading': 0, 'temp': 2}, {'heading': 90, 'temp': 2}]
    msg = problems(P.parse_set, ['hedaing=3'], {'heading': 0}, 'f.yaml')
    assert msg == ["f.yaml: --set hedaing=3: no parameter 'hedaing' (did you mean "
                   "'heading'?); declared: heading"]
    assert problems(P.parse_set, ['heading'], {'heading': 0}, 'f.yaml') == [
        'f.yaml: --set heading: expected NAME=VALUE']


def test_bad_inputs_have_file_and_line(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY   # BODY starts on line 2
    # an unknown ${name}: line of the value, with a suggestion
    path = write(tmp_path, base.replace("'${temp}'", "'${tmep}'"))
    msg = problems(scenario.load, path)
    assert len(msg) == 1
    assert msg[0].startswith(path + ":6: timeline[0].values.temperature: unknown parameter "
                             "'tmep' in '${tmep}' (did you mean 'temp'?); declared: heading, "
                             "temp, y"), msg
    # a type that does not fit once substituted: the scenario validator's message and line,
    # and the run that has it
    path = write(tmp_path, base + 'sweep: {y: [0, abc]}\n')
    msg = problems(scenario.expand, P.load_raw(path), path)
    assert msg == [path + ":4: phones[0].position: expected a list of 3 numbers, got "
                   "[0, 'abc', 1] (run y=abc)"], msg
    # empty distributions
    for dist, text in (('[]', 'empty value set'), ('{range: [0, -1, 1]}',
                                                   'empty distribution: from 0 to -1 by 1'),
                       ('{uniform: [0, 1], count: 0, seed: 1}', 'empty distribution: count 0'),
                       ('{uniform: [2, 1], count: 3, seed: 1}',
                        'empty distribution: low 2 > high 1'),
                       ('{values: []}', 'empty value set'),
                       ('{range: [0, 1, 0]}', 'the step is 0')):
        path = write(tmp_path, base + 'sweep:\n  heading: %s\n' % dist)
        msg = problems(scenario.expand, P.load_raw(path), path)
        assert len(msg) == 1 and ':10: sweep.heading' in msg[0] and text in msg[0], (dist, msg)
    # stochastic draws need a seed and a count
    path = write(tmp_path, base + 'sweep:\n  heading: {normal: [0, 1]}\n')
    msg = problems(scenario.expand, P.load_raw(path), path)
    assert any(':10: sweep.heading.count: a normal distribution needs count' in m for m in msg)
    assert any(':10: sweep.heading.seed: a normal distribution needs seed' in m for m in msg)
    # zip of different lengths, a parameter not declared, one swept twice
    path = write(tmp_path, base + 'sweep:\n  zip: {heading: [1, 2], y: [1, 2, 3]}\n')
    assert problems(scenario.expand, P.load_raw(path), path) == [
        path + ':10: sweep.zip: zip needs distributions of the same length, got heading: 2, '
        'y: 3']
    path = write(tmp_path, base + 'sweep:\n  headng: [1, 2]\n')
    msg = problems(scenario.expand, P.load_raw(path), path)
    assert msg == [path + ":10: sweep.headng: unknown parameter (did you mean 'heading'?); "
                   "declared in parameters: heading, temp, y"]
    path = write(tmp_path, base + 'sweep:\n  cartesian:\n  - {heading: [1]}\n'
                 '  - {heading: [2]}\n')
    assert 'swept twice' in problems(scenario.expand, P.load_raw(path), path)[0]
    # a sweep without parameters, a bad expression, a bad parameter name
    path = write(tmp_path, BODY.replace("'${y}'", '0').replace("'${temp}'", '1').replace(
        "'${radians(heading)}'", '0').replace("'${(338.5 - heading) % 360}'", '1') +
        'sweep: {a: [1]}\n')
    assert path + ':8: sweep: a sweep needs a parameters: block' in problems(
        scenario.load, path)[0]
    path = write(tmp_path, base.replace('${temp}', '${temp +}'))
    assert problems(scenario.load, path) == [
        path + ':6: timeline[0].values.temperature: cannot read the expression ${temp +}']
    path = write(tmp_path, base.replace('${temp}', '${__import__("os")}'))
    assert 'only numbers, parameters' in problems(scenario.load, path)[0]
    path = write(tmp_path, 'parameters: {1x: 0, pi: 2, ok: null}\n' + BODY)
    msg = problems(scenario.load, path)
    assert any(':1: parameters.1x: a parameter name is a word' in m for m in msg), msg
    assert any(":1: parameters.pi: the name 'pi' is taken" in m for m in msg), msg
    assert any(':1: parameters.ok: expected a default value' in m for m in msg), msg


def test_expansion_over_the_limit_is_refused_with_the_count(tmp_path):
    base = 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY
    text = base + ('sweep:\n  heading: {range: [0, 359, 1]}\n  y: {range: [0, 29, 1]}\n')
    path = write(tmp_path, text)
    msg = problems(scenario.expand, P.load_raw(path), path)
    assert msg == [path + ':10: sweep: expands to 10800 runs, more than the limit of 10000 '
                   '(raise it with --max-runs N or sweep.max_runs: N)']
    assert len(P.expand(P.load_raw(path), path, max_runs=20000)) == 10800
    path = write(tmp_path, text.replace('sweep:\n', 'sweep:\n  max_runs: 11000\n'))
    assert len(P.expand(P.load_raw(path), path)) == 10800
    path = write(tmp_path, base + 'sweep:\n  heading: {range: [0, 1000000000, 1]}\n')
    assert 'expands to 1000000001 values, more than the limit of 10000' in problems(
        P.expand, P.load_raw(path), path)[0]


def test_example_sweep_validates_and_names_runs():
    path = os.path.join(EX, 'compass_sweep.yaml')
    runs = sweep.plan([path])
    assert len(runs) == 24
    r = runs[3]
    assert r.name == 'compass_sweep[heading=30,seed=5]' and r.seed == 5
    assert r.id == 'compass_sweep-heading=30-seed=5'
    assert r.reproduce().endswith('compass_sweep.yaml --set heading=30 --set seed=5 --seed 5')
    # the defaults alone without --sweep; an explicit --seed overrides every run's
    one = sweep.plan([path], sweep=False)
    assert len(one) == 1 and one[0].values == {} and one[0].seed == 4
    assert {r.seed for r in sweep.plan([path], seed=9)} == {9}
    assert len(sweep.plan([path], sets=['seed=4'])) == 12


def _fake(run, status, lines, node='n1', attempts=1):
    rc = {'PASS': 0, 'FAIL': 1, 'ERROR': 2}[status]
    return sweep.result(run, rc, '\n'.join(['scenario x: %s' % status] + lines), 1.0, node,
                        attempts)


def test_summary_text_junit_json(tmp_path):
    path = os.path.join(EX, 'compass_sweep.yaml')
    runs = sweep.plan([path])[:4]
    assert [r.label for r in runs] == ['heading=0,seed=4', 'heading=0,seed=5',
                                       'heading=30,seed=4', 'heading=30,seed=5']
    res = [_fake(runs[0], 'PASS', ['PASS a: ok', 'PASS b: ok']),
           _fake(runs[1], 'FAIL', ['PASS a: ok', 'FAIL b: expected 1; actual 2']),
           _fake(runs[2], 'PASS', ['PASS a: ok', 'PASS b: ok'], node='n2', attempts=2),
           _fake(runs[3], 'ERROR', ['ERROR the world stopped answering'])]
    s = sweep.summarise(res, 60.0, 'cluster')
    assert (s['total'], s['passed'], s['failed'], s['errors']) == (4, 2, 1, 1)
    assert s['pass_rate'] == 0.5
    assert s['per_parameter']['seed'] == {'4': {'runs': 2, 'passed': 2, 'pass_rate': 1.0},
                                          '5': {'runs': 2, 'passed': 0, 'pass_rate': 0.0}}
    assert s['per_parameter']['heading']['30']['passed'] == 1
    assert s['retried'] == ['compass_sweep[heading=30,seed=4]']
    assert s['nodes'] == ['n1', 'n2']
    lines = sweep.text(s)
    t = '\n'.join(lines)
    assert '4 runs: 2 passed, 1 failed, 1 errors; pass rate 50.0 % (2 nodes)' in t
    assert '  seed  4: 2/2 (100 %)   5: 0/2 (0 %)' in t
    i = lines.index('  FAIL compass_sweep[heading=0,seed=5]')
    assert lines[i + 1].endswith('compass_sweep.yaml --set heading=0 --set seed=5 --seed 5')
    assert lines[i + 2] == '      FAIL b: expected 1; actual 2'
    assert 'retried after a node died (counted once): compass_sweep[heading=30,seed=4]' in t
    lay = sweep.Layout(junit=str(tmp_path / 'j'), out=str(tmp_path / 'o'),
                       json_path=str(tmp_path / 's.json'))
    sweep.write_outputs(s, lay)
    suite = ET.parse(str(tmp_path / 'j' / 'sweep.xml')).getroot()
    cases = {c.get('name'): c for c in suite.iter('testcase')}
    assert sorted(cases) == ['heading=0,seed=4', 'heading=0,seed=5', 'heading=30,seed=4',
                             'heading=30,seed=5']
    assert cases['heading=0,seed=5'].find('failure') is not None
    assert '--set heading=0 --set seed=5' in cases['heading=0,seed=5'].find('failure').text
    assert cases['heading=30,seed=5'].find('error') is not None
    assert cases['heading=0,seed=4'].find('failure') is None
    assert suite.get('failures') == '1' and suite.get('errors') == '1'
    js = json.loads((tmp_path / 's.json').read_text())
    assert js['runs'][1]['verdicts'] == [{'name': 'a', 'status': 'PASS'},
                                         {'name': 'b', 'status': 'FAIL'}]
    assert (tmp_path / 'o' / 'summary.txt').read_text().startswith('run ')
    assert json.loads((tmp_path / 'o' / 'summary.json').read_text()) == js


def test_sweep_main_refuses_before_anything_starts(tmp_path):
    path = write(tmp_path, 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY +
                 'sweep: {heading: {range: [0, 20000, 1]}}\n')
    a = types.SimpleNamespace(sweep=True, set=None, max_runs=None, seed=None, shard=None,
                              junit=None, record=None, out=None, json=None, cluster=None,
                              jobs=2, rtf=None, cpus_per_run=1)
    out = []
    assert sweep.main([path], a, out=out.append) == 2
    assert out == ['ERROR the sweep cannot start:', '  %s:9: sweep.heading.range: expands to 20001 '
                   'values, more than the limit of 10000 (raise it with --max-runs N or '
                   'sweep.max_runs)' % path]


def test_cluster_without_ray_is_one_line(tmp_path, monkeypatch):
    """Ray is optional: --cluster where it is not installed is one ERROR line, exit 2."""
    import sys
    from testing_instance.farm import cluster
    monkeypatch.setitem(sys.modules, 'ray', None)        # import ray -> ImportError
    path = write(tmp_path, 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY)
    a = types.SimpleNamespace(sweep=True, set=None, max_runs=None, seed=None, shard=None,
                              junit=None, record=None, out=None, json=None,
                              cluster='localhost:6379', jobs=1, rtf=None, cpus_per_run=1,
                              report=None)
    out = []
    assert sweep.main([path], a, out=out.append, remote=cluster.run_cluster) == 2
    assert out == ['ERROR --cluster needs Ray (pip install "ray==2.40.0"; tools/setup installs '
                   'it into build/venv)'], out


def test_report_folder_per_run_in_the_sweep_layout(tmp_path):
    lay = sweep.Layout(report=str(tmp_path / 'r'))
    run = sweep.plan([write(tmp_path, 'parameters: {heading: 0, y: 0, temp: 20}\n' + BODY +
                            'sweep: {heading: [0, 90]}\n')])[1]
    assert lay.report_of(run) == str(tmp_path / 'r' / run.id)
    cmd = sweep.run_command(run, report=lay.report_of(run))
    assert cmd[cmd.index('--report') + 1] == lay.report_of(run)
    assert '--report' not in sweep.run_command(run)
