"""run_scenario's embedded world: the World in the runner's own process, as gz-sim's
TestFixture owns its server.

    rosrun mobile_device_sim run_scenario FILE --embedded

The scenario's launch file is read with roslaunch's own loader (arguments, includes,
``$(find)``, xacro commands: everything roslaunch would do). Its parameters go to a fresh
roscore, its nodes start as processes of the run (spawners, helpers), but for the one
``mobile_device_sim/sim_world`` node: the runner itself becomes that node (one rospy process
is one node: the same name, namespace, remappings and private parameters), builds the same
WorldHost the sim_world executable builds, and steps it by a function call. Every topic and
service is still served over ROS, so apps, rostopic, rosbag and rviz see the same graph as
with the sim_world node; only the runner's own subscriptions take the world's messages as
objects (sim_world.transport's local delivery, counted for the slice handshake like a
remote connection), and its service calls to the world are function calls
(sim_world.transport.local_service).
"""
import logging
import os

from ..scenario.results import RunError
from . import procs
from .procs import Proc

__all__ = ['LaunchPlan', 'plan_launch', 'WORLD_NODE']

WORLD_NODE = ('mobile_device_sim', 'sim_world')     # (package, type) of the world node


class LaunchPlan(object):
    """What a launch file asks for, split for an embedded world: ``world`` (roslaunch's
    Node of the sim_world node), ``params`` [(key, value)] in roslaunch's order,
    ``clear_params``, ``nodes`` (the other roslaunch Nodes)."""

    why = None

    def __init__(self, world, params, clear_params, nodes):
        self.world, self.params, self.clear_params, self.nodes = \
            world, params, clear_params, nodes

    @property
    def world_name(self):
        ns = (self.world.namespace or '/').rstrip('/')
        return '%s/%s' % (ns, self.world.name)

    def world_argv(self):
        """The argv the world node would get (its args, remappings, namespace) for
        rospy.init_node and sim_world.node.host_from_params."""
        argv = ['sim_world'] + (self.world.args.split() if self.world.args else [])
        argv += ['%s:=%s' % tuple(kv) for kv in self.world.remap_args]
        ns = self.world_namespace()
        if ns != '/':
            argv.append('__ns:=%s' % ns)
        return argv

    def world_namespace(self):
        """The world node's namespace, global, ending in '/' ('/' for none)."""
        from rosgraph.names import make_global_ns
        return make_global_ns(self.world.namespace or '/')

    def set_params(self, master):
        """Clear and set the launch file's parameters as roslaunch does."""
        for key in self.clear_params:
            try:
                if master.hasParam(key):
                    master.deleteParam(key)
            except Exception:  # noqa: BLE001 - nothing to clear
                pass
        for key, value in self.params:
            master.setParam(key, value)

    def start_nodes(self, env, log_dir):
        """Start the launch file's other nodes; returns their Procs (logs in log_dir)."""
        from roslaunch.node_args import create_local_process_args
        from rosgraph.names import make_global_ns
        out = []
        for node in self.nodes:
            try:
                cmd = create_local_process_args(node, node.machine)
            except Exception as e:  # noqa: BLE001 - roslaunch's NodeParamsException and co.
                raise RunError('world.launch: node %s (%s/%s) cannot start: %s'
                               % (node.name, node.package, node.type, e))
            node_env = dict(env)
            node_env.update((k, v) for k, v in node.env_args)
            if (node.namespace or '/').strip('/'):
                node_env['ROS_NAMESPACE'] = node.namespace
            name = node.name.replace('/', '_')
            proc = Proc(cmd, node_env, os.path.join(log_dir, '%s.log' % name))
            # its ROS name, for what the run says of it (WorldSide.stop)
            proc.node_name = make_global_ns(node.namespace or '/') + node.name
            out.append(proc)
        return out


def plan_launch(path, args, port):
    """Load launch file ``path`` with ``args`` ('name:=value') for a master on ``port``
    and split it (LaunchPlan; its ``world`` None and ``why`` said when the file has not
    exactly one world node); RunError says what is wrong with the file."""
    import roslaunch.config
    import roslaunch.core
    import roslaunch.xmlloader

    class LaunchFileOnly(roslaunch.xmlloader.XmlLoader):
        """roslaunch's loader without roscore.xml (``core``): the run's own core
        (procs.Core) sets roscore's parameters and starts rosout; roscore.xml's two
        ``rosversion`` commands took 0.21 s of every embedded start-up."""
        def load(self, filename, ros_config, core=False, argv=None, verbose=True):
            if not core:
                return super().load(filename, ros_config, core=core, argv=argv,
                                    verbose=verbose)
    try:
        config = roslaunch.config.load_config_default([(path, list(args))], port,
                                                      loader=LaunchFileOnly())
    except (roslaunch.core.RLException, OSError, ValueError) as e:
        raise RunError('world.launch %s cannot be read: %s' % (path, e))
    worlds = [n for n in config.nodes if (n.package, n.type) == WORLD_NODE]
    params = [(p.key, p.value) for p in config.params.values()]
    if len(worlds) != 1:
        plan = LaunchPlan(None, params, list(config.clear_params), list(config.nodes))
        plan.why = ('the launch file %s has %d %s/%s nodes (one can be embedded)'
                    % (path, len(worlds), WORLD_NODE[0], WORLD_NODE[1]))
        return plan
    nodes = [n for n in config.nodes if n is not worlds[0]]
    return LaunchPlan(worlds[0], params, list(config.clear_params), nodes)


class LogFile(object):
    """The embedded world's log lines (rospy's 'rosout' logger) into a file of the run,
    as the sim_world node's output goes to the world log: the error tails read it."""

    def __init__(self, path):
        self.path = path
        self.handler = logging.FileHandler(path)
        self.handler.setFormatter(logging.Formatter('[%(levelname)s] %(message)s'))
        log = logging.getLogger('rosout')
        # the world's lines go to the run's world log, not to the runner's own output
        # (to the end of the process: the world outlives the run by its teardown)
        for h in [h for h in log.handlers if type(h).__name__ == 'RosStreamHandler']:
            log.removeHandler(h)
        log.addHandler(self.handler)

    def close(self):
        """The run is over: the file is complete (it stays for the log tails)."""
        logging.getLogger('rosout').removeHandler(self.handler)
        self.handler.close()

    def tail(self, n=25):
        self.handler.flush()
        return procs.tail(self.path, n)
