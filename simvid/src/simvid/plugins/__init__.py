"""World plugins: one registry, one lifecycle, one place to add a sensor.

A plugin is a class registered under the library file names a URDF uses for it, in both
syntaxes the simulator reads::

    <!-- 2011, thesis appendix A -->
    <controller:gazebo_ros_camera name="c" plugin="libgazebo_ros_camera.so"> ...
    <!-- Gazebo classic -->
    <plugin name="c" filename="libgazebo_ros_camera.so"> ...

Lifecycle, driven by ``simvid.world.World``:

1. ``cls(spec, model, world)``: spec is a ``simvid.model.PluginSpec`` (its ``param()``
   reads the plugin's and the enclosing sensor's parameters), model the ``Model`` it
   belongs to, world the running ``World``.
2. ``load()``: read parameters, create ROS interfaces. Raise ``PluginError`` with a clear
   message for bad parameters; the world logs it as one line and keeps the model.
3. ``update(sim_time)``: called when sim time reaches the plugin's next period
   (``update_rate`` Hz of *sim* time; 0 = every world step), whatever the wall clock does.
4. ``renderer_created(renderer)`` once, when the first camera creates the renderer;
   ``reset()`` on /gazebo/reset_world, ``shutdown()`` when the model is deleted.

What plugins may use of the world: ``world.sim_time``, ``world.ros_now()`` (rospy.Time
of the sim time), ``world.link_pose(model_name, link_name)`` (Pose in the world),
``world.renderer`` (the one offscreen renderer, created on first use), ``world.models``,
``world.ros_enabled`` (False in unit tests without a roscore).

Register a plugin with ``@register('libgazebo_ros_foo.so')`` in a module listed in
``PLUGIN_MODULES`` (imported lazily, so a broken optional plugin module costs one warning,
not the world).
"""
import importlib
import logging

__all__ = ['Plugin', 'PluginError', 'register', 'lookup', 'create', 'registered_names',
           'PLUGIN_MODULES']

log = logging.getLogger('simvid.plugins')

# Modules that define plugins; imported on first lookup.
PLUGIN_MODULES = [
    'simvid.plugins.camera',
    'simvid.plugins.imu',
    'textvid.video',
]

_REGISTRY = {}
_loaded = False
_warned = set()


class PluginError(ValueError):
    """A plugin cannot be created from its parameters; the message says why."""


class Plugin(object):
    """Base class of every world plugin."""

    #: library names this class answers to (filled by @register)
    names = ()

    def __init__(self, spec, model, world):
        self.spec = spec
        self.model = model
        self.world = world
        self.update_rate = 0.0
        self.next_update = 0.0

    # -- helpers -------------------------------------------------------------------------
    def param(self, *names, **kw):
        return self.spec.param(*names, **kw)

    def float_param(self, *names, **kw):
        text = self.spec.param(*names)
        if text is None:
            return kw.get('default')
        try:
            return float(text)
        except ValueError:
            raise PluginError('%s: parameter <%s> must be a number, got %r'
                              % (self.spec.filename, names[0], text))

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

    def due(self, sim_time):
        """True when the plugin should update at ``sim_time``; advances its schedule by
        whole periods so the rate in sim time is exact."""
        if self.update_rate <= 0:
            return True
        if sim_time + 1e-9 < self.next_update:
            return False
        period = 1.0 / self.update_rate
        self.next_update += period
        if self.next_update <= sim_time:   # far behind (e.g. after a reset or rate change)
            self.next_update = sim_time + period
        return True

    # -- lifecycle -----------------------------------------------------------------------
    def load(self):
        pass

    def update(self, sim_time):
        pass

    def renderer_created(self, renderer):
        """Called once when the world creates its renderer (the first camera that renders),
        before that camera's first frame."""

    def reset(self):
        self.next_update = 0.0

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


def _load_modules():
    global _loaded
    if _loaded:
        return
    _loaded = True
    for mod in PLUGIN_MODULES:
        try:
            importlib.import_module(mod)
        except ImportError as e:
            log.warning('plugin module %s not available: %s', mod, e)


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
        if spec.filename not in _warned:
            _warned.add(spec.filename)
            logger.warning('plugin %s (model %s) is not implemented; the model loads without it',
                           spec.filename, model.name)
        return None
    plugin = cls(spec, model, world)
    try:
        plugin.load()
    except PluginError as e:
        logger.error('plugin %s of model %s not loaded: %s', spec.filename, model.name, e)
        return None
    return plugin
