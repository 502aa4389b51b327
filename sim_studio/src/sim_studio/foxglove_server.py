"""``studio --foxglove [PORT]``: the studio's world also on a Foxglove WebSocket server
(foxglove-sdk, PyPI), for Foxglove and Lichtblick users (issue 47, optional).

Channels (foxglove's own schemas, protobuf encoded):

- ``/scene`` (foxglove.SceneUpdate): each model's links as entities of primitives (boxes,
  cylinders, spheres; meshes and textured shapes as their bounding boxes), in the link's
  frame (``model/link``, frame-locked), again every 2 s for late subscribers;
- ``/tf`` (foxglove.FrameTransforms): ``world`` -> each model and each of its links (the
  jointed models' links where the world has them now), at ``rate`` Hz;
- ``<camera topic>/compressed`` (foxglove.CompressedImage): the camera panel's JPEG;
- ``/<phone>/fix`` (foxglove.LocationFix): each phone's GPS fix (the subscription to the
  phone's ``fix`` is made only while a Foxglove client listens: the GPS then computes).

Timestamps are the world's sim time. Nothing is built or encoded for a channel nobody
subscribes to, and the world is never waited for (the studio's latest values). The server
binds 127.0.0.1 only: the Foxglove protocol has no token, and whoever reaches it could see
the world (the studio's own ``--host`` is not used for it)."""
import asyncio
import time

__all__ = ['DEFAULT_PORT', 'FoxgloveBridge', 'split_port', 'start']

DEFAULT_PORT = 8765


def split_port(value, args):
    """``--foxglove`` takes an optional PORT: (port or None, launch args). A ``name:=value``
    argparse took for it goes back to the launch arguments."""
    if value is None:
        return None, list(args)
    if value == '':
        return DEFAULT_PORT, list(args)
    if value.isdigit():
        return int(value), list(args)
    if ':=' in value:
        return DEFAULT_PORT, [value] + list(args)
    raise SystemExit('studio: --foxglove PORT: a port number, got %s' % value)


def _stamp(t):
    from foxglove.messages import Timestamp
    sec = int(t)
    return Timestamp(sec=sec, nsec=int(round((t - sec) * 1e9)) % 1000000000)


def _covariance_type(n):
    """NavSatFix's COVARIANCE_TYPE_* (0..3) as foxglove's enum (the same numbers)."""
    from foxglove.messages import LocationFixPositionCovarianceType as T
    kinds = {k.value: k for k in (T.Unknown, T.Approximated, T.DiagonalKnown, T.Known)}
    return kinds.get(int(n), T.Unknown)


def _pose(position, orientation):
    from foxglove.messages import Pose, Quaternion, Vector3
    return Pose(position=Vector3(x=float(position[0]), y=float(position[1]),
                                 z=float(position[2])),
                orientation=Quaternion(x=float(orientation[0]), y=float(orientation[1]),
                                       z=float(orientation[2]), w=float(orientation[3])))


def _compose(a, b):
    """Pose ``b`` (dict position/orientation) in frame ``a`` (the same): as a dict."""
    from sim_world.transforms import Pose
    p = Pose(a['position'], a['orientation']) * Pose(b['position'], b['orientation'])
    return {'position': [float(v) for v in p.p], 'orientation': [float(v) for v in p.q]}


