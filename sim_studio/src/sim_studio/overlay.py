"""What the 3D view shows beyond the models (issue 47, item 1), and the phone's outputs that
are not topic values (item 3). An extension (sim_studio.extensions).

- ``world_info`` {}: the icons: the world's lights (``<light>``), WiFi access points,
  Bluetooth devices, NFC tags and cell towers, read from the world file by the world's own
  loaders and plugins (``moves.offline_world``: the radios' transmitters as
  ``world.transmitters`` has them, the NFC tags as their plugins registered them), each
  with the model it is on and its offset in that model (the icon moves with the model);
  and ``bounds`` [xmin, xmax, ymin, ymax] (m) of the world's furniture (the top view's).
- ``wifi_map`` {bssid, height, grid}: the received power (dBm) of the strongest access
  point (or the one of ``bssid``) over the floor, by ``simsensors.wifi_map.power_grid`` (the
  radio budget of the phone's WiFi receiver: its own gains and obstacle model, read from
  the phone's description with the receiver's parameter rows; no fading), as a colour PNG
  (``image``, a data URL, north up) over ``bounds``, with ``lo``/``hi`` dBm of its scale.
- a stream ``outputs`` {t, speaker: {model: dBFS of the last chunk on <model>/speaker/audio}}
  to every client, 4 times a second while something plays (the LED, vibration and
  projector are topic values of the device stream)."""
import asyncio
import base64
import math
import threading

import numpy as np

from .moves import offline_world, world_file

__all__ = ['OPS', 'handle', 'routes', 'world_info', 'map_png', 'receiver_params',
           'strongest_grid', 'rms_dbfs', 'LO', 'HI']

LO, HI = -90.0, -20.0          # dBm of the colour scale (wifi_map's)
MAX_CELLS = 40000

OPS = {
    'world_info': dict(required={}, optional={}, changes_world=False, needs_control=False,
                       doc='the icons of the 3D view: lights, WiFi access points, Bluetooth '
                           'devices, NFC tags, cell towers; the bounds of the top view'),
    'wifi_map': dict(required={}, optional={'bssid': None, 'height': 1.0, 'grid': 0.2},
                     kinds={'bssid': 'str', 'height': 'num', 'grid': 'num>0'},
                     changes_world=False, needs_control=False,
                     doc='the WiFi map: received power (dBm) of the strongest access point '
                         '(or bssid) at height m over the floor on a grid of grid m, by the '
                         "phone's radio budget (simsensors), as a PNG over bounds"),
}


def _offset(world, model, p):
    """``p`` (world) in the frame of ``model``'s pose in the world file."""
    m = world.models.get(model)
    if m is None:
        return [float(v) for v in p]
    return [float(v) for v in m.pose.inverse().transform_point(np.asarray(p, float))]


def world_info(world):
    """{'icons': [{kind, name, id, model, position, offset, ...}], 'bounds'} of a sim_world
    World (``offline_world``)."""
    icons = []
    for li in world.lights:
        icons.append({'kind': 'light', 'name': li.name, 'id': li.name, 'model': None,
                      'light': li.kind, 'position': [float(v) for v in li.pose.p],
                      'offset': [float(v) for v in li.pose.p],
                      'rgb': [float(v) for v in li.diffuse[:3]]})
    names = {'wifi': 'wifi', 'bluetooth': 'bluetooth', 'cell': 'cell'}
    for tx in world.transmitters():
        if tx.kind not in names:
            continue
        p = tx.position()
        icons.append({'kind': names[tx.kind], 'name': tx.name, 'id': tx.id, 'model': tx.model,
                      'frequency': tx.frequency, 'channel': tx.channel,
                      'position': [float(v) for v in p], 'offset': _offset(world, tx.model, p)})
    from simsensors.nfc import NfcTag
    for model, plugins in world.plugins.items():
        for pl in plugins:
            if isinstance(pl, NfcTag) and getattr(pl, 'data', None):
                p = world.link_pose(model, pl.body).p
                icons.append({'kind': 'nfc', 'name': pl.name, 'id': pl.name, 'model': model,
                              'data': pl.data, 'position': [float(v) for v in p],
                              'offset': _offset(world, model, p)})
    return {'icons': icons, 'bounds': bounds(world)}


