"""The studio's moves (issue 47, item 2): presets and walks, and the device panel's switches
that have no core op (item 3): radios and the charger. An extension (sim_studio.extensions).

- ``preset`` {model, name, surface}: flat on the desk, face down on it, held in portrait,
  in a pocket. Each is one ``set_pose`` computed from the world: the desk's top is where a
  ray cast down onto the desk model's collision shapes meets it (sim_world's ray caster on
  the world file, loaded as the world loads it), the phone's thickness is its own
  description's boxes, the hand and pocket heights are a standing adult's above the floor
  under the phone. Recorded as ``set_pose`` is: the runner's ``set_model_state``.
- ``walk`` {model, waypoints, speed}: the runner's own ``walk`` action
  (``testing_instance.run.actions.Walk``, ``scenario.motion.walk_points``: the hand-held
  walking profile) carried out in the running world, each of its poses (with its velocity
  as twist) sent by /gazebo/set_model_state at its sim time (``Mover`` follows /clock: a
  paused world pauses the walk). Recorded as that ``walk`` action, with a ``log`` action
  at its end so that the recorded scenario lasts until the walk is over.
- ``radio`` {radio, enabled, model} and ``charger`` {plugged, model}: the runner's ``radio``
  and ``charger`` actions (``<ns>/<radio>/enable``, ``<ns>/charger``, latched), recorded as
  those actions.

The pure parts (``phone_extent``, ``preset_pose``, ``check_walk``) need no ROS."""
import asyncio
import heapq
import math
import threading
import types

import numpy as np

__all__ = ['OPS', 'handle', 'routes', 'PRESETS', 'HAND_HEIGHT', 'POCKET_HEIGHT',
           'phone_extent', 'preset_pose', 'check_walk', 'Mover', 'offline_world',
           'MAX_WALK_S', 'MAX_WAYPOINTS']

#: the presets, in the panel's order
PRESETS = ('flat_on_desk', 'face_down', 'held_portrait', 'in_pocket')
#: m above the floor: a phone held in front of the chest to be read by a standing adult
#: (about 1.75 m tall: elbow height ~1.09 m, the forearm raised)
HAND_HEIGHT = 1.25
#: m above the floor: the middle of a front trouser pocket of that adult (hip height ~0.9 m)
POCKET_HEIGHT = 0.80
#: rad: a phone held to be read leans back this much from vertical
HELD_TILT = math.pi / 6
GAP = 0.001                 # m between the phone and the desk it lies on
MAX_WALK_S = 600.0          # s of sim time a walk may last at most
MAX_WAYPOINTS = 100
RADIOS = ('wifi', 'bluetooth', 'cellular', 'nfc')


def _check_walk_fields(f):
    check_walk(f['waypoints'], f['speed'])


OPS = {
    'preset': dict(required={'model': 'str', 'name': PRESETS}, optional={'surface': 'desk'},
                   kinds={'surface': 'str'}, changes_world=True, takes_model=True,
                   doc='put a model at a preset pose computed from the world: flat_on_desk, '
                       'face_down (on the desk), held_portrait, in_pocket; surface: the '
                       'model it lies on (desk)'),
    'walk': dict(required={'model': 'str', 'waypoints': 'list', 'speed': 'num>0'},
                 optional={}, changes_world=True, takes_model=True,
                 field_check=_check_walk_fields,
                 doc="walk a model from where it is through waypoints [[x, y, z], ...] (at "
                     "least 2) at speed m/s in sim time: the runner's walk action"),
    'radio': dict(required={'radio': RADIOS, 'enabled': 'bool'},
                  optional={'model': 'mobile_device'}, changes_world=True, takes_model=True,
                  doc="switch a phone's radio (wifi, bluetooth, cellular, nfc) on or off: "
                      "<model>/<radio>/enable"),
    'charger': dict(required={'plugged': 'bool'}, optional={'model': 'mobile_device'},
                    changes_world=True, takes_model=True,
                    doc="plug (true) or unplug (false) a phone's charger: <model>/charger"),
}


