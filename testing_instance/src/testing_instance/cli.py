"""Command line of run_scenario / replay_scenario (see the README of testing_instance)."""
import argparse
import glob
import os
import sys
import time

from .runner import EXIT_ERROR, EXIT_FAIL, EXIT_PASS, run_file
from .yamlsrc import ScenarioError

__all__ = ['main', 'replay_main', 'farm']


def _parser(prog):
    p = argparse.ArgumentParser(
        prog=prog, description='Run scenario files (YAML) against the simulated phone in '
        'sim time and print a verdict per expectation. Exit 0: all passed, 1: a failure, '
        '2: an error (the scenario could not run).')
    p.add_argument('files', nargs='+', metavar='FILE|DIR',
                   help='scenario file(s); with --jobs also folders of *.yaml')
    p.add_argument('--seed', type=int, help='override the scenario\'s seed')
    p.add_argument('--record', metavar='BAG|MCAP', action='append',
                   help='write a recording of the run: .mcap = MCAP (ROS 1 encoding), else a '
                   'rosbag; may be given twice (both from the same messages); with --jobs: a '
                   'folder')
    p.add_argument('--junit', metavar='XML', help='write JUnit XML (with --jobs: a folder)')
    p.add_argument('--report', metavar='DIR', help='write an HTML report of the run to '
                   'DIR/index.html (opens offline; with --jobs, --sweep or --cluster: '
                   'DIR/<run>/ per run and an index page DIR/index.html)')
    p.add_argument('--real-time-factor', type=float, dest='rtf', metavar='R',
                   help='0 = as fast as possible (override the scenario\'s)')
    p.add_argument('--attach', action='store_true',
                   help='use the running world at ROS_MASTER_URI (rostest)')
    p.add_argument('--embedded', action='store_true',
                   help='run the world in this process, or fail (the default for one '
                   'scenario whose launch file has one sim_world node): this node becomes '
                   'that node and steps the World by a function call')
    p.add_argument('--world-node', action='store_true', dest='world_node',
                   help='run the launch file\'s sim_world node as a process of its own and '
                   'step it through /gazebo/step_world (as --attach and farms do)')
    p.add_argument('--replay', metavar='BAG|MCAP', help='play a recording (rosbag or MCAP) '
                   'as the clock source, no world; the apps and expectations run again')
    p.add_argument('--jobs', type=int, default=0, metavar='N',
                   help='run the scenarios N at a time: N workers, each with its own master '
                   'and a warm world that serves scenario after scenario on the same world '
                   '(reset between them with /gazebo/reload_world)')
    p.add_argument('--cold', action='store_true', help='with --jobs or --sweep: a fresh '
                   'master and world for every scenario instead of warm worlds')
    p.add_argument('--shard', metavar='I/N', help='run only the I-th of N shares of the files '
                   '(0-based; a CI matrix or several machines)')
    # sweeps and the Ray farm (testing_instance.sweep / .cluster, issue 21)
    p.add_argument('--sweep', action='store_true', help='run every concrete run of the '
                   'files\' sweep: blocks (a pass-rate summary, a command per failure)')
    p.add_argument('--set', action='append', metavar='NAME=VALUE', help='set a parameter '
                   '(repeatable); with --sweep it pins that parameter')
    p.add_argument('--max-runs', type=int, dest='max_runs', metavar='N',
                   help='refuse sweeps larger than N runs (default 10000)')
    p.add_argument('--out', metavar='DIR', help='sweep: summary.txt, summary.json, '
                   'sweep.xml and each run\'s report in logs/')
    p.add_argument('--json', metavar='FILE', help='sweep: the summary as JSON')
    p.add_argument('--cluster', metavar='ADDRESS', help='run on a Ray cluster (host:port, '
                   'ray://host:port, or auto = $RAY_ADDRESS / the local cluster)')
    p.add_argument('--cpus-per-run', type=float, default=1.0, dest='cpus_per_run',
                   metavar='C', help='--cluster: CPUs each run reserves (default 1)')
    p.add_argument('--check', action='store_true', help='validate the files (and every '
                   'concrete run of their sweeps) without starting anything: exit 0 valid, '
                   '2 invalid with FILE:LINE messages')
    p.add_argument('--port', type=int, metavar='P', help='master port of this run (default: a '
                   'free one; another is taken when P is busy)')
    p.add_argument('--gtest_output', help=argparse.SUPPRESS)   # rostest passes xml:PATH
    p.add_argument('--text', action='store_true', help=argparse.SUPPRESS)
    return p


def _record_arg(record):
    """--record given once: its path; twice or more: the list (one writer each)."""
    if not record:
        return None
    return record[0] if len(record) == 1 else list(record)


def _expand(items):
    files = []
    for it in items:
        if os.path.isdir(it):
            files += sorted(glob.glob(os.path.join(it, '*.yaml')))
        else:
            files.append(it)
    return files