def bounds(world, margin=1.0, near=100.0):
    """[xmin, xmax, ymin, ymax] around the links of the world's models (not planes; none
    farther than ``near`` m from the origin: a cell tower kilometres away), with a margin."""
    pts = []
    for name, m in world.models.items():
        if any(c.geometry.kind == 'plane' for ln in m.links.values()
               for c in ln.collisions):
            continue
        for ln in m.links:
            try:
                p = world.link_pose(name, ln).p
            except KeyError:
                continue
            if abs(p[0]) < near and abs(p[1]) < near:
                pts.append(p[:2])
    if not pts:
        return [-5.0, 5.0, -5.0, 5.0]
    a = np.asarray(pts)
    lo, hi = a.min(axis=0) - margin, a.max(axis=0) + margin
    return [float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])]


def receiver_params(model):
    """(g_rx, l_rx, wall keyword arguments) of the WiFi receiver of ``model`` (a sim_world
    Model: the phone's description), read with the receiver's own parameter rows; the
    receiver's defaults without one."""
    from types import SimpleNamespace
    from sim_world import plugins
    from sim_world.plugins.params import parse_params
    from simsensors.wifi import WifiReceiver
    spec = None
    if model is not None:
        spec = next((s for s in model.plugins if plugins.lookup(s.filename) is WifiReceiver),
                    None)
    if spec is None:
        from sim_world.model import PluginSpec
        spec = PluginSpec('libgazebo_ros_wifi.so')
    p, _errors = parse_params(spec, WifiReceiver.param_rows(), 'plugin %s' % spec.filename)
    return p.rxGain, p.rxLoss, WifiReceiver.wall_args(SimpleNamespace(p=p))


def strongest_grid(world, xs, ys, z, bssid=None, rx=(0.0, 0.0, {})):
    """(P_RX dBm grid [len(ys), len(xs)] of the strongest access point (or ``bssid``'s),
    solid mask, the access points used) by simsensors.wifi_map.power_grid."""
    from simsensors.wifi_map import power_grid
    aps = world.transmitters('wifi')
    if bssid is not None:
        aps = [t for t in aps if t.id == bssid.lower()]
        if not aps:
            raise ValueError('wifi_map: no access point with BSSID %s (the world has: %s)'
                             % (bssid, ', '.join(t.id for t in world.transmitters('wifi'))
                                or 'none'))
    if not aps:
        raise ValueError('wifi_map: the world has no access point (libgazebo_ros_wifi_ap.so)')
    g_rx, l_rx, wall = rx
    best, solid = None, None
    for tx in aps:
        grid, solid = power_grid(world, tx, xs, ys, z, g_rx, l_rx, **wall)
        best = grid if best is None else np.maximum(best, grid)
    return best, solid, [t.id for t in aps]


def map_png(grid, solid, lo=LO, hi=HI, alpha=190):
    """RGBA PNG bytes of a power grid (row 0 = the northmost, +y up), wifi_map's colours
    (jet from lo to hi dBm, grey below lo); walls transparent."""
    import cv2
    t = np.clip((grid - lo) / (hi - lo), 0, 1)
    bgr = cv2.applyColorMap((t * 255).astype(np.uint8), cv2.COLORMAP_JET)
    bgr[grid < lo] = (128, 128, 128)
    a = np.full(grid.shape, alpha, np.uint8)
    a[solid] = 0
    img = np.dstack([bgr, a])[::-1]
    ok, buf = cv2.imencode('.png', np.ascontiguousarray(img))
    if not ok:
        raise ValueError('wifi_map: cannot encode the map')
    return buf.tobytes()


def rms_dbfs(samples):
    """The level of PCM samples (full scale 1.0) in dBFS (-inf for silence)."""
    a = np.asarray(samples, float)
    if not a.size:
        return -math.inf
    r = float(np.sqrt(np.mean(a * a)))
    return 20 * math.log10(r) if r > 0 else -math.inf