# -- pure parts ------------------------------------------------------------------------------
def check_walk(waypoints, speed):
    """ProtocolError naming what is wrong with a walk's waypoints or speed."""
    from .protocol import ProtocolError, _kind
    if not isinstance(waypoints, list) or not 2 <= len(waypoints) <= MAX_WAYPOINTS:
        raise ProtocolError('walk.waypoints: expected a list of 2 to %d points [x, y, z], got '
                            '%s' % (MAX_WAYPOINTS, len(waypoints) if isinstance(waypoints, list)
                                    else type(waypoints).__name__))
    for i, w in enumerate(waypoints):
        waypoints[i] = _kind('vec3', w, 'walk.waypoints[%d]' % i)
    if not (isinstance(speed, float) and math.isfinite(speed) and speed > 0):
        raise ProtocolError('walk.speed: expected a number > 0, got %r' % (speed,))


def walk_length(start, waypoints):
    pts = np.asarray([start] + list(waypoints), float)
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def phone_extent(desc):
    """(lo, hi): the corners of the box around a model's boxes (its description's visuals:
    boxes, and shapes by their bounding boxes) in the model's frame at rest; a 1 cm cube
    when it has none."""
    from sim_world.transforms import Pose
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for ln in (desc or {}).get('links', []):
        lp = Pose(ln['pose']['position'], ln['pose']['orientation'])
        for v in ln['visuals']:
            g = v['geometry']
            if 'size' not in g or len(g['size']) != 3:
                continue
            c = np.asarray(g.get('center', (0, 0, 0)), float)
            half = np.asarray(g['size'], float) / 2
            p = lp * Pose(v['origin']['position'], v['origin']['orientation'])
            for sx in (-1, 1):
                for sy in (-1, 1):
                    for sz in (-1, 1):
                        q = p.transform_point(c + half * (sx, sy, sz))
                        lo, hi = np.minimum(lo, q), np.maximum(hi, q)
    if not np.all(np.isfinite(lo)):
        return np.full(3, -0.005), np.full(3, 0.005)
    return lo, hi


def _floor(world, x, y):
    """z of the floor under (x, y): the first surface below 0.3 m there (0 without one)."""
    hit = world.raycast(np.array([x, y, 0.3]), np.array([0.0, 0.0, -1.0]), 10.0)
    return float(hit.point[2]) if hit is not None else 0.0


def _top(world, surface, x, y):
    """z of the top of model ``surface`` at (x, y) (a ray from above meets its collision
    shapes there: other models are ignored), or None."""
    others = tuple(m for m in world.models if m != surface)
    hit = world.raycast(np.array([x, y, 50.0]), np.array([0.0, 0.0, -1.0]), 100.0,
                        ignore=others)
    return float(hit.point[2]) if hit is not None and hit.model == surface else None


def preset_pose(name, world, desc, position, yaw, surface='desk'):
    """(position [x, y, z], rpy) of preset ``name`` for a model described by ``desc`` (its
    scene description: the extent of its boxes) now at ``position`` with heading ``yaw``,
    in ``world`` (a sim_world World of the world file: its ray caster). ValueError naming
    what is missing (no such surface model, no top under it)."""
    x, y = float(position[0]), float(position[1])
    lo, hi = phone_extent(desc)
    if name in ('flat_on_desk', 'face_down'):
        if surface not in world.models:
            raise ValueError('preset %s: no model %s in the world file (surface: the model '
                             'to lie on)' % (name, surface))
        top = _top(world, surface, x, y)
        if top is None:                       # not over it: the middle of its top
            m = world.models[surface]
            x, y = float(m.pose.p[0]), float(m.pose.p[1])
            top = _top(world, surface, x, y)
        if top is None:
            raise ValueError('preset %s: model %s has no top surface under its origin'
                             % (name, surface))
        if name == 'flat_on_desk':            # display up: its lowest point on the top
            return [x, y, top - float(lo[2]) + GAP], [0.0, 0.0, float(yaw)]
        return [x, y, top + float(hi[2]) + GAP], [math.pi, 0.0, float(yaw)]
    floor = _floor(world, x, y)
    if name == 'held_portrait':
        # long side (x) up, leaning back HELD_TILT: the display faces the person behind it
        return [x, y, floor + HAND_HEIGHT], [0.0, -(math.pi / 2 - HELD_TILT), float(yaw)]
    if name == 'in_pocket':
        # upright, top down, in a front trouser pocket
        return [x, y, floor + POCKET_HEIGHT], [0.0, math.pi / 2, float(yaw)]
    raise ValueError('preset: unknown preset %r; expected one of %s' % (name, ', '.join(PRESETS)))


# -- the world file, loaded as the world loads it (no ROS): ray casts, radios -----------------
_WORLDS = {}
_WORLDS_LOCK = threading.Lock()


