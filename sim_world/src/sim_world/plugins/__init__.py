"""World plugins: one registry, one lifecycle, one place to add a sensor.

A plugin is a class registered under the library file names a URDF uses for it, in both
syntaxes the simulator reads::

    <!-- 2011, thesis appendix A -->
    <controller:gazebo_ros_camera name="c" plugin="libgazebo_ros_camera.so"> ...
    <!-- Gazebo classic -->
    <plugin name="c" filename="libgazebo_ros_camera.so"> ...

Lifecycle, driven by ``sim_world.world.World``:

1. ``cls(spec, model, world)``: spec is a ``sim_world.model.PluginSpec`` (its ``param()``
   reads the plugin's and the enclosing sensor's parameters), model the ``Model`` it
   belongs to, world the running ``World``.
2. ``load()``: read parameters, create ROS interfaces. Raise ``PluginError`` with a clear
   message for bad parameters; the world logs it as one line and keeps the model.
3. ``update(sim_time)``: called when sim time reaches the plugin's next period
   (``update_rate`` Hz of *sim* time; 0 = every world step), whatever the wall clock does.
4. ``renderer_created(renderer)`` once, when the first camera creates the renderer;
   ``reset()`` on /gazebo/reset_world, ``shutdown()`` when the model is deleted.

The world seam: what a plugin may use of ``sim_world.world.World`` (``WORLD_SEAM``; nothing
else, no private attribute, no probing with getattr/hasattr; test/unit/test_world_seam.py
holds every plugin module to it):

- time and threads: ``sim_time`` (s), ``step_size`` (s of one physics step), ``ros_now()``
  (rospy.Time of the sim time), ``lock`` (taken by ROS callbacks that touch the world),
  ``ros_enabled`` (False in unit tests without a roscore), ``log`` (the world's logger),
  ``reschedule()`` (after a plugin changed its rate from another thread);
- models and state: ``models`` (name -> Model), ``link_pose(model, link)`` (Pose in the
  world), ``joint_states(model)`` ({joint: (position, velocity)} of its simulated joints),
  ``entity_state(entity)`` and ``pass_state(entity)`` (pose, linear and angular
  velocity; the second read once per plugin pass), ``gravity`` (m/s^2 vector), ``rng(*keys)``
  (a generator from the world's seed);
- the renderer: ``renderer`` (the one offscreen renderer, created on first use),
  ``renderer_if_created`` (None until a camera made it), ``parallel_render`` and
  ``flush()`` (cameras render in the renderer's worker thread), ``lights``, ``ambient``;
- ray casts: ``raycast(origin, direction, max_dist, ignore)``,
  ``segment_intervals(a, b, ignore)``;
- contacts and wrenches: ``contacts(model, link=None)``, ``apply_wrench(model, force,
  torque, steps, key)``, ``clear_wrench(model, key)``;
- power: ``power`` (the power bus: ``set_draw``, ``draws``, ``set_flag``, ``flag``);
- environment: ``environment`` (weather, geodesy, magnetic field, indoor volumes);
- transmitters: ``transmitters(kind)``, ``add_transmitter(tx)``, ``remove_transmitter(tx)``;
- the registry: ``find_plugins(model, key=None)`` (other plugins of a model, e.g. the video
  texture whose ``texture_size(link)`` the touch screen reads), ``shared(name, factory)``
  (one object per world for a plugin family: the NFC proxy, the audio scene).

Register a plugin with ``@register('libgazebo_ros_foo.so')``. Plugin modules are found,
not listed: the registry imports the modules of this package, and of every stack of the
repository (``<stack>/src/<package>/``) whose package ``__init__`` says where its plugins are:
``PLUGIN_MODULES = ['textvid.video']`` (its own modules) or ``PLUGIN_PACKAGE = True`` (every
module of the package whose name does not start with ``_``). Imports happen on the first
lookup; a module that fails to import costs one warning, not the world.

Sensors are declared on ``sim_world.plugins.sensor.Sensor`` (parameters, one update timer, error
models, the world's seeded generators); every plugin's schedule is an ``UpdateTimer``.
"""
import glob
import importlib
import logging
import os
import pkgutil
import sys

from ..logonce import LogOnce
from .timer import UpdateTimer

__all__ = ['Plugin', 'PluginError', 'register', 'lookup', 'create', 'registered_names',
           'plugin_modules', 'WORLD_SEAM']

