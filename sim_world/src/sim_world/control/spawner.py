"""``rosrun mobile_device_sim spawner NAME...``: controller_manager's spawner (issue 48 part 4).

    spawner [--stopped] [--namespace NS] [--timeout T | --no-timeout]
            [--shutdown-timeout T] [--wait-for TOPIC] NAME_OR_YAML...

As controller_manager's: the services ``controller_manager/{load,switch,unload}_controller``
are resolved relative to the node's namespace (``ROS_NAMESPACE``, ``__ns:=``) with
``--namespace`` in front; it waits for them (``--timeout``, default 30 s; 0 or
``--no-timeout``: for ever), loads every named controller (an argument that is a YAML file
is put on the parameter server and its top-level keys are the controllers), starts all of
the loaded ones in one STRICT switch (not with ``--stopped``), then waits; on shutdown
(SIGINT, roslaunch's end) it stops them in one switch and unloads them in reverse order,
the calls given at most ``--shutdown-timeout`` s (default 3) each. ``--wait-for TOPIC``: loads
nothing until ``True`` arrives on that std_msgs/Bool topic. A controller that fails to load
is one error line; the others are loaded and started.

The node (sim_world/nodes/spawner) is ``main()`` of this module; ``Spawner`` does the work
with service proxies given to it, so the sequence is unit-tested without a roscore.
"""
import argparse
import os
import sys

__all__ = ['Spawner', 'parse_args', 'service_names', 'main']


def parse_args(argv):
    ap = argparse.ArgumentParser(prog='spawner', description='Controller spawner (loads, '
                                 'starts, and on shutdown stops and unloads controllers)')
    ap.add_argument('--stopped', action='store_true', help='load the controllers, do not '
                    'start them')
    ap.add_argument('--wait-for', metavar='TOPIC', help='load nothing until True arrives '
                    'on this std_msgs/Bool topic')
    ap.add_argument('--namespace', metavar='NS', help='namespace of the controller_manager '
                    'services')
    ap.add_argument('--timeout', metavar='T', type=float, default=30.0,
                    help='s to wait for the controller_manager services (<= 0: for ever)')
    ap.add_argument('--no-timeout', action='store_true', help='wait for the services for '
                    'ever (as --timeout 0)')
    ap.add_argument('--shutdown-timeout', metavar='T', type=float, default=3.0,
                    help='s each stop/unload call may take on shutdown (default 3)')
    ap.add_argument('controllers', metavar='controller', nargs='+',
                    help='controller names, or YAML files of controllers')
    return ap.parse_args(argv)


def service_names(namespace=None):
    """{'load': ..., 'switch': ..., 'unload': ...}: relative names (the node's namespace
    applies) with ``namespace`` in front."""
    ns = (namespace or '').rstrip('/')
    pre = ns + '/' if ns else ''
    return dict((k, pre + 'controller_manager/%s_controller' % k)
                for k in ('load', 'switch', 'unload'))


class Spawner(object):
    """The sequence, over callables ``load(name) -> ok``, ``switch(start, stop) -> ok``,
    ``unload(name) -> ok`` and a logger."""

    def __init__(self, load, switch, unload, log):
        self.load, self.switch, self.unload, self.log = load, switch, unload, log
        self.loaded = []

    def start(self, names, stopped=False):
        for name in names:
            self.log.info('Loading controller: %s' % name)
            if self.load(name):
                self.loaded.append(name)
            else:
                self.log.error('Failed to load %s' % name)
        self.log.info('Controller Spawner: Loaded controllers: %s' % ', '.join(self.loaded))
        if stopped or not self.loaded:
            return bool(self.loaded) or not names
        if self.switch(list(self.loaded), []):
            self.log.info('Started controllers: %s' % ', '.join(self.loaded))
            return True
        self.log.error('Failed to start controllers: %s' % ', '.join(self.loaded))
        return False

    def stop(self):
        """Stop every loaded controller in one switch, then unload them in reverse order."""
        if not self.loaded:
            return
        self.log.info('Shutting down spawner. Stopping and unloading controllers...')
        try:
            self.switch([], list(self.loaded))
            for name in reversed(self.loaded):
                if not self.unload(name):
                    self.log.warn('could not unload %s' % name)
        except Exception as e:  # noqa: BLE001 - the node is going away: say it, do not hang
            self.log.warn('Controller Spawner error while taking down controllers: %s' % e)
        self.loaded = []


