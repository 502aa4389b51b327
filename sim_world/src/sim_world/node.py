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
import gc
import importlib
import math
import os
import sys
import threading
import time

import rospy
import rospy.core

from . import transport
from .gazebo_api import GazeboRosApi, run_loop
from .model import MAX_POSITION, ModelError
ENGINES = ("ode", "bullet")
from .sdf import load_world_file
from .world import World
from .world_services import WorldServices

DEFAULT_WORLD = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                              '..', '..', 'worlds', 'office.world'))


class SetupError(Exception):
    """The node's parameters or world file are wrong: the one line to log (FATAL)."""


def _number(name, default):
    """Private parameter ``name`` as a float (SetupError: not a number)."""
    v = rospy.get_param(name, default)
    try:
        if isinstance(v, bool):
            raise ValueError
        return float(v)
    except (TypeError, ValueError):
        raise SetupError('%s must be a number, got %r' % (name, v))


def main(argv=None):
    import faulthandler
    import signal
    # kill -USR2 <pid>: every thread's Python stack to the log (a stuck or growing node)
    faulthandler.register(signal.SIGUSR2, all_threads=True)
    argv = rospy.myargv(argv if argv is not None else sys.argv)
    if not rospy.has_param('/use_sim_time'):
        rospy.set_param('/use_sim_time', True)
    rospy.init_node('sim_world')
    try:
        host = host_from_params(argv)
    except SetupError as e:
        rospy.logfatal('sim_world: %s' % e)
        return 1
    thread, failed = host.start()
    rospy.spin()
    thread.join(timeout=10.0)
    return 1 if failed else 0


def host_from_params(argv=()):
    """The WorldHost this (initialised) node's private parameters describe (the module
    docstring lists them); ``argv[1]``, when given, is the world file. SetupError: what is
    wrong. Used by the sim_world node and by run_scenario's embedded world."""
    world_file = rospy.get_param('~world_file', argv[1] if len(argv) > 1 else DEFAULT_WORLD)
    engine = rospy.get_param('~physics_engine', 'ode')
    if engine not in ENGINES:
        raise SetupError('unknown ~physics_engine %r (choose one of %s)'
                         % (engine, ', '.join(sorted(ENGINES))))
    try:
        desc = load_world_file(world_file)
    except ModelError as e:
        raise SetupError('cannot load world file %s: %s' % (world_file, e))
    step = _number('~max_step_size', desc.max_step_size or 0.001)
    if not (step > 0 and math.isfinite(step)):
        raise SetupError('~max_step_size must be a number > 0 (s), got %r' % step)
    rtf = _number('~real_time_factor',
                  desc.real_time_factor if desc.real_time_factor is not None else 1.0)
    if not rtf >= 0:
        raise SetupError('~real_time_factor must be >= 0, got %g' % rtf)
    rate = _number('~pub_clock_frequency', 100.0)
    seed = rospy.get_param('~seed', None)
    if seed is not None and seed != '':
        try:
            seed = int(seed)
            if seed < 0:
                raise ValueError
        except (TypeError, ValueError):
            raise SetupError('~seed must be a whole number >= 0, got %r' % (seed,))
    else:
        seed = None
    try:
        host = WorldHost(world_file, engine, step, desc.gravity, rtf, seed,
                         paused=bool(rospy.get_param('~paused', False)),
                         publish_rate=rate)
    except ValueError as e:
        raise SetupError(str(e))
    except ModelError as e:
        raise SetupError('cannot load world file %s: %s' % (world_file, e))
    world = host.world
    rospy.loginfo('sim_world: world %r from %s, %d models, physics %s, step %g s, '
                  'real_time_factor %g, seed %d', world.name, world_file, len(world.models),
                  engine, step, rtf, world.seed)
    return host


POSE_KEYS = ('x', 'y', 'z', 'R', 'P', 'Y')


def _preload_renderer(world, model):
    """A model that can draw (a camera) was added: import the renderer's modules (OpenCV:
    0.2 s) in the background, while the node waits for its first step; the renderer itself
    is made before the first step that needs it (World.prepare_renderer)."""
    from .plugins import Plugin
    if 'sim_world.render' in sys.modules or _PRELOAD:
        return
    if any(type(p).will_draw is not Plugin.will_draw
           for p in world.plugins.get(model.name, ())):
        _PRELOAD.append(threading.Thread(target=importlib.import_module,
                                         args=('sim_world.render',), daemon=True,
                                         name='preload renderer'))
        _PRELOAD[0].start()


_PRELOAD = []