def entities(models, t):
    """foxglove SceneEntity list of the studio's model descriptions (scene.describe_*)."""
    from foxglove.messages import (Color, CubePrimitive, CylinderPrimitive, SceneEntity,
                                   SpherePrimitive, Vector3)
    out = []
    for m in models:
        for ln in m.get('links', []):
            cubes, cyls, spheres = [], [], []
            for v in ln.get('visuals', []):
                g = v['geometry']
                rgba = v.get('rgba') or [0.8, 0.8, 0.8, 1.0]
                color = Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3] if rgba[3] > 0 else 1)
                origin = v.get('origin') or {'position': [0, 0, 0],
                                             'orientation': [0, 0, 0, 1]}
                kind = g.get('kind')
                if kind in ('box', 'plane', 'shape'):
                    size = list(g.get('size', [0.05, 0.05, 0.05])) + [0.0]
                    size = size[:3] if kind != 'plane' else [size[0], size[1], 0.001]
                    o = _compose(origin, {'position': g.get('center', [0, 0, 0]),
                                          'orientation': [0, 0, 0, 1]})
                    cubes.append(CubePrimitive(pose=_pose(o['position'], o['orientation']),
                                               size=Vector3(x=size[0], y=size[1], z=size[2]),
                                               color=color))
                elif kind == 'cylinder':
                    d = 2 * g['radius']
                    cyls.append(CylinderPrimitive(
                        pose=_pose(origin['position'], origin['orientation']),
                        size=Vector3(x=d, y=d, z=g['length']), bottom_scale=1.0,
                        top_scale=1.0, color=color))
                elif kind == 'sphere':
                    d = 2 * g['radius']
                    spheres.append(SpherePrimitive(
                        pose=_pose(origin['position'], origin['orientation']),
                        size=Vector3(x=d, y=d, z=d), color=color))
            if cubes or cyls or spheres:
                name = '%s/%s' % (m['name'], ln['name'])
                out.append(SceneEntity(timestamp=_stamp(t), frame_id=name, id=name,
                                       frame_locked=True, cubes=cubes, cylinders=cyls,
                                       spheres=spheres))
    return out


def transforms(studio, t):
    """foxglove FrameTransform list: world -> model, world -> model/link."""
    from foxglove.messages import FrameTransform, Quaternion, Vector3
    poses = studio.world.poses()
    moving = studio.world.link_poses()
    known = {m['name']: m for m in studio.scene_models}
    out = []
    stamp = _stamp(t)

    def tf(child, pos, q):
        out.append(FrameTransform(timestamp=stamp, parent_frame_id='world',
                                  child_frame_id=child,
                                  translation=Vector3(x=pos[0], y=pos[1], z=pos[2]),
                                  rotation=Quaternion(x=q[0], y=q[1], z=q[2], w=q[3])))
    for name, pq in sorted(poses.items()):
        tf(name, pq[:3], pq[3:])
        now = moving.get(name, {})
        model = {'position': pq[:3], 'orientation': pq[3:]}
        for ln in known.get(name, {}).get('links', []):
            if ln['name'] in now:
                p = now[ln['name']]
                tf('%s/%s' % (name, ln['name']), p[:3], p[3:])
            else:
                p = _compose(model, ln['pose'])
                tf('%s/%s' % (name, ln['name']), p['position'], p['orientation'])
    return out


