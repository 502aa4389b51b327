"""Models that appear after the studio started (issue 47): spawned by ``spawn_model``,
/gazebo/spawn_urdf_model or spawn_sdf_model, or by a scenario. An extension
(sim_studio.extensions) without ops of its own.

Twice a second it compares the names in /gazebo/model_states with the models the studio has
descriptions of (``Studio.scene_models``). A new name is asked once of the world's
/gazebo/get_model_description (in a worker thread: the event loop never waits for the
world), read with the world's own loaders (``scene.description_model``: sim_world.urdf or
sim_world.sdf) and described as the world file's models are (``scene.describe_model``: its
meshes and textures served through the studio's ``Assets``); its NFC tags and radio
transmitters are read by the world's own plugins too (an offline World holding the model
with only those plugins, ``overlay.world_info``). A name gone from /gazebo/model_states is
dropped from ``scene_models`` (and asked again if it comes back). Either change goes to
every page as the stream message ``scene_models`` {version, models: [names described
here]}: the page then asks ``scene`` and draws, replaces or removes its models
(static/ext/spawned.js). A model the world cannot describe stays a small box, with one log
line naming it and why.

``icons(studio)``: the icons of the models described here, and every icon with a model at
that model's current pose (``attach`` makes it one of ``studio.icon_hooks``, which the
``world_info`` op of overlay.py applies)."""
import asyncio

import numpy as np

__all__ = ['attach', 'routes', 'describe', 'model_icons', 'icons', 'state', 'tick', 'PERIOD']

PERIOD = 0.5                   # s between two looks at /gazebo/model_states


class _State(object):
    def __init__(self):
        self.asked = set()         # names asked of the world (described or not)
        self.present = set()       # names in the last /gazebo/model_states looked at
        self.mine = set()          # names whose description came from here
        self.icons = {}            # name -> [icon] of models described here
        self.version = 0
        self.pending = set()       # names being asked now


def state(studio):
    """This extension's state, kept on the studio (as barcode's reader and images' watch
    are): a module dict keyed by id(studio) outlived its studio and could hand a new one,
    made at a freed object's address, the old one's state."""
    st = getattr(studio, 'spawned_state', None)
    if st is None:
        st = studio.spawned_state = _State()
    return st


def describe(studio, name):
    """(scene description, icons) of model ``name`` as the world describes it
    (/gazebo/get_model_description); raises with the reason when it cannot."""
    from .scene import describe_model, description_model
    res = studio.world.model_description(name)
    model = description_model(res.format, res.xml, name, res.robot_namespace, res.base_dir)
    desc = describe_model(model, studio.assets)
    return desc, model_icons(model)


def _radio_classes():
    from simsensors.nfc import NfcTag
    from simsensors.wifi import TransmitterPlugin
    return (TransmitterPlugin, NfcTag)


def model_icons(model):
    """The icons (overlay.world_info's entries) of ``model``'s radio transmitters and NFC
    tags, read by their own plugins: ``model`` with only those plugins in an offline World
    (no ROS). [] when it has none."""
    from sim_world import plugins
    from sim_world.world import World
    from .overlay import world_info
    kinds = _radio_classes()
    keep = []
    for spec in model.plugins:
        cls = plugins.lookup(spec.filename)
        if isinstance(cls, type) and issubclass(cls, kinds):
            keep.append(spec)
    if not keep:
        return []
    model.plugins = keep
    w = World(physics='ode', seed=0)
    try:
        w.add_model(model)
        with w.lock:
            return [ic for ic in world_info(w)['icons'] if ic['model'] == model.name]
    finally:
        w.shutdown()


def icons(studio, listed):
    """``listed`` (world_info's icons of the world file) without those of models gone from
    the world, with those of the models described here, each icon on a model placed at that
    model's pose now x its offset."""
    st = state(studio)
    poses = studio.world.poses() if hasattr(studio.world, 'poses') else {}
    out = [ic for ic in listed if not ic.get('model') or not poses or ic['model'] in poses]
    for name in sorted(st.icons):
        out += [dict(ic) for ic in st.icons[name]]
    from sim_world.transforms import Pose
    for ic in out:
        pq = poses.get(ic.get('model') or '')
        if pq:
            ic['position'] = [float(v) for v in Pose(pq[:3], pq[3:]).transform_point(
                np.asarray(ic['offset'], float))]
    return out