class WorldHost(object):
    """The node's World, the ROS API serving it and the loop stepping it. On
    /gazebo/reload_world (mobile_device_sim/ReloadWorld) it starts the world over in this
    process: the old World shuts down (its plugins unregister every topic and service), a
    new one loads the same file with the requested seed, the models spawned before the
    first reload are spawned again from their requests, and the API serves the new World.
    What a fresh node would have is what the reloaded one has; a farm's warm world saves
    the master, roslaunch, Python and the imports (testing_instance's warm farm)."""

    def __init__(self, world_file, engine, step, gravity, rtf, seed, paused=False,
                 publish_rate=100.0):
        self.world_file, self.engine, self.step, self.gravity = \
            world_file, engine, step, gravity
        self.rtf, self.publish_rate = float(rtf), publish_rate
        self.world = self.build(seed)
        self.api = GazeboRosApi(self.world, paused=paused)
        self.services = WorldServices(self.world)
        self.start_models = None          # [(name, kind, SpawnModel request)]: first reload
        self._pending = None              # (plan, done Event, result box) for the loop
        self._one = threading.Lock()
        from mobile_device_sim.srv import ReloadWorld
        self.reload_srv = transport.service('/gazebo/reload_world', ReloadWorld, self.reload)

    def build(self, seed):
        world = World(physics=self.engine, step_size=self.step, gravity=self.gravity,
                      ros_enabled=True, seed=seed, logger=_RospyLogger())
        world.on_model_added.append(lambda model: _preload_renderer(world, model))
        world.load_world_file(self.world_file)
        return world

    def start(self):
        """Run the world in a thread of its own; returns (thread, [the exception that
        stopped it, if any]). The calling (main) thread stays free: rospy handles SIGINT and
        SIGTERM in the main thread, and had that thread been inside a publish() when the
        signal came, rospy's shutdown would wait for the lock that very thread holds (and
        roslaunch had to escalate to SIGKILL)."""
        failed = []

        def world_thread():
            try:
                self.run()
            except Exception as e:  # noqa: BLE001 - say what stopped it, stop the node
                if rospy.is_shutdown() or rospy.core.is_shutdown_requested():
                    # the node is shutting down (Ctrl-C, roslaunch's end, rostest's
                    # teardown) while a step was publishing: rospy closed the topic under
                    # it. A normal end, not a failure.
                    rospy.logdebug('sim_world: world loop ended with the node (%s: %s)'
                                   % (type(e).__name__, e))
                    return
                failed.append(e)
                rospy.logfatal('sim_world: the world loop stopped: %s: %s'
                               % (type(e).__name__, e))
                rospy.signal_shutdown('world loop failed')
            finally:
                self.world.shutdown()

        thread = threading.Thread(target=world_thread, name='sim_world_loop', daemon=True)
        thread.start()
        return thread, failed

    # -- the loop thread ---------------------------------------------------------------------
    def run(self):
        """The world thread: step until ROS shuts down, reloading between steps when asked."""
        while not rospy.is_shutdown():
            run_loop(self.world, self.api, real_time_factor=self.rtf,
                     publish_rate=self.publish_rate, should_stop=self._stop_loop)
            self.rtf = self.api.real_time_factor     # set_physics_properties' pace is kept
            if self._pending is not None and not rospy.is_shutdown():
                self._do_reload(*self._pending)

    def _stop_loop(self):
        return self._pending is not None or rospy.is_shutdown()

    # -- /gazebo/reload_world ----------------------------------------------------------------
    def reload(self, req):
        from mobile_device_sim.srv import ReloadWorldResponse
        t0 = time.monotonic()
        with self._one:
            if self.api.step_until is not None:
                return self._refused(ReloadWorldResponse, 'a step_world call is running')
            try:
                plan = self._plan(req)
            except ValueError as e:
                return self._refused(ReloadWorldResponse, str(e))
            # a pipelined scenario's last slice, held for its apps, is the old world's
            transport.release(drop=True, stop=True)
            done, box = threading.Event(), {}
            self._pending = (plan, done, box)
            self.api.reset_anchor.set()           # wakes a paused loop at once
            while not done.wait(0.1):
                if rospy.is_shutdown():
                    return self._refused(ReloadWorldResponse, 'the node is shutting down')
        ok, msg = box['result']
        return ReloadWorldResponse(ok, msg, time.monotonic() - t0)

    @staticmethod
    def _refused(cls, why):
        msg = 'ReloadWorld: %s; nothing changed' % why
        rospy.logerr(msg)
        return cls(False, msg, 0.0)

    def _plan(self, req):
        """What a reload request asks for, checked before anything is torn down
        (ValueError: the one line saying what is wrong)."""
        import math
        import yaml
        seed = int(req.seed)
        if seed < -1:
            raise ValueError('seed must be >= 0 (or -1: keep %d), got %d'
                             % (self.world.seed, seed))
        seed = self.world.seed if seed == -1 else seed
        rtf = float(req.real_time_factor)
        now = self.api.real_time_factor      # the pace now (set_physics_properties')
        now = self.rtf if now is None else now
        if not math.isfinite(rtf):        # -inf too: -1 is the 'keep' the type documents
            raise ValueError('real_time_factor must be a number (< 0: keep %g), got %r'
                             % (now, rtf))
        rtf = now if rtf < 0 else rtf
        start = self.start_models
        if start is None:                 # the first reload: what the launch spawned
            start = [(n, kind, r) for n, (kind, r) in self.api.spawned.items()
                     if n in self.world.models]
        try:
            poses = yaml.safe_load(req.start_poses) if req.start_poses.strip() else {}
        except yaml.YAMLError as e:
            raise ValueError('start_poses is not YAML: %s' % str(e).replace('\n', ' '))
        if not isinstance(poses, dict):
            raise ValueError('start_poses must be a mapping {model: {x: .., Y: ..}}, got %r'
                             % (poses,))
        names = [n for n, _k, _r in start]
        for name, o in poses.items():
            if name not in names:
                raise ValueError('start_poses: no remembered model %r (these start again: %s)'
                                 % (name, ', '.join(names) or 'none'))
            if not isinstance(o, dict) or set(o) - set(POSE_KEYS):
                raise ValueError('start_poses: %s: give a mapping of %s, got %r'
                                 % (name, ', '.join(POSE_KEYS), o))
            for k, v in o.items():
                if isinstance(v, bool) or not isinstance(v, (int, float)) or \
                        not math.isfinite(v):
                    raise ValueError('start_poses: %s.%s must be a finite number, got %r'
                                     % (name, k, v))
                # checked now: the spawn would refuse it after the old world is gone
                if k in 'xyz' and abs(v) > MAX_POSITION:
                    raise ValueError('start_poses: %s.%s must be within +-%g m, got %r'
                                     % (name, k, MAX_POSITION, v))
        return dict(seed=seed, rtf=rtf, start=start, poses=poses)

    def _do_reload(self, plan, done, box):
        """In the loop thread, between steps: the old World goes, a new one comes."""
        try:
            box['result'] = self._swap(plan)
        except Exception as e:  # noqa: BLE001 - said to the caller and in the log
            box['result'] = (False, 'ReloadWorld: %s: %s' % (type(e).__name__, e))
            rospy.logerr(box['result'][1])
        finally:
            self._pending = None
            done.set()

    def _swap(self, plan):
        from .spawn import spawn_xml
        t0 = time.monotonic()
        self.start_models = plan['start']
        old = self.world
        with old.lock:
            old.shutdown()           # plugins unregister: the new ones start afresh
        # the old World, its plugins and their rospy topics are reference cycles: without a
        # full collection now, rarely run in this process, each reload kept them (7 MB and
        # ten epoll descriptors of rospy's topic pollers per reload, bench/soak)
        gc.collect()
        _trim_heap()

        def rebuild(seed, poses):
            world = self.build(seed)
            spawned = []
            for name, kind, req in plan['start']:
                req2 = _with_pose(req, poses.get(name))
                ok, msg = spawn_xml(world, kind, name, req2.model_xml, req2.robot_namespace,
                                    req2.initial_pose, req2.reference_frame)
                if not ok:
                    world.shutdown()
                    raise RuntimeError(msg)
                spawned.append((name, (kind, req2)))
            return world, spawned
        try:
            world, spawned = rebuild(plan['seed'], plan['poses'])
        except Exception:
            # the old world is gone: serve it again as it started (then say what failed)
            world, spawned = rebuild(old.seed, {})
            self.world = world
            self.api.attach(world, spawned)
            self.api.paused = True
            self.services.attach(world)
            raise
        self.rtf = plan['rtf']
        self.world = world
        self.api.attach(world, spawned)
        self.api.paused = True
        self.services.attach(world)
        rospy.set_param('~seed', str(world.seed))
        rospy.set_param('~real_time_factor', self.rtf)
        msg = ('ReloadWorld: world %r started over with seed %d (%d models, %d spawned again), '
               'real_time_factor %g, in %.3f s' % (world.name, world.seed, len(world.models),
                                                  len(spawned), self.rtf,
                                                  time.monotonic() - t0))
        rospy.loginfo('sim_world: ' + msg)
        return True, msg


def _trim_heap():
    """Give the heap pages the old world freed back to the system (glibc's malloc_trim):
    its threads' arenas keep them otherwise, and a warm world's RSS grew by megabytes a
    reload (bench/soak)."""
    try:
        import ctypes
        ctypes.CDLL('libc.so.6').malloc_trim(0)
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def _with_pose(req, over):
    """A copy of SpawnModel request ``req`` whose initial pose has the values of ``over``
    ({x, y, z, R, P, Y}); the quaternion is kept exactly unless R, P or Y is given."""
    import copy
    from .transforms import Pose
    if not over:
        return req
    req = copy.deepcopy(req)
    p = req.initial_pose.position
    p.x, p.y, p.z = (float(over.get(k, v)) for k, v in zip('xyz', (p.x, p.y, p.z)))
    if set(over) & set('RPY'):
        rpy = Pose.from_msg(req.initial_pose).rpy()
        rpy = [float(over.get(k, v)) for k, v in zip('RPY', rpy)]
        q = Pose.from_xyz_rpy((0, 0, 0), rpy).q
        o = req.initial_pose.orientation
        o.x, o.y, o.z, o.w = (float(v) for v in q)
    return req


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
