"""A farm on Ray (issue 21): ``run_scenario FILE... --sweep --cluster ADDRESS``.

Each concrete run becomes a Ray task that reserves ``--cpus-per-run`` CPUs (default 1) on
some node of the cluster. The task starts the run as ``run_scenario`` would locally, in its
own process with its own master and world on that node, and ships back what a local farm
keeps: the exit code, the printed verdicts, the JUnit file and the recording. They land in
the submitting machine's folders with the same layout as ``--jobs N`` (``sweep.Layout``).

``ADDRESS`` is whatever ``ray.init(address=...)`` accepts: a head node's ``host:port``, a
``ray://host:10001`` client address, or ``auto`` (``$RAY_ADDRESS``, else the local
cluster). Every node needs this package set up at the same path as the submitter (a
container image with the repository and ``tools/setup`` run, as a KubeRay RayCluster's
image would be) and the scenario's files (apps, worlds) there.

Faults: a node that dies mid-run loses its task; Ray runs it again on another node
(``max_retries``), and the run counts once. Each attempt is registered with a small ledger
actor on the submitting machine's node, so the summary says which runs were retried and on
which nodes they ran. An address that does not answer: one line, exit 2, within seconds.
"""
import os
import socket
import subprocess
import sys
import tempfile
import time

from .sweep import result, finished, run_command, run_env

__all__ = ['ClusterError', 'run_cluster', 'check_address']

RETRIES = 3


class ClusterError(RuntimeError):
    pass


def _import_ray():
    try:
        import ray
    except ImportError:
        raise ClusterError('--cluster needs Ray (pip install "ray==2.40.0"; tools/setup '
                           'installs it into build/venv)')
    return ray


def check_address(address, timeout=3.0):
    """Resolve ``auto`` and check that a host:port or ray://host:port answers (TCP) within
    ``timeout`` s, so an unreachable cluster is one line, not a minute of retries."""
    if address == 'auto':
        address = os.environ.get('RAY_ADDRESS') or 'auto'
        if address == 'auto':
            return address
    hostport = address[len('ray://'):] if address.startswith('ray://') else address
    host, sep, port = hostport.rpartition(':')
    if not sep or not port.isdigit():
        raise ClusterError('cluster address %r is not host:port, ray://host:port or auto'
                           % address)
    try:
        socket.create_connection((host or 'localhost', int(port)), timeout=timeout).close()
    except OSError as e:
        raise ClusterError('cannot reach the Ray cluster at %s: %s' % (address,
                                                                       e.strerror or e))
    return address


def _die_with_parent():
    """Before the run starts: unblock the signals a Ray worker blocks, undo its niceness
    (Ray starts task workers at nice 15), and ask for
    SIGTERM when the Ray worker dies (a node killed mid-run), so the run stops its master
    and world instead of running on as an orphan (Linux prctl)."""
    import signal
    # a Ray worker blocks SIGINT: inherited, the run's roslaunch could not be stopped by
    # SIGINT and every run waited out its stop grace before SIGTERM (25 s against 7 s a run)
    signal.pthread_sigmask(signal.SIG_SETMASK, [])
    try:
        os.setpriority(os.PRIO_PROCESS, 0, 0)
    except OSError:     # unprivileged: cannot lower the niceness; the run still works
        pass
    try:
        import ctypes
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except Exception:   # noqa: BLE001 - not Linux: the run finishes on its own
        pass


def _node_name():
    try:
        import ray
        return ray.get_runtime_context().get_node_id()[:8]
    except Exception:   # noqa: BLE001 - outside a Ray worker
        return socket.gethostname()


def _execute(cmd_tail, want_junit, want_bag, ledger, run_id, want_report=False):
    """The task body, on a worker: run one scenario, return its outputs."""
    node = _node_name()
    if ledger is not None:
        import ray
        try:
            ray.get(ledger.start.remote(run_id, node), timeout=30)
        except Exception:   # noqa: BLE001 - the ledger only counts attempts
            pass
    try:     # Ray's own attempt count (0: the first), kept by the task itself: it survives
        import ray           # a ledger that was lost with its node
        attempt = int(ray._private.worker.global_worker.core_worker
                      .get_current_task_attempt_number())
    except Exception:   # noqa: BLE001 - another Ray version: the ledger alone counts
        attempt = None
    tmp = tempfile.mkdtemp(prefix='mds_ray_run_')
    try:
        junit = os.path.join(tmp, 'run.xml') if want_junit else None
        bag = os.path.join(tmp, 'run.bag') if want_bag else None
        cmd = [sys.executable] + cmd_tail
        if junit:
            cmd += ['--junit', junit]
        if bag:
            cmd += ['--record', bag]
        report = os.path.join(tmp, 'report') if want_report else None
        if report:
            cmd += ['--report', report]
        t0 = time.monotonic()
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           env=_run_env(), preexec_fn=_die_with_parent)
        out = {'rc': p.returncode, 'text': p.stdout, 'wall': time.monotonic() - t0,
               'node': node, 'attempt': attempt}
        for key, path in (('junit', junit), ('bag', bag)):
            if path and os.path.exists(path):
                with open(path, 'rb') as f:
                    out[key] = f.read()
        if report and os.path.isdir(report):      # the report folder, as a tar archive
            import io
            import tarfile
            buf = io.BytesIO()
            with tarfile.open(fileobj=buf, mode='w:gz') as tf:
                tf.add(report, arcname='.')
            out['report'] = buf.getvalue()
        return out
    finally:
        import shutil
        shutil.rmtree(tmp, ignore_errors=True)