def world_file(studio):
    path = getattr(studio, 'world_file', None)
    if path is None:
        rospy = getattr(studio.world, 'rospy', None)
        path = rospy.get_param('/sim_world/world_file', None) if rospy is not None else None
    if not path:
        raise ValueError('the studio knows no world file (/sim_world/world_file)')
    return path


def offline_world(path):
    """A sim_world World of the world file (cached per path; plugins loaded without ROS, as
    ``wifi_map`` loads it)."""
    with _WORLDS_LOCK:
        if path not in _WORLDS:
            from sim_world.world import World
            w = World(physics='ode', seed=0)
            w.load_world_file(path)
            _WORLDS[path] = w
        return _WORLDS[path]


# -- carrying the motions out in the running world ---------------------------------------------
class _Side(object):
    """What testing_instance's ``Hands`` calls of a world side: the studio's own service
    proxies (``WorldLink``)."""

    def __init__(self, link):
        from mobile_device_sim.srv import GetModelState, SetModelState
        self.link = link
        self.srv_types = {'get': GetModelState, 'set': SetModelState}

    def proxy(self, name, typ):
        return self.link.proxy(name, typ)

    def log_tail(self):
        return []


class Mover(object):
    """The runner's agenda in the running world: ``later(t, fn, what)`` runs ``fn(t)`` once
    /clock reaches sim time t (of each ``what`` only the latest due one: poses are
    teleports, a late studio skips to the newest); ``cancel(what)``."""

    def __init__(self, clock, log=print):
        self.clock = clock              # () -> sim time now
        self.log = log
        self.due = []                   # heap of (t, seq, what, fn)
        self.seq = 0
        self.cancelled = set()
        self.lock = threading.Lock()
        self.ends = {}                  # what -> sim time of its last step

    def later(self, t, fn, what):
        with self.lock:
            self.seq += 1
            heapq.heappush(self.due, (float(t), self.seq, what, fn))
            self.ends[what] = max(self.ends.get(what, 0.0), float(t))

    def cancel(self, what):
        with self.lock:
            self.due = [d for d in self.due if d[2] != what]
            heapq.heapify(self.due)
            self.ends.pop(what, None)

    def pending(self, what=None):
        with self.lock:
            return sum(1 for d in self.due if what is None or d[2] == what)

    def run_due(self):
        """Run what is due now (the latest of each ``what``); the number run."""
        now = self.clock()
        latest = {}
        with self.lock:
            while self.due and self.due[0][0] <= now + 1e-9:
                t, _seq, what, fn = heapq.heappop(self.due)
                latest[what] = (t, fn)
        for what, (t, fn) in latest.items():
            try:
                fn(t)
            except Exception as e:  # noqa: BLE001 - a refused pose: one line, the rest go on
                self.log('studio: %s at %.3f s: %s' % (what, t, e))
        return len(latest)


def _state(studio):
    st = getattr(studio, '_moves', None)
    if st is None:
        st = studio._moves = types.SimpleNamespace(mover=None, hands=None, walks={}, n=0)
        st.mover = Mover(lambda: studio.world.clock, studio.log)
    return st


def _hands(studio, model):
    """testing_instance's Hands over the studio's world link (one per studio: its latched
    publishers stay)."""
    st = _state(studio)
    if st.hands is None:
        from testing_instance.run.actions import Hands
        st.hands = Hands(types.SimpleNamespace(phones=[{'ns': model}]), _Side(studio.world),
                         st.mover.later, say=studio.log)
    return st.hands


def _record(studio, action, sim_time):
    """Add a runner action to the recording at ``sim_time`` (when recording is on)."""
    entry = studio.recorder.add_action(action, sim_time)
    if entry is not None:
        studio._tell_recording_threadsafe()
    return entry


def _description(studio, model):
    return next((m for m in studio.scene_models if m['name'] == model), None)


def _preset(studio, f):
    from testing_instance.scenario.motion import rpy_from_quat
    from .protocol import Command
    pos, quat = studio.world.get_pose(f['model'])
    yaw = rpy_from_quat(quat)[2]
    w = offline_world(world_file(studio))
    with w.lock:
        position, rpy = preset_pose(f['name'], w, _description(studio, f['model']), pos, yaw,
                                    f['surface'])
    cmd = Command('set_pose', {'model': f['model'], 'position': position, 'rpy': rpy})
    t = studio.world.clock
    stop_walk(studio, f['model'])
    studio.world.set_pose(f['model'], position, rpy)
    entry = studio.recorder.add(cmd, t)
    if entry is not None:
        studio._tell_recording_threadsafe()
    return {'position': position, 'rpy': rpy, 'sim_time': t, 'recorded': entry,
            'before': _pose_fields(pos, quat)}


