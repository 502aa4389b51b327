"""run_scenario --check FILE... (issue 19): validates without starting anything, exit 0 / 2
with FILE:LINE messages; fuzzed with Hypothesis over mutations of every example (types, keys,
YAML syntax, huge numbers, NaN, unicode): every result is OK or INVALID with messages that
name the file, never a traceback. Bounded here (seconds); bench/fuzz runs it longer."""
import glob
import os
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from testing_instance.farm.cli import check

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = sorted(glob.glob(os.path.join(ROOT, 'testing_instance', 'examples', '*.yaml')))
NODE = os.path.join(ROOT, 'testing_instance', 'nodes', 'run_scenario')


def run_check(paths):
    lines = []
    rc = check(list(paths), out=lines.append)
    return rc, lines


def test_examples_are_valid():
    rc, lines = run_check(EXAMPLES)
    assert rc == 0, lines
    assert len(lines) == len(EXAMPLES) and all(ln.startswith('OK ') for ln in lines)


def test_invalid_and_missing_files_exit_2_with_file_and_line(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: x\nduration: -3\nworld: office\nexpect: []\n')
    rc, lines = run_check([str(bad), str(tmp_path / 'nope.yaml'), EXAMPLES[0]])
    assert rc == 2
    assert lines[0] == 'INVALID %s' % bad
    assert any(('%s:2' % bad) in ln for ln in lines), lines
    assert any('nope.yaml: no such file' in ln for ln in lines), lines
    assert lines[-1].startswith('OK ')          # the valid file is still checked


def test_check_from_the_command_line_starts_nothing(tmp_path):
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:1')   # nothing may be reached
    p = subprocess.run([sys.executable, NODE, '--check'] + EXAMPLES[:2], capture_output=True,
                       text=True, env=env, timeout=60)
    assert p.returncode == 0, p.stdout + p.stderr
    bad = tmp_path / 'b.yaml'
    bad.write_text('duration: [\n')
    p = subprocess.run([sys.executable, NODE, '--check', str(bad)], capture_output=True,
                       text=True, env=env, timeout=60)
    assert p.returncode == 2 and 'INVALID' in p.stdout and 'Traceback' not in p.stderr


_SCALARS = st.one_of(st.integers(min_value=-10 ** 30, max_value=10 ** 30),
                     st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                     st.none(), st.text(max_size=12), st.sampled_from(
                         ['.nan', '-.inf', '1e999', '[', '{a: 1', '"\\u00e9\\u0000"', '&a',
                          '*a', '!!python/object:os.system', '~', "''", '0x1f', '::']))


def _mutate(text, data):
    lines = text.splitlines()
    kind = data.draw(st.sampled_from(['value', 'delete', 'duplicate', 'indent', 'garbage',
                                      'truncate', 'key']))
    i = data.draw(st.integers(0, max(0, len(lines) - 1)))
    if not lines:
        return text
    ln = lines[i]
    if kind == 'value' and ':' in ln:
        k = ln.split(':', 1)[0]
        lines[i] = '%s: %s' % (k, data.draw(_SCALARS))
    elif kind == 'delete':
        del lines[i]
    elif kind == 'duplicate':
        lines.insert(i, ln)
    elif kind == 'indent':
        lines[i] = ' ' * data.draw(st.integers(0, 7)) + ln.lstrip()
    elif kind == 'garbage':
        lines.insert(i, data.draw(st.text(max_size=30)))
    elif kind == 'truncate':
        return text[:data.draw(st.integers(0, len(text)))]
    elif kind == 'key' and ':' in ln:
        lines[i] = data.draw(st.text(min_size=1, max_size=10)).replace('\n', ' ') + ':' + \
            ln.split(':', 1)[1]
    return '\n'.join(lines) + '\n'


@settings(max_examples=int(os.environ.get('MDS_FUZZ_EXAMPLES', '150')), deadline=None,
          derandomize=not os.environ.get('MDS_FUZZ_SEED'), database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzzed_scenarios_are_valid_or_named_problems(tmp_path, data):
    src = data.draw(st.sampled_from(EXAMPLES))
    text = open(src).read()
    for _ in range(data.draw(st.integers(1, 3))):
        text = _mutate(text, data)
    # the examples' apps are found beside the file: keep the folder
    path = os.path.join(os.path.dirname(src), '.fuzz_%d.yaml' % os.getpid())
    try:
        with open(path, 'w', encoding='utf-8', errors='surrogatepass') as f:
            f.write(text)
        rc, lines = run_check([path])
    finally:
        os.unlink(path)
    assert rc in (0, 2), lines
    if rc == 0:
        assert lines[0].startswith('OK ')
    else:
        assert lines[0] == 'INVALID %s' % path
        assert len(lines) >= 2 and all(path in ln for ln in lines[1:]), lines
        assert not any('internal error' in ln for ln in lines), lines