def _unpack_report(data, dest, out):
    """A run's report folder shipped back from a worker (a tar archive) into ``dest``."""
    import io
    import tarfile
    try:
        os.makedirs(dest, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(data), mode='r:gz') as tf:
            for m in tf.getmembers():          # only plain files and folders below dest
                if not (m.isfile() or m.isdir()) or m.name.startswith('/') or \
                        '..' in m.name.split('/'):
                    continue
                tf.extract(m, dest)
    except (OSError, tarfile.TarError) as e:
        out('report: cannot unpack the report of %s: %s' % (dest, e))


def _run_env():
    env = run_env()
    env.pop('OMP_NUM_THREADS', None)     # Ray's worker setting, not the run's
    return env


class _Ledger(object):
    """Attempts per run (an actor on the submitting machine's node)."""

    def __init__(self):
        self.starts = {}

    def start(self, run_id, node):
        self.starts.setdefault(run_id, []).append(node)
        return len(self.starts[run_id])

    def all(self):
        return self.starts


def run_cluster(runs, address, layout, rtf=None, cpus=1.0, out=print):
    """Run ``runs`` on the Ray cluster at ``address``; results as ``sweep.run_local``."""
    ray = _import_ray()
    if not (cpus > 0):
        raise ClusterError('--cpus-per-run must be > 0, got %r' % cpus)
    address = check_address(address)
    try:
        ray.init(address=address, logging_level='ERROR', log_to_driver=False,
                 include_dashboard=False, ignore_reinit_error=True)
    except Exception as e:   # noqa: BLE001 - one line naming the address
        raise ClusterError('cannot join the Ray cluster at %s: %s' % (
            address, str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__))
    try:
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy
        # the ledger lives on the head node (it outlives the workers; the driver may be
        # attached to any raylet of its machine)
        heads = [n['NodeID'] for n in ray.nodes() if n.get('Alive')
                 and 'node:__internal_head__' in n.get('Resources', {})]
        home = heads[0] if heads else ray.get_runtime_context().get_node_id()
        ledger = ray.remote(num_cpus=0, max_restarts=0)(_Ledger).options(
            scheduling_strategy=NodeAffinitySchedulingStrategy(home, soft=True)).remote()
        task = ray.remote(_execute).options(num_cpus=cpus, max_retries=RETRIES,
                                            retry_exceptions=False)
        nodes = [n for n in ray.nodes() if n.get('Alive')]
        out('%d runs on the Ray cluster at %s (%d nodes, %g CPUs, %g per run; submitted '
            'through node %s)' % (len(runs), address, len(nodes),
                                  sum(n.get('Resources', {}).get('CPU', 0) for n in nodes),
                                  cpus, ray.get_runtime_context().get_node_id()[:8]))
        pending = {}
        for r in runs:
            tail = run_command(r, rtf=rtf)[1:]
            ref = task.remote(tail, bool(layout.junit), bool(layout.record), ledger, r.id,
                              bool(layout.report))
            pending[ref] = (r, time.monotonic())
        results = []
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
            for ref in done:
                r, t0 = pending.pop(ref)
                try:
                    o = ray.get(ref)
                except Exception as e:   # noqa: BLE001 - the run is lost after the retries
                    o = {'rc': 2, 'text': 'ERROR the run was lost on the cluster: %s'
                         % str(e).strip().splitlines()[0], 'wall': time.monotonic() - t0,
                         'node': '?'}
                if o.get('junit') and layout.junit_of(r):
                    with open(layout.junit_of(r), 'wb') as f:
                        f.write(o['junit'])
                if o.get('bag') and layout.bag_of(r):
                    with open(layout.bag_of(r), 'wb') as f:
                        f.write(o['bag'])
                if o.get('report') and layout.report_of(r):
                    _unpack_report(o['report'], layout.report_of(r), out)
                try:
                    attempts = len(ray.get(ledger.all.remote(), timeout=30).get(r.id, [])) or 1
                except Exception:   # noqa: BLE001 - ledger lost with its node: unknown
                    attempts = 1
                if o.get('attempt') is not None:    # the task's own count (CI once lost a
                    attempts = max(attempts, o['attempt'] + 1)   # retry: 'retried: none')
                res = result(r, o['rc'], o['text'], o['wall'], node=o['node'],
                             attempts=attempts)
                finished(res, layout, out)
                results.append(res)
        return results
    finally:
        ray.shutdown()
