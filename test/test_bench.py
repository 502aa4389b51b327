"""Every benchmark keeps running: each executable file in bench/ (found by glob, so a
bench added later is covered without editing this file) is run with ``--quick`` in the
project environment (build/env.sh: the venv python, PYOPENGL_PLATFORM=osmesa,
ROS_HOSTNAME=localhost, ROS_HOME in build/). It must exit 0 within the time limit and print
its figures: at least one ``name: number`` line, at least one figure whose name says
``ratio`` (the project's figures are ratios to a baseline measured in the same run), every
number finite, and every figure its source prints (``print('name: ...`` and ``out('name',
...``, with ``%s``/``%d`` in a name standing for any text/number), except the few the
full run alone prints or an error path prints (FULL_ONLY below) and the ones a missing
tool skips with a line that says so (SKIPPED): --quick is the smallest run through every
code path of the bench, not a different bench. Wall-clock speed is not asserted: only that
the bench runs and reports."""
import glob
import math
import os
import re
import signal
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCHES = sorted(p for p in glob.glob(os.path.join(ROOT, 'bench', '*'))
                 if os.path.isfile(p) and os.access(p, os.X_OK))
#: --quick takes 5-70 s on an unloaded machine; the suite's machine may be shared, and the
#: light lane runs it at nice 10 beside the integration tests (fixtures/lanes.py)
TIMEOUT = int(os.environ.get('MDS_BENCH_TIMEOUT', '600'))
FIGURE = re.compile(r'^([A-Za-z0-9_.\-/]+):\s+(-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?|-?inf|nan)\s*$',
                    re.M)


#: a figure line's name as the bench's source writes it: print('name: %.2f' % x) or
#: out('name', x) (bench/camera, feeds, tinyros)
TEMPLATE = re.compile(r'''(?:\bprint|\bout)\(\s*(['"])([A-Za-z0-9_%.\-]+)(?::\s|\1)''')
#: figures the --quick run does not print, as regular expressions over the name: the full
#: run's alone (it repeats, or runs what --quick leaves out) and those of error paths
FULL_ONLY = {
    'scenario': [r'sensors_embedded_ratio_inproc_median',       # three pairs
                 r'scenarios_per_minute_.*', r'jobs2_.*', r'serial_busy_cores',
                 r'warm_ratio_cold'],                            # the example farms
    'fuzz': [r'fuzz_libfuzzer_build_failed'],                    # the build failed
    'load': [r'load_kept'],                                      # --keep
    'feeds': [r'vnc_warning',                                    # wrong image sizes
              r'vnc_skipped', r'pcl2image_skipped'],             # a tool is missing
    'flaky': [r'flaky_wall_ratio_quiet_quiet'],                  # --no-load
    'loopback': [r'%s_ratio_to_30fps_target'],                   # a VM run's figures
}
#: figures a missing tool skips, with the line that says so: {bench: [(the line, figures)]}
SKIPPED = {
    'feeds': [(r'^vnc_skipped: ', r'vnc_.*'),
              (r'^pcl2image_skipped: ', r'pcl.*')],
    'loopback': [(r'^# image_sink conversion skipped', r'image_sink_.*')],
    'studio_streams': [(r'^# chromium: ', r'page_first_frame_ms|rtf_chromium_ratio')],
}


def templates(path):
    """The figure names the bench at path prints, as regular expressions."""
    with open(path) as f:
        src = f.read()
    out = {}
    for m in TEMPLATE.finditer(src):
        t = m.group(2)
        out[t] = re.escape(t).replace('%s', '.+').replace('%d', r'\d+')
    return out


def missing_figures(bench, out):
    """The figure names of the bench's source that its output lacks."""
    name = os.path.basename(bench)
    excused = list(FULL_ONLY.get(name, []))
    excused += [names for line, names in SKIPPED.get(name, []) if re.search(line, out, re.M)]
    missing = []
    for t, rx in sorted(templates(bench).items()):
        if any(re.fullmatch(e, t) or re.fullmatch(e, t.replace('%s', 'x')) for e in excused):
            continue
        if not re.search(r'^%s:(\s|$)' % rx, out, re.M):
            missing.append(t)
    return missing


def _env():
    build = os.environ.get('MDS_BUILD', os.path.join(ROOT, 'build'))
    env = dict(os.environ)
    venv_bin = os.path.join(build, 'venv', 'bin')
    if os.path.isdir(venv_bin):
        env['PATH'] = venv_bin + os.pathsep + env.get('PATH', '')
    env.setdefault('PYOPENGL_PLATFORM', 'osmesa')
    env['ROS_HOSTNAME'] = env.get('ROS_HOSTNAME') or 'localhost'
    env.setdefault('ROS_HOME', os.path.join(build, 'ros_home'))
    env.setdefault('ROS_LOG_DIR', os.path.join(env['ROS_HOME'], 'log'))
    os.makedirs(env['ROS_LOG_DIR'], exist_ok=True)
    env['PYTHONUNBUFFERED'] = '1'
    return env


def test_there_are_benches():
    assert BENCHES, 'no executable file in bench/'


@pytest.mark.slow
@pytest.mark.parametrize('bench', BENCHES, ids=[os.path.basename(b) for b in BENCHES])
def test_bench_quick(bench):
    env = _env()
    # '#!/usr/bin/env python3' finds the venv's python first on the PATH of env
    cmd = [bench, '--quick']
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)      # the bench and its roscore/nodes
        out, err = proc.communicate()
        pytest.fail('%s --quick did not finish in %d s\n%s\n%s' % (bench, TIMEOUT, out[-3000:],
                                                                    err[-3000:]))
    assert proc.returncode == 0, '%s --quick exited %d\n%s\n%s' % (
        bench, proc.returncode, out[-3000:], err[-5000:])
    figures = FIGURE.findall(out)
    assert figures, 'no "name: number" figure line in the output of %s:\n%s' % (bench, out[-3000:])
    ratios = [n for n, _ in figures if 'ratio' in n]
    assert ratios, 'no ratio figure in the output of %s:\n%s' % (bench, out[-3000:])
    bad = [(n, v) for n, v in figures if not math.isfinite(float(v))]
    assert not bad, 'figures of %s that are not finite numbers: %s\n%s' % (bench, bad,
                                                                            out[-3000:])
    missing = missing_figures(bench, out)
    assert not missing, '%s --quick did not print these figures of its source: %s\n%s' % (
        bench, missing, out[-3000:])


def test_figure_names_are_found_in_the_sources():
    """The check above reads the figure names from the sources: it finds the ones each
    style of bench prints, and a quick run lacking one is reported."""
    by_name = {os.path.basename(b): b for b in BENCHES}
    if 'camera' in by_name:                               # out('name', value)
        assert 'camera_max_rate_ratio_to_raw' in templates(by_name['camera'])
    if 'scenario' in by_name:                             # print('name: %.2f' % x)
        assert 'baseline_rtf' in templates(by_name['scenario'])
        assert 'sensors_embedded_ratio_inproc_median' not in missing_figures(
            by_name['scenario'], '')                      # full run only
        assert 'baseline_rtf' in missing_figures(by_name['scenario'], 'sensors_rtf: 1.0\n')
    if 'fuzz' in by_name:                                 # print('fuzz_%s_...: %d' % ...)
        miss = missing_figures(by_name['fuzz'], 'fuzz_tcpros_executions: 3\n')
        assert 'fuzz_%s_executions' not in miss and 'fuzz_%s_findings' in miss
