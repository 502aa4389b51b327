"""sim_world: the world server node (the Gazebo analogue), parameters and start-up.

    rosrun mobile_device_sim sim_world [world_file] [_physics_engine:=ode|bullet]
        [_real_time_factor:=1.0] [_max_step_size:=0.001] [_paused:=false]
        [_pub_clock_frequency:=100] [_seed:=N]

Private parameters: ~world_file (default sim_world/worlds/office.world), ~physics_engine,
~max_step_size (default: the world file's, else 0.001 s), ~real_time_factor (default: the
world file's, else 1.0; 0 = as fast as possible), ~paused, ~pub_clock_frequency (Hz of
wall time for /clock, /gazebo/model_states and /tf), ~seed (every random draw of every
plugin derives from it: the same seed gives the same sensor data; default: a random seed,
logged at start so the run can be repeated). Sets /use_sim_time to true unless it is
already set. Besides the Gazebo API (sim_world.gazebo_api) it serves /gazebo/set_environment,
/gazebo/environment and /gazebo/set_sensor_fault (sim_world.world_services).
"""
import os
import sys
import threading

import rospy
import rospy.core

from .gazebo_api import GazeboRosApi, run_loop
from .model import ModelError
ENGINES = ("ode", "bullet")
from .sdf import load_world_file
from .world import World
from .world_services import WorldServices

DEFAULT_WORLD = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                              '..', '..', 'worlds', 'office.world'))


def main(argv=None):
    argv = rospy.myargv(argv if argv is not None else sys.argv)
    if not rospy.has_param('/use_sim_time'):
        rospy.set_param('/use_sim_time', True)
    rospy.init_node('sim_world')
    world_file = rospy.get_param('~world_file', argv[1] if len(argv) > 1 else DEFAULT_WORLD)
    engine = rospy.get_param('~physics_engine', 'ode')
    if engine not in ENGINES:
        rospy.logfatal('sim_world: unknown ~physics_engine %r (choose one of %s)'
                       % (engine, ', '.join(sorted(ENGINES))))
        return 1
    try:
        desc = load_world_file(world_file)
    except ModelError as e:
        rospy.logfatal('sim_world: cannot load world file %s: %s' % (world_file, e))
        return 1
    step = float(rospy.get_param('~max_step_size', desc.max_step_size or 0.001))
    rtf = rospy.get_param('~real_time_factor', None)
    if rtf is None:
        rtf = desc.real_time_factor if desc.real_time_factor is not None else 1.0
    rtf = float(rtf)
    if rtf < 0:
        rospy.logfatal('sim_world: ~real_time_factor must be >= 0, got %g' % rtf)
        return 1
    seed = rospy.get_param('~seed', None)
    if seed is not None and seed != '':
        try:
            seed = int(seed)
            if seed < 0:
                raise ValueError
        except (TypeError, ValueError):
            rospy.logfatal('sim_world: ~seed must be a whole number >= 0, got %r' % (seed,))
            return 1
    else:
        seed = None
    try:
        world = World(physics=engine, step_size=step, gravity=desc.gravity, ros_enabled=True,
                      seed=seed, logger=_RospyLogger())
    except ValueError as e:
        rospy.logfatal('sim_world: %s' % e)
        return 1
    try:
        world.load_world_file(world_file)
    except ModelError as e:
        rospy.logfatal('sim_world: cannot load world file %s: %s' % (world_file, e))
        return 1
    api = GazeboRosApi(world, paused=bool(rospy.get_param('~paused', False)))
    services = WorldServices(world)  # noqa: F841 - keeps the services alive
    rospy.loginfo('sim_world: world %r from %s, %d models, physics %s, step %g s, '
                  'real_time_factor %g, seed %d', world.name, world_file, len(world.models),
                  engine, step, rtf, world.seed)
    # The world runs in its own thread; the main thread only waits in rospy.spin(). rospy
    # handles SIGINT/SIGTERM in the main thread: had that thread been inside a publish()
    # when the signal came, rospy's shutdown would wait for the lock that very thread holds,
    # and roslaunch had to escalate to SIGKILL.
    failed = []

    def world_thread():
        try:
            run_loop(world, api, real_time_factor=rtf,
                     publish_rate=float(rospy.get_param('~pub_clock_frequency', 100.0)))
        except Exception as e:  # noqa: BLE001 - say what stopped the world, then stop the node
            if rospy.is_shutdown() or rospy.core.is_shutdown_requested():
                # the node is shutting down (Ctrl-C, roslaunch's end, rostest's teardown)
                # while a step was publishing: rospy closed the topic under it. A normal end,
                # not a failure (it used to print a FATAL line at every tools/demo --exit).
                rospy.logdebug('sim_world: world loop ended with the node (%s: %s)'
                               % (type(e).__name__, e))
                return
            failed.append(e)
            rospy.logfatal('sim_world: the world loop stopped: %s: %s' % (type(e).__name__, e))
            rospy.signal_shutdown('world loop failed')
        finally:
            world.shutdown()

    thread = threading.Thread(target=world_thread, name='sim_world_loop', daemon=True)
    thread.start()
    rospy.spin()
    thread.join(timeout=10.0)
    return 1 if failed else 0


class _RospyLogger(object):
    """logging-style calls ('%s' formatting) routed to rospy's log."""

    @staticmethod
    def _fmt(msg, args):
        return msg % args if args else msg

    def info(self, msg, *args):
        rospy.loginfo(self._fmt(msg, args))

    def warning(self, msg, *args):
        rospy.logwarn(self._fmt(msg, args))

    warn = warning

    def error(self, msg, *args):
        rospy.logerr(self._fmt(msg, args))

    def debug(self, msg, *args):
        rospy.logdebug(self._fmt(msg, args))
