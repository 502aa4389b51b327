"""A scenario's Python app, started before the run's world is ready (procs.PreApp).

    python3 preapp.py SCRIPT [ARGS...]      then, on stdin, the master's URI

A Python app spends 0.3 s (and an app with OpenCV 0.6 s) in its imports before it talks to
ROS: rospy, genpy, the message modules, numpy. The runner used to start it once the world
was ready and then wait for all of that. This process is started with the scenario's run
instead, with the app's final command line and environment (rospy reads its remappings and
namespace from them when it is imported). It imports the modules the script imports at its
top (the import statements before its first other statement, those found outside the
script's folder: libraries, not the app's own modules), then waits for one line on stdin:
the URI of the run's master, once the world is reset and answering. It talks to no master
before that. Then it runs the script as ``python3 SCRIPT ARGS`` would (``runpy``, as
``__main__``, its folder first on ``sys.path``). An empty line, a closed stdin or SIGINT
before that (the run ended first) ends it quietly with exit code 0.

From then on the runner's end of stdin stays open for as long as the runner lives; the
script gets /dev/null as its stdin. When the runner dies (SIGKILLed: a CI job cancelled, a
Ray node removed) the app gets SIGTERM (procs.Proc's parent-death signal), and rospy shuts
it down; but rospy's signal handler deadlocks when the signal lands while the main thread is
in a call to the master (``rospy.core._LockedServerProxy`` holds a plain lock around each
call, and the handler's ``RegManager.cleanup`` takes it again, in the same thread). So a
thread here waits on stdin: once it closes, the app has :data:`GRACE` s to end, and then its
process group (the app and whatever it started) is SIGKILLed, as ``procs.Proc.finish`` does
when the runner lives.

A module that fails to import here is left for the script, which then fails as it would
have failed on its own.
"""
import ast
import importlib.util
import os
import signal
import sys

__all__ = ['GRACE', 'leading_imports', 'outside', 'until_told', 'watch_runner', 'main']

GRACE = 5.0     # s an app has to end once its runner is gone, before its group is SIGKILLed


def leading_imports(path):
    """The top-level module names the script ``path`` imports before its first statement
    that is not an import (its docstring and ``__future__`` imports aside), in order."""
    try:
        with open(path, 'rb') as f:
            tree = ast.parse(f.read(), path)
    except (OSError, SyntaxError, ValueError):
        return []
    out = []
    for i, node in enumerate(tree.body):
        if i == 0 and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) \
                and isinstance(node.value.value, str):
            continue                                      # the docstring
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.module == '__future__':
                continue
            if node.level or not node.module:
                break                                     # relative: the app's own
            out.append(node.module)
        else:
            break
    return out


def outside(name, here):
    """Is the module ``name`` found (as the script would find it) outside the folder
    ``here`` and its subfolders: a library, not one of the app's own modules?"""
    top = name.split('.')[0]
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return False
    if spec is None:
        return False
    if spec.origin in ('built-in', 'frozen'):
        return True
    where = ([spec.origin] if spec.origin else []) + list(spec.submodule_search_locations or [])
    root = os.path.join(os.path.abspath(here), '')
    return bool(where) and not any(os.path.abspath(w).startswith(root) for w in where)


def until_told(prepare):
    """Run ``prepare()`` (the imports), then wait for one line on stdin, the URI of the
    run's master, talking to no master meanwhile; returns it, set as ROS_MASTER_URI. SIGINT
    ends the process quietly (exit code 0) until then, even when it came in ignored (a
    runner started in the background of a non-interactive shell: CI); afterwards the
    process has the disposition it came with. An empty line or a closed stdin (the run
    ended first) ends it the same way. procs.Launch's roslaunch waits here too."""
    inherited = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        prepare()
        uri = sys.stdin.readline().strip()
    except KeyboardInterrupt:
        uri = ''                # the run stopped before its world was ready: no traceback
    if not uri:
        sys.exit(0)
    signal.signal(signal.SIGINT, inherited)
    os.environ['ROS_MASTER_URI'] = uri
    return uri


def _import_libraries(script, here):
    for name in leading_imports(script):
        if outside(name, here):
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001 - the script meets it again and says so
                pass


def watch_runner(grace=GRACE):
    """Keep the runner's end of stdin (fd 0) on a descriptor of its own, give fd 0
    /dev/null, and start a daemon thread blocked reading it (no wake-ups: to the run's app
    watch the app stays idle). When it closes (the runner died or finished with this app),
    the process group is SIGKILLed if this process is still alive ``grace`` s later."""
    import threading
    import time
    fd = os.dup(0)                                # not inherited by the app's children
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.close(null)

    def wait():
        try:
            while os.read(fd, 4096):
                pass
        except OSError:
            pass
        time.sleep(grace)
        try:
            sys.stderr.write('preapp: the runner is gone and the app did not end in %g s '
                             '(rospy\'s shutdown deadlocks when the signal lands during a call '
                             'to the master): SIGKILL to its process group\n' % grace)
            sys.stderr.flush()
        except (OSError, ValueError):
            pass
        if os.getpgrp() == os.getpid():           # its own group (procs.Proc): the app's
            os.killpg(os.getpgrp(), signal.SIGKILL)
        os.kill(os.getpid(), signal.SIGKILL)      # started some other way: itself alone

    t = threading.Thread(target=wait, name='preapp-runner-watch', daemon=True)
    t.start()
    return t


def main():
    script = sys.argv[1]
    sys.argv = sys.argv[1:]                   # as `python3 SCRIPT ARGS` has them
    here = os.path.dirname(os.path.abspath(script))
    sys.path[0] = here
    until_told(lambda: _import_libraries(script, here))
    watch_runner()
    import runpy
    runpy.run_path(script, run_name='__main__')


if __name__ == '__main__':
    main()