# -- the studio's side --------------------------------------------------------------------------
_PHONES = {}


def _phone_model(studio):
    """The phone's sim_world Model (its description, /robot_description), or None."""
    key = id(studio)
    if key not in _PHONES:
        model = None
        rospy = getattr(studio.world, 'rospy', None)
        text = rospy.get_param('/robot_description', None) if rospy is not None else None
        if text:
            try:
                from sim_world.urdf import parse_urdf
                model = parse_urdf(text, name='mobile_device')
            except Exception as e:  # noqa: BLE001 - then the receiver's defaults
                studio.log('studio: wifi_map: the phone description: %s' % e)
        _PHONES[key] = model
    return _PHONES[key]


def _world_info(studio):
    w = offline_world(world_file(studio))
    with w.lock:
        info = world_info(w)
    # what other extensions add (spawned.icons: the spawned models' icons, and each icon at
    # its model's pose now), registered by their attach(): overlay imports none of them
    for fn in getattr(studio, 'icon_hooks', ()):
        info['icons'] = fn(studio, info['icons'])
    return info


def _wifi_map(studio, f):
    w = offline_world(world_file(studio))
    b = bounds(w)
    step = f['grid']
    xs = np.arange(b[0] + step / 2, b[1], step)
    ys = np.arange(b[2] + step / 2, b[3], step)
    if len(xs) * len(ys) > MAX_CELLS:
        raise ValueError('wifi_map: grid %g m makes %d cells over the world; at most %d '
                         '(a larger grid)' % (step, len(xs) * len(ys), MAX_CELLS))
    rx = receiver_params(_phone_model(studio))
    with w.lock:
        grid, solid, aps = strongest_grid(w, xs, ys, f['height'], f['bssid'], rx)
    png = map_png(grid, solid)
    return {'image': 'data:image/png;base64,' + base64.b64encode(png).decode(),
            'bounds': [float(xs[0] - step / 2), float(xs[-1] + step / 2),
                       float(ys[0] - step / 2), float(ys[-1] + step / 2)],
            'lo': LO, 'hi': HI, 'min': float(grid.min()), 'max': float(grid.max()),
            'access_points': aps, 'height': f['height'], 'grid': step}


async def handle(studio, cmd, client):
    loop = asyncio.get_event_loop()
    if cmd.op == 'world_info':
        return await loop.run_in_executor(None, _world_info, studio)
    return await loop.run_in_executor(None, _wifi_map, studio, cmd.fields)


class SpeakerLevel(object):
    """The level of each phone's speaker: <model>/speaker/audio's last chunk, in dBFS."""

    def __init__(self, rospy, phones):
        from mobile_device_sim.msg import AudioData
        self.levels = {}
        self.at = {}
        self.lock = threading.Lock()
        self.subs = [rospy.Subscriber('/%s/speaker/audio' % p, AudioData, self._on,
                                      callback_args=p, queue_size=1) for p in phones]

    def _on(self, msg, phone):
        v = rms_dbfs(msg.samples)
        with self.lock:
            self.levels[phone] = round(v, 1) if math.isfinite(v) else None
            self.at[phone] = msg.header.stamp.to_sec()

    def close(self):
        for s in self.subs:
            s.unregister()


def routes(app, studio):
    """The speaker levels' stream (``outputs``), 4 Hz while a speaker has played."""
    async def start(_app):
        async def tick():
            rospy = getattr(studio.world, 'rospy', None)
            phones = [m['name'] for m in studio.scene_models if m.get('display')]
            if rospy is None or not phones:
                return
            level = SpeakerLevel(rospy, phones)
            try:
                while True:
                    await asyncio.sleep(0.25)
                    with level.lock:
                        levels = dict(level.levels)
                    if levels and studio.clients:
                        studio.broadcast('outputs', {'t': studio.world.clock,
                                                     'speaker': levels})
            finally:
                level.close()
        app['overlay'] = asyncio.ensure_future(tick())

    async def stop(_app):
        app['overlay'].cancel()
    app.on_startup.append(start)
    app.on_shutdown.append(stop)