#: what a plugin may use of the World (see the module doc)
WORLD_SEAM = (
    'sim_time', 'step_size', 'ros_now', 'lock', 'ros_enabled', 'log', 'reschedule',
    'models', 'link_pose', 'entity_state', 'pass_state', 'joint_states', 'gravity', 'rng',
    'renderer', 'renderer_if_created', 'parallel_render', 'flush', 'lights', 'ambient',
    'raycast', 'segment_intervals',
    'contacts', 'apply_wrench', 'clear_wrench',
    'power',
    'environment',
    'transmitters', 'add_transmitter', 'remove_transmitter',
    'find_plugins', 'shared',
)

log = logging.getLogger('sim_world.plugins')

#: the repository root (<root>/sim_world/src/sim_world/plugins/__init__.py)
ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                     '..', '..', '..', '..'))

_REGISTRY = {}
_loaded = False
_unimplemented = LogOnce(log)      # one warning per plugin name and process


class PluginError(ValueError):
    """A plugin cannot be created from its parameters; the message says why."""


class Plugin(object):
    """Base class of every world plugin."""

    #: library names this class answers to (filled by @register)
    names = ()
    #: declared parameters (sim_world.plugins.params.Param rows; the README tables come from them)
    PARAMS = []

    @classmethod
    def param_rows(cls):
        return list(cls.PARAMS)

    def __init__(self, spec, model, world):
        self.spec = spec
        self.model = model
        self.world = world
        self.timer = UpdateTimer()

    # -- schedule (one UpdateTimer in sim time) ----------------------------------------------
    @property
    def update_rate(self):
        return self.timer.rate

    @update_rate.setter
    def update_rate(self, rate):
        self.timer.rate = float(rate)

    @property
    def next_update(self):
        return self.timer.next_time

    @next_update.setter
    def next_update(self, t):
        self.timer.next_time = float(t)

    def set_update_rate_now(self, rate):
        """Change the rate in Hz of sim time, effective at once (from any thread); raises
        ValueError for a negative or non-finite rate."""
        with self.world.lock:
            self.timer.set_rate(rate, self.world.sim_time)
            self.world.reschedule()

    # -- helpers -------------------------------------------------------------------------
    @property
    def label(self):
        """'plugin <file> of model <m>': how every error line names the plugin."""
        return 'plugin %s of model %s' % (self.spec.filename, self.model.name)

    def param(self, *names, **kw):
        return self.spec.param(*names, **kw)

    def parse(self, rows):
        """Declared parameters (``sim_world.plugins.params.Param`` rows) read from the spec;
        each bad value gets one error line and its default."""
        from .params import parse_params
        vals, _ = parse_params(self.spec, rows, self.label, self.world.log)
        return vals

    def float_param(self, *names, **kw):
        """One number (a declared row made on the fly): a bad value is an error line and
        the default."""
        from .params import Param
        row = Param(names[0], float, kw.get('default'), aliases=names[1:],
                    check=kw.get('check'))
        return getattr(self.parse([row]), names[0])

    @property
    def namespace(self):
        ns = self.param('robotNamespace')
        if ns is None:
            ns = self.model.robot_namespace
        return (ns or '').strip('/')

    def resolve(self, topic):
        """Topic name inside the plugin's robot namespace (absolute names stay)."""
        if topic.startswith('/') or not self.namespace:
            return topic if topic.startswith('/') else '/' + topic
        return '/%s/%s' % (self.namespace, topic)

    def tf_frame(self, frame):
        """``frame`` as this model's tf frames are named: prefixed with the model's tf prefix
        where it has one (a URDF robot spawned in a robot namespace, sim_world.spawn), as
        gazebo_ros's plugins resolve their frameName with tf_prefix; absolute names stay."""
        prefix = (self.model.tf_prefix or '').strip('/')
        if not prefix or not frame:
            return frame
        if frame.startswith('/'):
            return frame[1:]
        return '%s/%s' % (prefix, frame)

    def due(self, sim_time):
        """True when the plugin should update at ``sim_time``; advances its schedule by
        whole periods so the rate in sim time is exact."""
        return self.timer.due(sim_time)

    # -- lifecycle -----------------------------------------------------------------------
    def load(self):
        pass

    def update(self, sim_time):
        pass

    def will_draw(self):
        """True when this plugin will render a frame at its next tick (a camera somebody
        subscribes to): the world then creates its renderer ahead, before the sim time it
        is stepped to (World.prepare_renderer), not inside the first frame's tick."""
        return False

    def renderer_created(self, renderer):
        """Called once when the world creates its renderer (the first camera that renders),
        before that camera's first frame."""

    def texture_size(self, link):
        """(width, height) px of the picture this plugin shows on ``link`` of its model, or
        None (video textures answer; the touch screen maps touches to these pixels)."""
        return None

    def ros_names(self):
        """The resolved names of the topics this plugin publishes and the services it serves
        (the world refuses a model whose plugins would take another model's: World.add_model)."""
        return set()

    def reset(self):
        self.timer.reset(self.world.sim_time)

    def shutdown(self):
        pass


