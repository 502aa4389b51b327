"""The studio's world when it is not attached: a master at ROS_MASTER_URI if none answers
there (testing_instance.world.procs.Core: rosmaster and rosout, /use_sim_time set), and the launch
file on it (procs.Launch: ``roslaunch --wait``), stopped together at the end
(procs.stop_run, then the master). The same code the scenario runner starts its worlds
with."""
import os
import time
from urllib.parse import urlparse

__all__ = ['StartedWorld', 'LaunchError', 'master_answers', 'world_running']


class LaunchError(RuntimeError):
    pass


def _master(uri):
    import rosgraph
    return rosgraph.Master('/studio', master_uri=uri)


def master_answers(uri):
    try:
        _master(uri).getPid()
        return True
    except Exception:  # noqa: BLE001 - no master there (OSError), or not a master
        return False


def world_running(uri):
    try:
        return bool(_master(uri).lookupService('/gazebo/get_model_state'))
    except Exception:  # noqa: BLE001 - rosgraph.MasterError: not registered
        return False


class StartedWorld(object):
    """The master (if this studio started it) and the world's roslaunch."""

    def __init__(self, uri, launch_path, args, run_dir, timeout=120.0):
        from testing_instance.world import procs
        self.procs = procs
        self.uri = uri
        self.core = None
        self.launch = None
        self.run_dir = run_dir
        port = urlparse(uri).port
        host = urlparse(uri).hostname
        env = procs.ros_env(os.path.join(run_dir, 'log'))
        env['ROS_MASTER_URI'] = uri
        deadline = time.monotonic() + timeout
        if world_running(uri):
            raise LaunchError('a world already runs at %s (ROS_MASTER_URI): join it with '
                              '--attach' % uri)
        if not master_answers(uri):
            if host not in ('localhost', '127.0.0.1', os.uname()[1]):
                raise LaunchError('no ROS master answers at %s and it is not on this machine'
                                  % uri)
            self.core = procs.Core(port, env, run_dir)
            m = _master(uri)
            if not self.core.wait_up(m, deadline):
                why = self.core.failure(timeout)
                self.core.kill()
                self.core = None
                raise LaunchError(why)
            self.core.up(m)
        self.launch = procs.Launch([launch_path] + list(args),
                                   procs.launch_env(env, run_dir),
                                   os.path.join(run_dir, 'world.log'))
        self.launch.go(uri)
        while not world_running(uri):
            if not self.launch.alive() or time.monotonic() > deadline:
                tail = '\n'.join(procs.tail(self.launch.log_path, 15))
                self.stop()
                raise LaunchError('the world did not start (%s):\n%s' % (
                    'roslaunch exited' if not self.launch.alive() else 'timeout', tail))
            time.sleep(0.1)

    def alive(self):
        return self.launch is not None and self.launch.alive()

    def log_tail(self, n=15):
        return self.procs.tail(self.launch.log_path, n) if self.launch else []

    def stop(self):
        """Every process this studio started ends (SIGINT, then SIGKILL of its group)."""
        if self.launch is not None:
            node = self.procs.world_node(self.launch).get(self.procs.WORLD_NODE)
            self.procs.stop_run([], self.launch, node, grace=10.0)
            self.launch = None
        if self.core is not None:
            self.core.kill()
            self.core = None