def stop_walk(studio, model):
    """End the walk of ``model`` that is under way (if any): its poses still due are
    dropped."""
    st = _state(studio)
    st.mover.cancel(st.walks.pop(model, None))


class _EndOf(object):
    """What a runner action's ``Hands`` is asked, answered at once: the last pose the
    action sets (a walk's end), without a world."""

    def __init__(self, pos, quat):
        self.start = (list(pos), list(quat))
        self.due = []
        self.end = None

    def model_state(self, ev, model):
        return self.start

    def later(self, t, fn, what):
        self.due.append((t, len(self.due), fn))

    def set_pose(self, ev, model, pos, quat, *rest, **kw):
        self.end = ([float(v) for v in pos], [float(v) for v in quat])

    def last(self, action, t0):
        action.apply(self, t0)
        for t, _i, fn in sorted(self.due):
            fn(t)
        return self.end


def _walk(studio, f):
    from testing_instance.run.actions import Walk
    st = _state(studio)
    model = f['model']
    pos, _q = studio.world.get_pose(model)
    length = walk_length(pos, f['waypoints'])
    if length / f['speed'] > MAX_WALK_S:
        raise ValueError('walk: %.1f m at %g m/s lasts %.0f s of sim time, more than %g'
                         % (length, f['speed'], length / f['speed'], MAX_WALK_S))
    st.mover.cancel(st.walks.pop(model, None))     # a new walk of the model replaces its last
    st.n += 1
    ev = {'id': 'studio_walk%d' % st.n, 'action': 'walk', 'model': model,
          'waypoints': f['waypoints'], 'speed': f['speed']}
    t0 = studio.world.clock
    Walk(ev).apply(_hands(studio, model), t0)
    last = _EndOf(pos, _q).last(Walk(ev), t0)        # where the walk ends (study's undo)
    st.walks[model] = ev['id']
    end = st.mover.ends.get(ev['id'], t0)
    entry = _record(studio, {'action': 'walk', 'model': model, 'waypoints': f['waypoints'],
                             'speed': f['speed']}, t0)
    if entry is not None:
        _record(studio, {'action': 'log', 'text': 'the walk %s ends' % entry['id']}, end)
    return {'sim_time': t0, 'end': end, 'length': length, 'steps': st.mover.pending(ev['id']),
            'recorded': entry, 'before': _pose_fields(pos, _q),
            'end_pose': _pose_fields(*last) if last else None}


def _pose_fields(pos, quat):
    from testing_instance.scenario.motion import rpy_from_quat
    return {'position': [float(v) for v in pos],
            'rpy': [float(v) for v in rpy_from_quat(quat)]}


def _switch(studio, op, f):
    from testing_instance.run.actions import Charger, Radio
    t = studio.world.clock
    if op == 'radio':
        action = {'action': 'radio', 'ns': f['model'], 'radio': f['radio'],
                  'enabled': f['enabled']}
        cls = Radio
    else:
        action = {'action': 'charger', 'ns': f['model'], 'plugged': f['plugged']}
        cls = Charger
    cls(dict(action, id=op)).apply(_hands(studio, f['model']), t)
    return {'sim_time': t, 'recorded': _record(studio, action, t)}


async def handle(studio, cmd, client):
    loop = asyncio.get_event_loop()
    if studio.lock is None:
        studio.lock = asyncio.Lock()
    async with studio.lock:
        if cmd.op == 'preset':
            return await loop.run_in_executor(None, _preset, studio, cmd.fields)
        if cmd.op == 'walk':
            return await loop.run_in_executor(None, _walk, studio, cmd.fields)
        return await loop.run_in_executor(None, _switch, studio, cmd.op, cmd.fields)


def routes(app, studio):
    """The mover's task: the walks' poses at their sim times (looked at every 10 ms of wall
    time)."""
    from .extensions import periodic

    async def tick():
        st = _state(studio)
        if st.mover.pending():
            await asyncio.get_event_loop().run_in_executor(None, st.mover.run_due)
    periodic(app, studio, 'moves', 0.01, tick)
