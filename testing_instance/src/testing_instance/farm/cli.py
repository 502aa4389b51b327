"""Command line of run_scenario / replay_scenario (see the README of testing_instance)."""
import os
import sys
import time

from ..run.runner import EXIT_ERROR, EXIT_FAIL, EXIT_PASS
from .command import expand, parser, run_one

__all__ = ['main', 'replay_main', 'farm']


def check(files, sets=(), max_runs=None, out=print):
    """run_scenario --check FILE...: validate as a linter would (roslaunch --files style),
    nothing started. Each file: every concrete run of its sweep is substituted and validated.
    Exit 0 when all are valid, 2 otherwise (the FILE:LINE messages printed)."""
    from ..scenario.format import ScenarioError
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
            from ..scenario.format import load
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
    if argv == ['--warm-worker']:       # a farm's worker (testing_instance.farm.warm)
        from .warm import worker_main
        _graph_gone[0] = True
        return worker_main()
    a = parser(prog).parse_args(argv)
    if a.gtest_output and a.gtest_output.startswith('xml:') and not a.junit:
        a.junit = a.gtest_output[4:]
    files = expand(a.files)
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
    res = run_one(a, files[0], attach=a.attach, replay=a.replay, port=a.port,
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
    """Run every file ``jobs`` at a time (testing_instance.farm.warm.Pool: warm worlds, or with
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
    pool = Pool(jobs, warm=not a.cold)
    pool.run(items, lambda f, rc, text, wall: done(f, rc, wall, text))
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
    for note in pool.notes:
        out(note)
    if a.report:
        _farm_index(a.report, results, time.monotonic() - wall0, out)
    return worst


def _farm_index(report, results, wall, out):
    from ..report import write_farm_index
    runs = [dict(name=os.path.splitext(os.path.basename(f))[0],
                 status={EXIT_PASS: 'PASS', EXIT_FAIL: 'FAIL'}.get(rc, 'ERROR'), wall=w,
                 report=os.path.join(report, os.path.splitext(os.path.basename(f))[0]))
            for f, rc, w, _text in results]
    write_farm_index(report, runs, wall, out)