def register(*names):
    """Class decorator: register a Plugin subclass under library names."""
    def deco(cls):
        cls.names = tuple(names)
        for n in names:
            _REGISTRY[_key(n)] = cls
        return cls
    return deco


def _key(name):
    name = name.strip()
    if name.startswith('lib'):
        name = name[3:]
    if name.endswith('.so'):
        name = name[:-3]
    return name


def _package_modules(pkg_name):
    """Modules a package names as its plugins (PLUGIN_MODULES / PLUGIN_PACKAGE)."""
    try:
        pkg = importlib.import_module(pkg_name)
    except Exception as e:  # noqa: BLE001 - a broken stack costs one warning
        log.warning('plugin package %s not available: %s', pkg_name, e)
        return []
    mods = list(getattr(pkg, 'PLUGIN_MODULES', ()))
    if getattr(pkg, 'PLUGIN_PACKAGE', False):
        for info in pkgutil.iter_modules(getattr(pkg, '__path__', [])):
            if not info.name.startswith('_'):
                mods.append('%s.%s' % (pkg_name, info.name))
    return mods


def plugin_modules():
    """Every module that defines plugins: those that the stacks of the repository declare in
    their package ``__init__`` (no hand-kept list of other stacks' modules). The SDK itself
    (this package) holds no plugins."""
    mods = []
    for init in sorted(glob.glob(os.path.join(ROOT, '*', 'src', '*', '__init__.py'))):
        pkg_dir = os.path.dirname(init)
        name = os.path.basename(pkg_dir)
        src = os.path.dirname(pkg_dir)
        with open(init) as f:
            text = f.read()
        if 'PLUGIN_MODULES' not in text and 'PLUGIN_PACKAGE' not in text:
            continue
        if name not in sys.modules and src not in sys.path:
            sys.path.append(src)      # source-tree use (tests); catkin's devel space has it
        mods.extend(_package_modules(name))
    return mods


def _load_modules():
    global _loaded
    if _loaded:
        return
    _loaded = True
    for mod in plugin_modules():
        try:
            importlib.import_module(mod)
        except Exception as e:  # noqa: BLE001 - one broken module must not stop the world
            log.warning('plugin module %s not available: %s: %s', mod, type(e).__name__, e)


def lookup(filename):
    """The Plugin class registered for a library name, or None."""
    _load_modules()
    return _REGISTRY.get(_key(filename))


def registered_names():
    _load_modules()
    return sorted('lib%s.so' % k for k in _REGISTRY)


def create(spec, model, world, logger=None):
    """Instantiate and load the plugin ``spec`` names.

    Returns the plugin, or None when no plugin of that name is implemented (one warning per
    name and process) or when loading failed (one error line naming the plugin and cause).
    """
    logger = logger or log
    cls = lookup(spec.filename)
    if cls is None:
        _unimplemented.warning('plugin %s (model %s) is not implemented; the model loads '
                               'without it' % (spec.filename, model.name),
                               key=spec.filename, logger=logger)
        return None
    plugin = None
    try:
        plugin = cls(spec, model, world)
        plugin.load()
    except PluginError as e:
        logger.error('plugin %s of model %s not loaded: %s', spec.filename, model.name, e)
        _quiet_shutdown(plugin)
        return None
    except Exception as e:  # noqa: BLE001 - e.g. a ROS name of another model's (a second
        # phone in the same namespace: 'service [/ns/x] already registered'): the model
        # cannot run as described; the world refuses it and stays as it was
        _quiet_shutdown(plugin)
        from ..model import ModelError
        raise ModelError('plugin %s of model %r cannot be loaded: %s: %s'
                         % (spec.filename, model.name, type(e).__name__, e))
    return plugin


def _quiet_shutdown(plugin):
    """Undo what a plugin that failed in load() registered (best effort)."""
    if plugin is None:
        return
    try:
        plugin.shutdown()
    except Exception:  # noqa: BLE001 - half-loaded: nothing more to undo
        pass