def check(files, sets=(), max_runs=None, out=print):
    """run_scenario --check FILE...: validate as a linter would (roslaunch --files style),
    nothing started. Each file: every concrete run of its sweep is substituted and validated.
    Exit 0 when all are valid, 2 otherwise (the FILE:LINE messages printed)."""
    from .scenario import ScenarioError
    from .sweep import plan
    if not files:
        out('ERROR no scenario files given')
        return EXIT_ERROR
    bad = 0
    for f in files:
        try:
            if not os.path.isfile(f):
                raise ScenarioError(['%s: no such file' % f])
            runs = plan([f], sweep=True, sets=sets, max_runs=max_runs)
            from .scenario import load
            for r in runs:
                load(f, values=dict(r.values) or None)
        except ScenarioError as e:
            bad += 1
            out('INVALID %s' % f)
            for p in e.problems:
                out('  ' + p)
        except Exception as e:  # noqa: BLE001 - a validator bug must not hide the file
            bad += 1
            out('INVALID %s' % f)
            out('  %s: internal error while checking: %s: %s' % (f, type(e).__name__, e))
        else:
            out('OK %s (%d run%s)' % (f, len(runs), '' if len(runs) == 1 else 's'))
    return EXIT_ERROR if bad else EXIT_PASS


def _shard(files, spec):
    """The farm's share of the files: sorted, then dealt round robin (sweep.shard)."""
    from .sweep import shard
    return shard(sorted(files), spec)


def main(argv=None, prog='run_scenario'):
    import rospy
    argv = rospy.myargv(sys.argv if argv is None else argv)[1:]
    if argv == ['--warm-worker']:       # a farm's worker (testing_instance.warm)
        from .warm import worker_main
        _graph_gone[0] = True
        return worker_main()
    a = _parser(prog).parse_args(argv)
    if a.gtest_output and a.gtest_output.startswith('xml:') and not a.junit:
        a.junit = a.gtest_output[4:]
    files = _expand(a.files)
    if a.check:
        return check(files, sets=a.set or (), max_runs=a.max_runs)
    if a.embedded and a.world_node:
        print('ERROR --embedded and --world-node exclude each other')
        return EXIT_ERROR
    if a.embedded and (a.jobs or len(files) > 1 or a.attach or a.replay or a.sweep or
                       a.cluster):
        print('ERROR --embedded runs one scenario with a world of its own; it does not go '
              'with --jobs, several files, --attach, --replay, --sweep or --cluster')
        return EXIT_ERROR
    if a.sweep or a.cluster:
        from . import sweep
        remote = None
        if a.cluster:
            from .cluster import run_cluster as remote
        return sweep.main(files, a, remote=remote)
    if a.shard:
        files = _shard(files, a.shard)
    if not files:
        print('ERROR no scenario files in %s' % ' '.join(a.files))
        return EXIT_ERROR
    if a.jobs or len(files) > 1:
        return farm(files, max(1, a.jobs), a)
    res = _run_one(a, files[0], attach=a.attach, replay=a.replay, port=a.port,
                   embedded=True if a.embedded else not a.world_node and 'auto')
    if res is None:
        return EXIT_ERROR
    _graph_gone[0] = not a.attach
    if a.text:          # rostest --text: the summary a rosunit test node prints
        errs = [v.name for v in res.verdicts if v.error] + (['run'] if res.error else [])
        fails = [v.name for v in res.verdicts if not v.passed and not v.error]
        print('-' * 61 + '\nSUMMARY:\n * RESULT: %s\n * TESTS: %d\n * ERRORS: %d [%s]\n'
              ' * FAILURES: %d [%s]' % ('SUCCESS' if res.exit_code == EXIT_PASS else 'FAIL',
                                       max(1, len(res.verdicts)), len(errs), ', '.join(errs),
                                       len(fails), ', '.join(fails)))
    return res.exit_code


def _values(a, path):
    """--set NAME=VALUE of parsed arguments ``a`` for file ``path`` (None without)."""
    if not a.set:
        return None
    from .params import declared, parse_set
    from .yamlsrc import read
    return parse_set(a.set, declared(read(path), path), path)


def run_argv(argv, warm=None, out=None):
    """Run one run_scenario command line (a single scenario) in this process, in the warm
    world ``warm`` (a testing_instance.warm.WarmHost); the exit code."""
    a = _parser('run_scenario').parse_args(list(argv))
    res = _run_one(a, _expand(a.files)[0], out=out, warm=warm)
    return EXIT_ERROR if res is None else res.exit_code


def _run_one(a, path, out=None, **kw):
    """Run scenario ``path`` with the parsed arguments ``a`` (and run_file's ``kw``): its
    Result, or None when --set is bad (said through ``out``)."""
    try:
        values = _values(a, path)
    except ScenarioError as e:
        (out or print)('ERROR ' + '\n  '.join(e.problems))
        return None
    return run_file(path, values=values, seed=a.seed, record=_record_arg(a.record),
                    junit=a.junit, real_time_factor=a.rtf, report=a.report, out=out, **kw)


