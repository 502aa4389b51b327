"""Child processes of a run (roscore, the world, the scenario's apps) and port allocation."""
import os
import signal
import subprocess

from sim_world.netutil import free_port  # noqa: F401 - the one copy, re-exported

__all__ = ['Proc', 'free_port', 'tail']


def tail(path, n=25):
    try:
        with open(path, errors='replace') as f:
            return [ln.rstrip('\n') for ln in f.readlines()[-n:]]
    except OSError:
        return []


class Proc(object):
    """A child process in its own process group, output to a log file."""

    def __init__(self, cmd, env, log_path, cwd=None):
        self.cmd = cmd
        self.log_path = log_path
        self.log = open(log_path, 'w')
        self.p = subprocess.Popen(cmd, env=env, stdout=self.log, stderr=subprocess.STDOUT,
                                  stdin=subprocess.DEVNULL, start_new_session=True, cwd=cwd)

    def alive(self):
        return self.p.poll() is None

    def stop(self, grace=10.0):
        if self.p.poll() is None:
            try:
                os.killpg(self.p.pid, signal.SIGINT)
            except OSError:
                pass
            try:
                self.p.wait(grace)
            except subprocess.TimeoutExpired:
                try:
                    os.killpg(self.p.pid, signal.SIGKILL)
                except OSError:
                    pass
                self.p.wait(5)
        self.log.close()