def _drop(studio, st, name):
    studio.scene_models[:] = [m for m in studio.scene_models if m['name'] != name]
    getattr(studio.world, 'articulated', {}).pop(name, None)
    st.icons.pop(name, None)
    st.mine.discard(name)
    st.asked.discard(name)


def _add(studio, st, name, desc, model_icons_):
    studio.scene_models[:] = [m for m in studio.scene_models if m['name'] != name]
    studio.scene_models.append(desc)
    if desc.get('articulated') and hasattr(studio.world, 'articulated'):
        studio.world.articulated[name] = [ln['name'] for ln in desc['links']
                                          if ln['name'] != 'world']
    st.mine.add(name)
    if model_icons_:
        st.icons[name] = model_icons_


def watch_phone(studio, name):
    """A phone (a model with a touch display) that came after the studio started: its
    topics join the device panel (``DeviceWatch.add``; made here when the world had no phone
    at start); its display's image topic is in ``scene_models`` and the display stream
    subscribes it."""
    if getattr(studio, 'device', None) is None:
        rospy = getattr(studio.world, 'rospy', None)
        if rospy is None:
            return
        from .device import DeviceWatch
        studio.device = DeviceWatch(rospy, [name])
    else:
        studio.device.add(name)


def _tell(studio, st):
    st.version += 1
    studio.broadcast('scene_models', {'version': st.version,
                                      'models': sorted(m['name'] for m in studio.scene_models)})


async def tick(studio, loop=None):
    """One look at /gazebo/model_states: forget the models gone, describe the new ones.
    Returns the names it asked the world about."""
    loop = loop or asyncio.get_event_loop()
    st = state(studio)
    if not hasattr(studio.world, 'model_names'):
        return []
    names = set(studio.world.model_names())
    if not names:                       # no /gazebo/model_states yet
        return []
    # a test's stand-in for the world without services: nothing to ask
    can_ask = hasattr(studio.world, 'model_description')
    changed = False
    for name in sorted(st.present - names):
        known = any(m['name'] == name for m in studio.scene_models)
        _drop(studio, st, name)
        changed = changed or known
    st.present = names
    known = {m['name'] for m in studio.scene_models}
    new = sorted(names - known - st.asked - st.pending) if can_ask else []
    for name in new:
        st.asked.add(name)
        st.pending.add(name)
        try:
            desc, ics = await loop.run_in_executor(None, describe, studio, name)
        except Exception as e:  # noqa: BLE001 - a world without the service, a bad file
            studio.log('studio: model %s appeared but cannot be described (a box stands in '
                       'for it): %s' % (name, e))
            continue
        finally:
            st.pending.discard(name)
        if name not in studio.world.model_names():
            st.asked.discard(name)      # deleted while it was being described
            continue
        _add(studio, st, name, desc, ics)
        if desc.get('display'):
            await loop.run_in_executor(None, watch_phone, studio, name)
        changed = True
    if changed:
        _tell(studio, st)
    return new


def attach(studio):
    """``world_info``'s icons (overlay.py) pass through ``icons``: the hook list
    ``studio.icon_hooks`` keeps overlay from importing this module, which imports it."""
    hooks = getattr(studio, 'icon_hooks', None)
    if hooks is None:
        hooks = studio.icon_hooks = []
    if icons not in hooks:
        hooks.append(icons)


def routes(app, studio):
    """The look at /gazebo/model_states every PERIOD s while the server runs (the first look
    asks also for the models present at start that the world file and the launch's
    parameters did not describe)."""
    from .extensions import periodic
    periodic(app, studio, 'spawned models', PERIOD, lambda: tick(studio))