def world_key_of(argv):
    """The world (testing_instance.runner.world_key) a run_scenario command line needs."""
    from .runner import world_key
    from .scenario import load
    a = _parser('run_scenario').parse_args(list(argv))
    path = _expand(a.files)[0]
    return world_key(load(path, values=_values(a, path)), a.report)


_graph_gone = [False]     # this process's run has torn down the master it registered with


def leave(code):
    """The node scripts' exit. After a run that started its own master (not --attach) and
    stopped it, everything is written and closed, and rospy's exit would only unregister
    from a master that is gone and join its threads (0.1-0.6 s of every run): the process
    flushes its output and ends at once. Otherwise (--attach, --check, a farm) a normal
    exit."""
    if _graph_gone[0]:
        import logging
        sys.stdout.flush()
        sys.stderr.flush()
        logging.shutdown()
        os._exit(code if isinstance(code, int) else EXIT_ERROR)
    sys.exit(code)


def replay_main(argv=None):
    argv = list(sys.argv if argv is None else argv)
    a = [x for x in argv[1:]]
    if len(a) >= 2 and not a[0].startswith('-') and a[1].endswith(('.bag', '.mcap')):
        return main([argv[0], a[0], '--replay', a[1]] + a[2:], prog='replay_scenario')
    print('usage: replay_scenario FILE BAG|MCAP [--junit XML] [--record BAG2]')
    return EXIT_ERROR


def farm_argv(f, a):
    """The run_scenario command line (without the program) of file ``f`` in a farm run
    with the parsed arguments ``a``: the options that apply to each run, the output
    folders' per-file paths (created)."""
    argv = [f]
    if a.seed is not None:
        argv += ['--seed', str(a.seed)]
    if a.rtf is not None:
        argv += ['--real-time-factor', str(a.rtf)]
    for s in a.set or ():               # every file must declare the parameter
        argv += ['--set', s]
    if a.world_node:                    # (a warm worker's world is a node anyway)
        argv.append('--world-node')
    name = os.path.splitext(os.path.basename(f))[0]
    if a.junit:
        os.makedirs(a.junit, exist_ok=True)
        argv += ['--junit', os.path.join(a.junit, name + '.xml')]
    if a.report:
        argv += ['--report', os.path.join(a.report, name)]
    if a.record:                        # a folder: <name>.bag
        os.makedirs(a.record[0], exist_ok=True)
        argv += ['--record', os.path.join(a.record[0], name + '.bag')]
    return argv


def farm(files, jobs, a, out=print):
    """Run every file ``jobs`` at a time (testing_instance.warm.Pool: warm worlds, or with
    --cold a run_scenario process and master per file); print a summary table. Exit: the
    worst of the runs."""
    from .warm import Pool
    items = [(f, farm_argv(f, a)) for f in files]
    results = []
    wall0 = time.monotonic()

    def done(f, rc, wall, text):
        results.append((f, rc, wall, text))
        for ln in text.splitlines():
            out('[%s] %s' % (os.path.basename(f), ln))
    Pool(jobs, warm=not a.cold).run(items, lambda f, rc, text, wall: done(f, rc, wall, text))
    status = {EXIT_PASS: 'PASS', EXIT_FAIL: 'FAIL'}
    out('')
    out('%-40s %-6s %8s %s' % ('scenario', 'result', 'wall s', 'expectations'))
    worst = EXIT_PASS
    for f, rc, wall, text in sorted(results):
        n_pass = sum(1 for ln in text.splitlines() if ln.startswith('PASS '))
        n_all = sum(1 for ln in text.splitlines() if ln.split(' ', 1)[0] in
                    ('PASS', 'FAIL', 'ERROR'))
        out('%-40s %-6s %8.1f %d/%d passed' % (os.path.basename(f), status.get(rc, 'ERROR'),
                                                 wall, n_pass, n_all))
        worst = max(worst, rc if rc in (0, 1) else EXIT_ERROR)
    out('%d scenarios, %d jobs, %.1f s wall' % (len(results), jobs, time.monotonic() - wall0))
    if a.report:
        _farm_index(a.report, results, time.monotonic() - wall0, out)
    return worst


def _farm_index(report, results, wall, out):
    from .report import write_farm_index
    runs = [dict(name=os.path.splitext(os.path.basename(f))[0],
                 status={EXIT_PASS: 'PASS', EXIT_FAIL: 'FAIL'}.get(rc, 'ERROR'), wall=w,
                 report=os.path.join(report, os.path.splitext(os.path.basename(f))[0]))
            for f, rc, w, _text in results]
    write_farm_index(report, runs, wall, out)
