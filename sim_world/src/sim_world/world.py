"""The simulated world: models, physics, sim time, plugins and the renderer.

``World`` knows nothing of ROS services (``sim_world.gazebo_api`` adds those); it can run in a
unit test with no roscore. The world advances in fixed physics steps of sim time; each
plugin (camera, video texture, ...) is called when sim time reaches its next period, so a
sensor's rate in sim time does not depend on how fast anything renders. Every access from
another thread (ROS service callbacks) takes ``world.lock``.
"""
import logging
import math
import threading
from collections import OrderedDict

import numpy as np

from . import plugins as plugin_registry
from .plugins.timer import EPS as TIMER_EPS
from .environment import Environment
from .logonce import LogOnce
from .model import ModelError
from .physics import make_engine
from .sdf import load_world_file
from .transforms import InvalidPose, Pose

__all__ = ['World', 'WORLD_FRAMES']

log = logging.getLogger('sim_world.world')
_TIME = [None]                 # rospy.Time, once World.ros_now was first asked

#: names that mean "the world frame" in relative_entity_name / reference_frame
WORLD_FRAMES = ('', 'world', 'map', '/world', '/map')


class PowerBus(object):
    """What each phone's components draw now (W) and its switches (WiFi on, display on,
    charger in ...): outputs and radios report here, the battery reads here."""

    def __init__(self):
        self._draws = {}
        self._flags = {}

    def set_draw(self, model, component, watts):
        watts = float(watts)
        if not (math.isfinite(watts) and watts >= 0):
            raise ValueError('power draw of %s must be a number >= 0 W, got %r'
                             % (component, watts))
        self._draws.setdefault(model, {})[component] = watts

    def draws(self, model):
        return dict(self._draws.get(model, {}))

    def total(self, model):
        return sum(self._draws.get(model, {}).values())

    def set_flag(self, model, name, value):
        self._flags.setdefault(model, {})[name] = value

    def flag(self, model, name, default=None):
        return self._flags.get(model, {}).get(name, default)

    def forget(self, model):
        self._draws.pop(model, None)
        self._flags.pop(model, None)



def _clash_text(name, other, ros_name, filename):
    """The one line refusing model ``name`` whose plugin would take ``ros_name`` of model
    ``other``'s."""
    return ('model %r clashes with model %r: both would use %s%s; spawn it in a namespace '
            'of its own (spawn_model -robot_namespace /%s)'
            % (name, other, ros_name, ' (plugin %s)' % filename if filename else '', name))