def expand(args, set_param=None):
    """Controller names from the arguments: a YAML file's top-level keys (the file goes on
    the parameter server through ``set_param(text)``), other arguments as they are."""
    out = []
    for a in args:
        if os.path.isfile(a):
            import yaml
            with open(a) as f:
                text = f.read()
            data = yaml.safe_load(text) or {}
            if not isinstance(data, dict):
                raise ValueError('%s: not a YAML mapping of controllers' % a)
            if set_param is not None:
                set_param(text)
            out.extend(data)
        else:
            out.append(a)
    return out


def main(argv=None):
    import rospy
    from mobile_device_sim.srv import (LoadController, SwitchController,
                                       SwitchControllerRequest, UnloadController)
    argv = rospy.myargv(sys.argv if argv is None else argv)[1:]
    args = parse_args(argv)
    timeout = None if args.no_timeout or args.timeout <= 0 else args.timeout
    rospy.init_node('spawner', anonymous=True)
    names = service_names(args.namespace)
    for key in ('load', 'switch', 'unload'):
        rospy.loginfo('Controller Spawner: Waiting for service %s'
                      % rospy.resolve_name(names[key]))
        try:
            rospy.wait_for_service(names[key], timeout=timeout)
        except rospy.ROSException:
            rospy.logerr("Controller Spawner couldn't find the expected controller_manager "
                         "ROS interface (%s within %g s)" % (rospy.resolve_name(names[key]),
                                                            timeout))
            return 1
        except rospy.ROSInterruptException:
            return 0
    load = rospy.ServiceProxy(names['load'], LoadController)
    switch = rospy.ServiceProxy(names['switch'], SwitchController)
    unload = rospy.ServiceProxy(names['unload'], UnloadController)
    if args.wait_for:
        from std_msgs.msg import Bool
        while not rospy.is_shutdown():
            try:
                if rospy.wait_for_message(args.wait_for, Bool, timeout=1.0).data:
                    break
            except rospy.ROSException:
                continue
    strict = SwitchControllerRequest.STRICT

    def call(proxy, *a):
        return proxy(*a).ok

    def set_param(text):
        import rosparam
        for params, ns in rosparam.load_str(text, '<yaml>',
                                            default_namespace=rospy.get_namespace()):
            rosparam.upload_params(ns, params)

    sp = Spawner(lambda n: call(load, n),
                 lambda start, stop: call(switch, start, stop, strict, False, 0.0),
                 lambda n: call(unload, n), _Log(rospy))
    done_timeout = args.shutdown_timeout

    def take_down():
        # a pre-shutdown hook runs before rospy's shutdown flag: services still work here
        _with_timeout(sp.stop, done_timeout * (1 + len(sp.loaded)))
    rospy.core.add_preshutdown_hook(lambda reason: take_down())
    try:
        controllers = expand(args.controllers, set_param)
    except (ValueError, OSError) as e:
        rospy.logerr('Controller Spawner: %s' % e)
        return 1
    try:
        ok = sp.start(controllers, stopped=args.stopped)
    except rospy.ServiceException as e:
        rospy.logerr('Controller Spawner: %s' % e)
        ok = False
    if not ok and not sp.loaded:
        return 1
    rospy.spin()
    return 0


def _with_timeout(fn, seconds):
    """Run fn in a thread; give up waiting after ``seconds`` (the node exits anyway)."""
    import threading
    t = threading.Thread(target=fn, daemon=True, name='spawner shutdown')
    t.start()
    t.join(seconds)


class _Log(object):
    def __init__(self, rospy):
        self.info, self.error, self.warn = rospy.loginfo, rospy.logerr, rospy.logwarn
