"""One run_scenario command line: its parser, and running it in this process (a single run,
or a farm worker's job: testing_instance.farm.warm). Below the command line's other jobs (cli:
farms, sweeps, clusters, checks), so a farm's worker needs nothing above it."""
import argparse
import glob
import os
import shutil
import time

from ..run.runner import EXIT_ERROR, run_file
from ..scenario.yamlsrc import ScenarioError

__all__ = ['expand', 'parser', 'prepare_argv', 'record_arg', 'run_argv', 'run_one',
           'values_of', 'world_key_of']


def parser(prog):
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
    # sweeps and the Ray farm (testing_instance.farm.sweep / .cluster, issue 21)
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
    p.add_argument('--live', action='store_true', help='also print each expectation\'s '
                   'verdict the moment it is decided, as "decided PASS|FAIL|ERROR NAME: ... '
                   'at t=T s" (an eventually met, an always or never broken; the studio puts '
                   'them on its timeline during the run); the verdicts at the end are as without')
    p.add_argument('--gtest_output', help=argparse.SUPPRESS)   # rostest passes xml:PATH
    p.add_argument('--text', action='store_true', help=argparse.SUPPRESS)
    return p


def record_arg(record):
    """--record given once: its path; twice or more: the list (one writer each)."""
    if not record:
        return None
    return record[0] if len(record) == 1 else list(record)


def expand(items):
    files = []
    for it in items:
        if os.path.isdir(it):
            files += sorted(glob.glob(os.path.join(it, '*.yaml')))
        else:
            files.append(it)
    return files


def values_of(a, path):
    """--set NAME=VALUE of parsed arguments ``a`` for file ``path`` (None without)."""
    if not a.set:
        return None
    from ..scenario.params import declared, parse_set
    from ..scenario.yamlsrc import read
    return parse_set(a.set, declared(read(path), path), path)


def run_argv(argv, warm=None, out=None, on_start=None):
    """Run one run_scenario command line (a single scenario) in this process, in the warm
    world ``warm`` (a testing_instance.farm.warm.WarmHost); the exit code. ``on_start()`` is
    called when the scenario reaches sim time 0."""
    a = parser('run_scenario').parse_args(list(argv))
    res = run_one(a, expand(a.files)[0], out=out, warm=warm, on_start=on_start)
    return EXIT_ERROR if res is None else res.exit_code


def prepare_argv(argv, warm):
    """Make the warm world ``warm`` (a WarmHost) hold the world that run_scenario command
    line's scenario needs, launched and answering, without running it (a farm's spare
    worker launches the next world while another worker runs)."""
    from ..world import procs
    from ..run.runner import Runner
    procs.first_run()      # its first scenario's start-up counts from its job, not from here
    a, sc = _scenario_of(argv)
    r = Runner(sc, seed=a.seed, real_time_factor=a.rtf, report=a.report, warm=warm,
               out=lambda s: None)
    try:
        warm.ready(r, time.monotonic() + min(sc.timeout, 120.0))
    finally:
        shutil.rmtree(r.run_dir, ignore_errors=True)


def run_one(a, path, out=None, **kw):
    """Run scenario ``path`` with the parsed arguments ``a`` (and run_file's ``kw``): its
    Result, or None when --set is bad (said through ``out``)."""
    try:
        values = values_of(a, path)
    except ScenarioError as e:
        (out or print)('ERROR ' + '\n  '.join(e.problems))
        return None
    if getattr(a, 'live', False):
        kw['live'] = True
    return run_file(path, values=values, seed=a.seed, record=record_arg(a.record),
                    junit=a.junit, real_time_factor=a.rtf, report=a.report, out=out, **kw)


def world_key_of(argv):
    """The world (testing_instance.world.worldside.world_key) a run_scenario command line needs."""
    from ..world.worldside import world_key
    a, sc = _scenario_of(argv)
    return world_key(sc, a.report)


def _scenario_of(argv):
    """The parsed arguments of a run_scenario command line and its (first) scenario,
    loaded with its --set values."""
    from ..scenario.format import load
    a = parser('run_scenario').parse_args(list(argv))
    path = expand(a.files)[0]
    return a, load(path, values=values_of(a, path))