class World(object):
    def __init__(self, physics='ode', step_size=0.001, gravity=(0.0, 0.0, -9.81),
                 ros_enabled=False, logger=None, seed=None):
        self.log = logger or log
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (2 ** 31))
            self.log.info('world seed %d (no seed given: pass it as ~seed / seed:= to repeat '
                          'this run)', seed)
        try:
            seed = int(seed)
        except (TypeError, ValueError):
            raise ValueError('seed must be a whole number, got %r' % (seed,))
        if seed < 0:
            raise ValueError('seed must be >= 0, got %d' % seed)
        self.seed = seed
        self.environment = Environment()
        self.power = PowerBus()
        self.lock = threading.RLock()
        self.step_size = float(step_size)
        if not (self.step_size > 0 and math.isfinite(self.step_size)):
            raise ValueError('max_step_size must be a positive number, got %r' % step_size)
        self.physics_name = physics
        self.physics = make_engine(physics, self.step_size, gravity)
        self.gravity = np.asarray(gravity, float)
        self.ros_enabled = ros_enabled
        self.name = 'default'
        self.models = OrderedDict()       # name -> Model
        self.plugins = OrderedDict()      # model name -> [Plugin]
        self.lights = []
        self.shadows = False              # <scene><shadows>: spot lights' shadows in cameras
        #: cameras render in the renderer's worker thread, overlapping the stepping (frames
        #: still show and are stamped with their tick's scene and time; see step, flush)
        self.parallel_render = True
        self.ambient = np.array([0.4, 0.4, 0.4, 1.0])
        self.background = np.array([0.7, 0.7, 0.75, 1.0])
        self.steps = 0
        self.pass_states = None           # see _update_plugins
        self.sim_time = 0.0
        self._initial = {}                # model name -> Pose at spawn (reset_world)
        self._renderer = None
        self._shared = {}                 # see shared()
        self._plugin_failed = LogOnce(self.log)   # one line per failing plugin
        self._next_plugin_time = math.inf
        self._static_poses = {}           # model name -> {link: Pose} for static models
        self.on_model_added = []          # callbacks(model) (ROS API: tf_static)
        self.on_model_deleted = []
        self.before_plugin_updates = []   # callbacks(sim_time) (ROS API: /clock first)

    def set_gravity(self, g):
        """The gravity (m/s^2, world frame) of the engine and of what reads ``gravity``
        (the IMU's, the pose sensors'): the world file's, or /gazebo/set_physics_properties'."""
        self.physics.set_gravity(g)
        self.gravity = np.asarray(self.physics.gravity, float)

    # -- loading ---------------------------------------------------------------------------
    def load_world_file(self, path):
        """Load an SDF world file. Raises ModelError naming the file or element."""
        desc = load_world_file(path)
        self.name = desc.name
        self.set_gravity(desc.gravity)
        self.lights = list(desc.lights)
        self.shadows = bool(desc.shadows)
        self.ambient, self.background = desc.ambient, desc.background
        if desc.environment is not None:
            transmitters = self.environment.transmitters
            self.environment = desc.environment
            self.environment.transmitters.extend(transmitters)
        for m in desc.models:
            self.add_model(m)
        if self._renderer is not None:
            self._renderer.set_lights(self.lights, ambient=self.ambient[:3],
                                      shadows=self.shadows)
        return desc

    def add_model(self, model, pose=None):
        """Add a Model (physics, renderer, plugins). Raises ModelError on a clash or bad
        model; on error nothing of the model stays in the world."""
        with self.lock:
            if model.name in self.models:
                raise ModelError('a model named %r already exists' % model.name)
            if pose is not None:
                model.pose = pose
            model.validate()
            self.physics.add_model(model)
            self.models[model.name] = model
            self._initial[model.name] = model.pose.copy()
            if model.static:
                self._static_poses[model.name] = self.physics.link_poses(model.name)
            if self._renderer is not None:
                try:
                    self._renderer.add_model(model)
                except Exception as e:  # noqa: BLE001 - a bad mesh must not take the world down
                    self.log.error('model %s: cannot draw it: %s', model.name, e)
            self.plugins[model.name] = []
            taken = self._ros_names() if self.ros_enabled else {}
            try:
                for spec in model.plugins:
                    p = plugin_registry.create(spec, model, self, logger=self.log)
                    if p is not None:
                        p.timer.reset(self.sim_time)
                        self.plugins[model.name].append(p)
                        self._refuse_clash(model, p, taken)
            except ModelError as e:
                self.delete_model(model.name)   # its loaded plugins, body and drawing
                # rospy's own refusal of a second service of that name, said the same way
                n = next((n for n in sorted(taken) if '[%s]' % n in str(e)), None)
                if n is None:
                    raise
                raise ModelError(_clash_text(model.name, taken[n], n, None)) from None
            self.reschedule()
            for cb in self.on_model_added:
                cb(model)
            return model

    def _ros_names(self):
        """{resolved topic or service name: model name} of every plugin in the world."""
        taken = {}
        for name, plugins in self.plugins.items():
            for p in plugins:
                for n in p.ros_names():
                    taken.setdefault(n, name)
        return taken

    def _refuse_clash(self, model, plugin, taken):
        """ModelError when ``plugin`` (of ``model``, being added) took a topic or service of
        another model's (two phones from one description, neither spawned in a namespace of
        its own: one IMU topic for both, ``set_device_time`` registered twice)."""
        for n in sorted(plugin.ros_names()):
            other = taken.get(n)
            if other is not None and other != model.name:
                raise ModelError(_clash_text(model.name, other, n, plugin.spec.filename))

    def delete_model(self, name):
        with self.lock:
            if name not in self.models:
                raise KeyError('no model named %r' % name)
            for p in self.plugins.pop(name, []):
                try:
                    p.shutdown()
                except Exception as e:  # noqa: BLE001
                    self.log.error('plugin %s of %s failed to shut down: %s', p.spec.filename,
                                   name, e)
            self.physics.remove_model(name)
            if self._renderer is not None:
                self._renderer.remove_model(name)
            del self.models[name]
            self._initial.pop(name, None)
            self._static_poses.pop(name, None)
            self.power.forget(name)
            self.reschedule()
            for cb in self.on_model_deleted:
                cb(name)

    # -- renderer ----------------------------------------------------------------------------
    @property
    def renderer(self):
        """The one offscreen renderer, created on first use (most worlds without cameras
        never pay for a GL context)."""
        if self._renderer is None:
            from .render import Renderer
            r = Renderer()
            r.set_lights(self.lights, ambient=self.ambient[:3], shadows=self.shadows)
            if hasattr(r, 'set_background'):
                r.set_background(self.background)
            for m in self.models.values():
                try:
                    r.add_model(m)
                except Exception as e:  # noqa: BLE001
                    self.log.error('model %s: cannot draw it: %s', m.name, e)
            self._renderer = r
            # poses are pulled once per render, not pushed on every plugin tick
            if hasattr(r, 'set_pose_source'):
                r.set_pose_source(self.link_poses)
            self.sync_renderer(force=True)
            # let plugins that waited for a GL context (video textures) draw before the
            # first frame is rendered
            for ps in self.plugins.values():
                for p in ps:
                    try:
                        p.renderer_created(r)
                    except Exception as e:  # noqa: BLE001
                        self.log.error('plugin %s of model %s: %s', p.spec.filename,
                                       p.model.name, e)
        return self._renderer

    def sync_renderer(self, force=False):
        """Push every link's current world pose to the renderer (a renderer that pulls them
        itself at each render needs nothing, unless ``force``)."""
        if self._renderer is None:
            return
        if not force and getattr(self._renderer, '_pose_source', None) is not None:
            return
        for name in self.models:
            self._renderer.set_link_poses(name, self.link_poses(name))

    def prepare_renderer(self):
        """Create the renderer now if a plugin will draw at its next tick (a camera with a
        subscriber), so that the GL context, the imports and the upload of the models'
        meshes (about 0.3 s) happen before a run's first step, as Gazebo loads its
        rendering with its sensors, and not inside the first frame's tick. True when the
        world has a renderer after the call."""
        if self._renderer is None:
            for ps in self.plugins.values():
                for p in ps:
                    try:
                        draws = p.will_draw()
                    except Exception:  # noqa: BLE001 - then its tick creates it, as before
                        draws = False
                    if draws:
                        self.renderer
                        return True
        return self._renderer is not None

    @property
    def renderer_if_created(self):
        """The renderer if a camera made one, else None (plugins that only change what
        cameras see have nothing to do without one)."""
        return self._renderer

    # -- what plugins share ----------------------------------------------------------------------
    def shared(self, name, factory):
        """The world's one object named ``name`` (an NFC proxy, an audio scene), made by
        ``factory(world)`` on first use: per-world state of a plugin family."""
        obj = self._shared.get(name)
        if obj is None:
            obj = self._shared[name] = factory(self)
        return obj

    def transmitters(self, kind=None):
        """The radio transmitters in the world (of one ``kind``: wifi, cell, bluetooth), in
        a stable order (by id)."""
        txs = [t for t in self.environment.transmitters if kind is None or t.kind == kind]
        return sorted(txs, key=lambda t: (t.id, t.model))

    def add_transmitter(self, tx):
        self.environment.transmitters.append(tx)

    def remove_transmitter(self, tx):
        if tx in self.environment.transmitters:
            self.environment.transmitters.remove(tx)

    def contacts(self, model_name, link_name=None):
        """The physics engine's contact points of a model (or one link of it) now."""
        return self.physics.contacts(model_name, link_name)

    def apply_wrench(self, model_name, force, torque=None, steps=1, key=None):
        """A force (N) and torque (N m) in the world frame on a model for ``steps`` physics
        steps (None: until cleared; rows of forces: one per step) under ``key``."""
        return self.physics.apply_wrench(model_name, force, torque, steps=steps, key=key)

    def clear_wrench(self, model_name, key):
        """End the wrench ``key`` on a model (nothing if the model is gone)."""
        try:
            self.physics.clear_wrench(model_name, key)
        except KeyError:
            pass

    # -- state -------------------------------------------------------------------------------
    def raycast(self, origin, direction, max_dist, ignore=()):
        """First collision surface along a ray, or None (sim_world.raycast)."""
        from .raycast import raycast
        return raycast(self, origin, direction, max_dist, ignore)

    def segment_intervals(self, a, b, ignore=(), incidence=False):
        """Parts of the segment a->b inside solid shapes (sim_world.raycast); with
        ``incidence`` each part also holds the shape's thickness (m)."""
        from .raycast import segment_intervals
        return segment_intervals(self, a, b, ignore, incidence)

    def link_poses(self, model_name):
        if model_name in self._static_poses:
            return self._static_poses[model_name]
        return self.physics.link_poses(model_name)

    def link_pose(self, model_name, link_name):
        if model_name in self._static_poses:
            poses = self._static_poses[model_name]
            if link_name not in poses:
                raise KeyError('model %r has no link %r' % (model_name, link_name))
            return poses[link_name]
        if model_name not in self.models:
            raise KeyError('no model named %r' % model_name)
        return self.physics.link_pose(model_name, link_name)

    def joint_states(self, model_name):
        """{joint: (position, velocity)} of a model's simulated joints ({} for a model
        that is one rigid body); KeyError for an unknown model."""
        if model_name not in self.models:
            raise KeyError('no model named %r' % model_name)
        return self.physics.joint_states(model_name)

    def model_state(self, name):
        """(Pose, linear, angular) of a model's root link in the world."""
        if name not in self.models:
            raise KeyError('no model named %r' % name)
        if name in self._static_poses:
            return self.models[name].pose, np.zeros(3), np.zeros(3)
        pose, lin, ang = self.physics.model_state(name)
        return pose, np.asarray(lin, float), np.asarray(ang, float)

    def pass_state(self, entity):
        """``entity_state``, read once per plugin pass: the sensors on the same link share it
        (a teleport during the pass clears it, nothing outlives the pass)."""
        cache = self.pass_states
        if cache is None:
            return self.entity_state(entity)
        got = cache.get(entity)
        if got is None:
            got = cache[entity] = self.entity_state(entity)
        return got

    def entity_state(self, entity):
        """State of a model, of 'model::link', or of a link name unique in the world."""
        if entity in self.models:
            return self.model_state(entity)
        model_name, link = None, entity
        if '::' in entity:
            model_name, link = entity.split('::', 1)
            if model_name not in self.models:
                raise KeyError('no model named %r' % model_name)
        else:
            owners = [n for n, m in self.models.items() if entity in m.links]
            if len(owners) > 1:
                raise KeyError('link name %r is ambiguous (models %s): use model::link'
                               % (entity, ', '.join(owners)))
            if not owners:
                raise KeyError('no model or link named %r' % entity)
            model_name = owners[0]
        if model_name in self._static_poses:
            pose = self.link_pose(model_name, link)
            root, lin, ang = self.model_state(model_name)
        elif self.physics._get(model_name).art is not None:
            return self.physics.link_state(model_name, link)   # a link with a body of its own
        else:
            off = self.physics._get(model_name).spec.link_offsets.get(link)
            if off is None:
                raise KeyError('model %r has no link %r' % (model_name, link))
            root, lin, ang = self.model_state(model_name)
            pose = root * off       # = physics.link_pose, the body read once
        # lin + ang x (pose.p - root.p), in plain floats (np.cross is slow on 3-vectors)
        a0, a1, a2 = ang.tolist()
        p0, p1, p2 = pose.p.tolist()
        r0, r1, r2 = root.p.tolist()
        b0, b1, b2 = p0 - r0, p1 - r1, p2 - r2
        v0, v1, v2 = lin.tolist()
        lin = np.array((v0 + (a1 * b2 - a2 * b1), v1 + (a2 * b0 - a0 * b2),
                        v2 + (a0 * b1 - a1 * b0)))
        return pose, lin, ang

    def get_state(self, name, relative_to=''):
        """Model state relative to an entity frame (Gazebo's get_model_state)."""
        pose, lin, ang = self.model_state(name)
        if relative_to in WORLD_FRAMES:
            return pose, lin, ang
        fpose, flin, fang = self.entity_state(relative_to)
        rinv = fpose.inverse()
        return (fpose.inverse() * pose, rinv.rotate(lin - flin), rinv.rotate(ang - fang))

    def set_state(self, name, pose, lin=None, ang=None, reference_frame=''):
        """Teleport a model; pose and twist are given in ``reference_frame``."""
        if name not in self.models:
            raise KeyError('no model named %r' % name)
        if not isinstance(pose, Pose):
            raise InvalidPose('pose must be a Pose')
        lin = np.zeros(3) if lin is None else np.asarray(lin, float)
        ang = np.zeros(3) if ang is None else np.asarray(ang, float)
        if not (np.all(np.isfinite(lin)) and np.all(np.isfinite(ang))):
            raise InvalidPose('twist has a non-finite value')
        if reference_frame not in WORLD_FRAMES:
            fpose, _, _ = self.entity_state(reference_frame)
            pose = fpose * pose
            lin, ang = fpose.rotate(lin), fpose.rotate(ang)
        model = self.models[name]
        if self.pass_states:
            self.pass_states.clear()
        if model.static:
            model.pose = pose
            self.physics.set_model_pose(name, pose)
            self._static_poses[name] = self.physics.link_poses(name)
            return
        self.physics.set_model_pose(name, pose)
        self.physics.set_model_twist(name, lin, ang)

    # -- randomness --------------------------------------------------------------------------
    def rng(self, *keys):
        """A numpy Generator derived from the world's seed and text keys (a plugin passes
        its model and plugin names): the same seed gives the same draws, whatever else runs
        in the world and in whatever order plugins load."""
        from .plugins.sensor import stable_seed
        return np.random.Generator(np.random.PCG64(
            np.random.SeedSequence([self.seed] + stable_seed(*keys))))

    def find_plugins(self, model_name, key=None):
        """Plugins of a model matching ``key``: the plugin's name, its library file name,
        or one of its topics (None: all)."""
        found = []
        for p in self.plugins.get(model_name, []):
            topics = [getattr(q, 'topic', None) for q in getattr(p, 'pubs', [])]
            topics.append(getattr(p, 'topic', None))
            topics = [t for t in topics if t]
            k = (key or '').strip('/')
            if key is None or key in (p.spec.name, p.spec.filename) or any(
                    t.strip('/') == k or t.endswith('/' + k) for t in topics):
                found.append(p)
        return found

    # -- time ----------------------------------------------------------------------------------
    def ros_now(self):
        """Sim time as a new rospy.Time (every stamp of every message: made without
        genpy's checking constructor, 0.11 us instead of 0.77 us; the fields are whole
        numbers here already)."""
        ns = int(round(self.steps * self.step_size * 1e9))
        cls = _TIME[0]
        if cls is None:
            import rospy                     # late: rospy is heavy, and not needed before
            cls = _TIME[0] = rospy.Time
        t = cls.__new__(cls)
        t.secs, t.nsecs = ns // 1000000000, ns % 1000000000
        return t

    def step(self, n=1, wait=True):
        """Advance n fixed steps, running plugins that fall due. Cameras render in the
        renderer's worker thread meanwhile (``parallel_render``); with ``wait`` every frame
        of these steps has been delivered when step returns (``flush``); the run loop of
        the sim_world node passes False and flushes when it pauses or ends a slice."""
        physics = self.physics
        dt = self.step_size
        for _ in range(n):
            physics.step()
            self.steps += 1
            self.sim_time = self.steps * dt
            if self.sim_time + 1e-12 >= self._next_plugin_time:
                self._update_plugins()
        if wait:
            self.flush()

    def flush(self):
        """Return when the frame rendering in the renderer's worker thread (if any) has been
        delivered (published, ``last_image`` set)."""
        r = self._renderer
        if r is not None and hasattr(r, 'wait_idle'):
            r.wait_idle()

    def _update_plugins(self):
        t = self.sim_time
        te = t + TIMER_EPS
        # UpdateTimer.due's first test inline: a plugin with a rate whose next firing is
        # later is skipped without two calls (with one plugin updating every step, the
        # arm's controller, this scan ran every step over every plugin of the world)
        due = [p for ps in self.plugins.values() for p in ps
               if not (p.timer.rate > 0 and te < p.timer.next_time) and p.due(t)]
        if due:
            for cb in self.before_plugin_updates:
                cb(t)
            self.sync_renderer()
            # link states read during this pass, shared by the sensors on the same link
            # (Sensor.state); a teleport during the pass clears it, nothing outlives it
            self.pass_states = {}
            try:
                for p in due:
                    try:
                        p.update(t)
                    except Exception as e:  # noqa: BLE001 - one bad plugin must not stop the world
                        self._plugin_failed.error(
                            'plugin %s of model %s failed at t=%.3f: %s: %s'
                            % (p.spec.filename, p.model.name, t, type(e).__name__, e),
                            key=id(p))
            finally:
                self.pass_states = None
        self.reschedule()

    def reschedule(self):
        """Recompute when the next plugin falls due (after a plugin changed its rate)."""
        nxt = math.inf
        now = self.sim_time
        for ps in self.plugins.values():
            for p in ps:
                tm = p.timer                   # UpdateTimer.next_due, inline (every step
                if tm.rate > 0:                # while a plugin updates every step)
                    t = tm.next_time
                else:
                    t = now if now > tm.offset else tm.offset
                if t < nxt:
                    nxt = t
        self._next_plugin_time = nxt

    def reset(self, time=False):
        """Gazebo's reset_world (poses back, twists zero); with time=True also the clock
        (reset_simulation)."""
        self.flush()
        with self.lock:
            self.physics.detach_all()      # the link attacher's joints (a run starts free)
            for name, pose in self._initial.items():
                self.set_state(name, pose.copy())
                self.physics.reset_joints(name)    # joints to their spawn values, at rest
            if time:
                self.steps = 0
                self.sim_time = 0.0
            for ps in self.plugins.values():
                for p in ps:
                    p.reset()
                    p.timer.reset(self.sim_time)
            self.reschedule()

    def shutdown(self):
        self.flush()
        for name in list(self.plugins):
            for p in self.plugins[name]:
                try:
                    p.shutdown()
                except Exception:  # noqa: BLE001
                    pass
        self.plugins.clear()
        if self._renderer is not None and hasattr(self._renderer, 'close'):
            try:
                self._renderer.close()   # its GL objects leave the shared context
            except Exception as e:  # noqa: BLE001 - a world going away must go away
                self.log.warning('closing the renderer: %s', e)
            self._renderer = None
        close = getattr(self.physics, 'close', None)
        if close is not None:
            close()   # frees Bullet's native client now, not at garbage collection