class FoxgloveBridge(object):
    """The studio's world on a foxglove-sdk WebSocket server (``start``, ``run``, ``stop``)."""

    def __init__(self, studio, rospy, port=DEFAULT_PORT, rate=20.0):
        self.studio = studio
        self.rospy = rospy
        self.port = port
        self.rate = rate
        self.server = None
        self.fixes = {}               # phone -> latest NavSatFix
        self._fix_subs = {}
        self._scene_at = -1e9
        self._image_seq = -1
        self._image_at = 0.0
        self.sent = {'scene': 0, 'tf': 0, 'image': 0, 'fix': 0}

    def start(self):
        import foxglove
        from foxglove.channels import (CompressedImageChannel, FrameTransformsChannel,
                                       LocationFixChannel, SceneUpdateChannel)
        self.server = foxglove.start_server(name='mobile_device_sim studio',
                                            host='127.0.0.1', port=self.port)
        self.port = self.server.port
        self.scene_ch = SceneUpdateChannel('/scene')
        self.tf_ch = FrameTransformsChannel('/tf')
        cam = getattr(self.studio.world, 'camera_topic', None) or '/camera'
        self.image_ch = CompressedImageChannel(cam.rstrip('/') + '/compressed')
        self.phones = [m['name'] for m in self.studio.scene_models if m.get('display')]
        self.fix_ch = {p: LocationFixChannel('/%s/fix' % p) for p in self.phones}
        return self

    def _on_fix(self, phone):
        def cb(msg):
            self.fixes[phone] = msg
        return cb

    def _watch_fixes(self):
        """Subscribe to a phone's fix while a Foxglove client listens to it, not longer."""
        from sensor_msgs.msg import NavSatFix
        for p, ch in self.fix_ch.items():
            want = ch.has_sinks()
            if want and p not in self._fix_subs:
                self._fix_subs[p] = self.rospy.Subscriber('/%s/fix' % p, NavSatFix,
                                                          self._on_fix(p), queue_size=1)
            elif not want and p in self._fix_subs:
                self._fix_subs.pop(p).unregister()
                self.fixes.pop(p, None)

    def publish_once(self, jpeg=None):
        """One tick: what each listened-to channel needs now (``jpeg``: the camera image
        when a new one is due and already made)."""
        from foxglove.messages import (CompressedImage, FrameTransforms, LocationFix,
                                       SceneUpdate)
        t = float(self.studio.world.clock)
        ns = int(t * 1e9)
        now = time.monotonic()
        if self.scene_ch.has_sinks() and now - self._scene_at > 2.0:
            self._scene_at = now
            self.scene_ch.log(SceneUpdate(entities=entities(self.studio.scene_models, t)),
                              log_time=ns)
            self.sent['scene'] += 1
        elif not self.scene_ch.has_sinks():
            self._scene_at = -1e9            # a new subscriber gets the scene at once
        if self.tf_ch.has_sinks():
            self.tf_ch.log(FrameTransforms(transforms=transforms(self.studio, t)),
                           log_time=ns)
            self.sent['tf'] += 1
        if jpeg:
            self.image_ch.log(CompressedImage(timestamp=_stamp(t), frame_id='camera',
                                              data=jpeg, format='jpeg'), log_time=ns)
            self.sent['image'] += 1
        self._watch_fixes()
        for p, msg in list(self.fixes.items()):
            self.fixes.pop(p, None)
            ft = msg.header.stamp.to_sec() or t
            self.fix_ch[p].log(LocationFix(
                timestamp=_stamp(ft), frame_id=msg.header.frame_id or p,
                latitude=msg.latitude, longitude=msg.longitude, altitude=msg.altitude,
                position_covariance=[float(c) for c in msg.position_covariance],
                position_covariance_type=_covariance_type(msg.position_covariance_type)),
                log_time=int(ft * 1e9))
            self.sent['fix'] += 1

    def _image_due(self):
        w = self.studio.world
        period = 1.0 / self.studio.camera_rate if self.studio.camera_rate > 0 else None
        seq = getattr(w, 'image_seq', 0)
        return (period is not None and self.image_ch.has_sinks() and seq != self._image_seq
                and time.monotonic() - self._image_at >= period), seq

    async def run(self):
        loop = asyncio.get_event_loop()
        period = 1.0 / self.rate
        while True:
            try:
                jpeg = None
                due, seq = self._image_due()
                if due:
                    self._image_seq, self._image_at = seq, time.monotonic()
                    cam = getattr(self.studio, '_cam', None)
                    if cam and cam[1] == seq and self.studio.last_jpeg:
                        jpeg = self.studio.last_jpeg     # the page's stream made it already
                    else:
                        jpeg = await loop.run_in_executor(None, self.studio.world.camera_jpeg)
                self.publish_once(jpeg)
            except asyncio.CancelledError:
                raise
            except Exception as e:  # noqa: BLE001 - the bridge must outlive a bad tick
                self.studio.log('studio: foxglove: %s: %s' % (type(e).__name__, e))
            await asyncio.sleep(period)

    def stop(self):
        task = getattr(self, 'task', None)
        if task is not None:
            task.cancel()
        for s in self._fix_subs.values():
            s.unregister()
        self._fix_subs = {}
        if self.server is not None:
            self.server.stop()
            self.server = None
            for ch in [self.scene_ch, self.tf_ch, self.image_ch] + list(self.fix_ch.values()):
                ch.close()


def start(studio, rospy, port, loop):
    """Start the bridge's server and its task on ``loop``; prints the address. None (and
    one line saying why) when it cannot: the studio serves on without it."""
    try:
        b = FoxgloveBridge(studio, rospy, port).start()
    except Exception as e:  # noqa: BLE001 - a port in use, the SDK missing
        print('studio: --foxglove: cannot serve on 127.0.0.1:%d: %s' % (port, e), flush=True)
        return None
    b.task = loop.create_task(b.run())
    print('studio: foxglove ws://127.0.0.1:%d' % b.port, flush=True)
    return b
