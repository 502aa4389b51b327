"""The studio's aiohttp server: the page and its assets, ``/ws``, ``POST /api/cmd``,
``GET /api/scene``, and the one command handler they share (``Studio.handle``).

Streams: every client of ``/ws`` gets the model poses, sim time and real-time factor
(``{"type": "poses"}``) at ``rate`` Hz, the phone camera's latest JPEG (a binary
message) at most ``camera_rate`` Hz and each phone display's image topic as JPEG
(``{"type": "display"}``) at most ``display_rate`` Hz. Each client has one slot per stream
that the next value overwrites: a slow client gets the latest and loses the rest; nothing
waits for it.

Control: one client holds control (the first that sends a command needing it, or asks with
``{"op": "control", "take": true}``); the others are read-only until it lets go or leaves.
``POST /api/cmd`` from 127.0.0.1 acts under the holder's control."""
import asyncio
import base64
import json
import os
import re
import secrets
import subprocess
import sys
import tempfile
import time

from aiohttp import WSMsgType, web

from . import extensions, protocol
from .protocol import ProtocolError
from .recorder import Recorder, check as check_yaml

__all__ = ['Studio', 'make_app', 'index_html', 'STATIC', 'THREE']

STATIC = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'static')
THREE = os.environ.get('MDS_THREE_DIR', '/usr/share/javascript/three')
PKG_ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                         '..', '..', '..'))
RUN_SCENARIO = os.path.join(PKG_ROOT, 'testing_instance', 'nodes', 'run_scenario')
VERDICT = re.compile(r'^(PASS|FAIL|ERROR) ([\w.-]+):? ?(.*)$')
STATUS = {0: 'PASS', 1: 'FAIL'}
DISPLAY_WIDTH = 300      # px at most of the display stream's images (twice the page's view)


class Client(object):
    """One /ws connection: its latest-wins slots and the task that sends them."""
    _n = 0

    def __init__(self, ws, remote):
        Client._n += 1
        self.name = 'client%d' % Client._n
        self.ws = ws
        self.remote = remote
        self.slots = {}            # 'poses' / 'camera' / 'replies'... -> latest payload
        self.replies = []          # answers are never dropped (one per command)
        self.wake = asyncio.Event()
        self.sent = 0
        self.device = False        # wants the device panel's values
        self.acks = False          # it says 'ack' for each message it has taken in
        self.unacked = 0

    #: messages a client that acks may have sent to it and not yet taken in; the streams
    #: wait in their slots (latest wins) beyond that, so a slow page never falls behind
    WINDOW = 6

    def put(self, key, payload):
        self.slots[key] = payload
        self.wake.set()

    def ack(self):
        """The client took in one more message (text 'ack': flow control on)."""
        self.acks = True
        self.unacked = max(0, self.unacked - 1)
        if self.slots or self.replies:
            self.wake.set()

    def answer(self, obj):
        self.replies.append(json.dumps(obj))
        self.wake.set()

    async def pump(self):
        while not self.ws.closed:
            await self.wake.wait()
            self.wake.clear()
            while self.replies:
                await self.ws.send_str(self.replies.pop(0))
                self.unacked += self.acks
            if self.acks and self.unacked >= self.WINDOW:
                continue                 # the page is behind: its slots wait for its acks
            slots, self.slots = self.slots, {}
            for key, payload in slots.items():
                if isinstance(payload, bytes):
                    await self.ws.send_bytes(payload)
                else:
                    await self.ws.send_str(payload)
                self.sent += 1
                self.unacked += self.acks


class Studio(object):
    """The command handler and the streams, over a world link (``world.WorldLink`` or a
    test's stand-in with the same methods)."""

    def __init__(self, world, scene_models=(), rate=40.0, camera_rate=15.0, token=None,
                 run_dir=None, launch='office', assets=None):
        self.world = world
        self.assets = assets             # scene.Assets: the meshes and textures served
        self.scene_models = list(scene_models)     # scene.describe_* of the known models
        self.rate = rate
        self.camera_rate = camera_rate
        self.token = token
        self.run_dir = run_dir or tempfile.mkdtemp(prefix='studio-')
        self.recorder = Recorder(launch=launch)
        self.clients = []
        self.holder = None           # the Client holding control
        self.lock = None             # asyncio.Lock: world commands one at a time
        self.runs = 0
        self.last_jpeg = None
        self.want_camera = False
        self.display_rate = camera_rate  # Hz at most of each phone display's images
        self.want_display = False        # a new client: send the displays' latest again
        self._disp = {}                  # model -> (when its image went out, its seq)
        self._disp_jpeg = {}             # topic -> (seq, base64 JPEG)
        self._displays_watched = set()   # the display image topics subscribed
        self.device = None           # device.DeviceWatch (None: no device panel)
        self.device_rate = 4.0       # Hz of the device panel's values
        self._device_at = [0.0, 0.0]  # when they went out, when topics were looked for
        self.health = None           # () -> None or (why the world is gone, log tail)
        self.world_gone = None
        self._health_at = 0.0
        self.log = lambda text: print(text, flush=True)
        # fn(cmd: Command or None, raw: the decoded object or None, reply, client, sim time,
        # wall time) after every command is answered (an extension's log: sim_studio.study)
        self.on_command = []
        self.extensions = extensions.load()

    def broadcast(self, kind, obj, clients=None):
        """One stream message ``{"v": 1, "type": kind, ...obj}`` to every client (or those
        given), in its latest-wins slot ``kind``: an extension's stream."""
        msg = json.dumps(dict(obj, v=protocol.VERSION, type=kind), separators=(',', ':'))
        for c in (self.clients if clients is None else clients):
            c.put(kind, msg)

    # -- the one command handler --------------------------------------------------------
    async def handle_text(self, text, client=None, local=False):
        """Parse and carry out one command's text; returns its reply (a dict), which each
        ``on_command`` hook sees first."""
        raw, cmd, sim, wall = None, None, self.world.clock, time.time()
        try:
            try:
                raw = json.loads(text) if isinstance(text, (str, bytes)) and \
                    len(text) <= protocol.MAX_BYTES else None
            except ValueError:
                raw = None
            cmd = protocol.parse(text, models=self._models())
        except ProtocolError as e:
            self.log('studio: refused a command from %s: %s'
                     % (client.name if client else 'POST /api/cmd', e))
            rep = protocol.error(str(e), raw=raw)
        else:
            rep = await self.handle(cmd, client, local)
        for fn in self.on_command:
            fn(cmd, raw, rep, client, sim, wall)
        return rep

    def _models(self):
        names = self.world.model_names()
        return names if names else None

    async def handle(self, cmd, client=None, local=False):
        if cmd.op in protocol.WORLD_OPS or cmd.op == 'control':
            why = self._control(cmd, client, local)
            if why:
                return protocol.error(why, cmd)
            if cmd.op == 'control':
                return protocol.reply(cmd, control=self.holder is client and client is not None)
        try:
            ext = extensions.handler(cmd.op)
            if ext is not None:
                return protocol.reply(cmd, **((await ext(self, cmd, client)) or {}))
            if cmd.op == 'scene':
                return protocol.reply(cmd, scene=self.scene())
            if cmd.op == 'device':
                return protocol.reply(cmd, **(await self._device_op(cmd['on'], client)))
            if cmd.op == 'expect':
                entry = self.recorder.expect(cmd.fields)
                self._tell_recording()
                return protocol.reply(cmd, expect=entry, yaml=self.recorder.yaml())
            if cmd.op == 'check':
                return protocol.reply(cmd, problems=check_yaml(cmd['yaml']))
            if cmd.op == 'record':
                return protocol.reply(cmd, **self._record(cmd['on']))
            if cmd.op == 'run':
                return protocol.reply(cmd, **(await self.run_yaml(cmd['yaml'])))
            if self.lock is None:
                self.lock = asyncio.Lock()
            async with self.lock:
                loop = asyncio.get_event_loop()
                extra = await loop.run_in_executor(None, self._apply, cmd)
        except Exception as e:  # noqa: BLE001 - a refused service: one error back
            self.log('studio: %s failed: %s' % (cmd.op, e))
            # an extension's exception may carry more of the reply (``reply``: {field: value})
            return dict(getattr(e, 'reply', None) or {}, **protocol.error(str(e), cmd))
        return protocol.reply(cmd, **(extra or {}))

    async def _device_op(self, on, client):
        if self.device is None:
            raise ValueError('device: this studio watches no phone (no model with a touch '
                             'display in the descriptions it read)')
        if client is not None:
            client.device = on
        if on:
            loop = asyncio.get_event_loop()
            await loop.run_in_executor(None, self.device.refresh)
            self._device_at[1] = time.monotonic()
        return {'device': on, 'topics': self.device.values()}

    def device_message(self):
        return json.dumps({'v': protocol.VERSION, 'type': 'device', 't': self.world.clock,
                           'topics': self.device.values()}, separators=(',', ':'))

    def _control(self, cmd, client, local):
        """None when ``client`` may send ``cmd``, else why not."""
        if client is None:                 # POST /api/cmd
            if local or self.holder is None:
                return None
            return 'read-only: %s holds control' % self.holder.name
        if cmd.op == 'control' and not cmd['take']:
            if self.holder is client:
                self.holder = None
                self._tell_control()
            return None
        if self.holder is None or self.holder.ws.closed:
            self.holder = client
            self._tell_control()
            return None
        if self.holder is client:
            return None
        return 'read-only: %s holds control; ask again once it lets go' % self.holder.name

    def _tell_control(self):
        for c in self.clients:
            c.put('control', json.dumps({'v': protocol.VERSION, 'type': 'control',
                                         'you': c is self.holder,
                                         'holder': self.holder.name if self.holder else None}))

    def _record(self, on):
        if on:
            self.recorder.start(self.world.clock)
        else:
            self.recorder.stop()
        self._tell_recording()
        return {'recording': self.recorder.on, 'yaml': self.recorder.yaml()}

    def _tell_recording(self):
        msg = json.dumps({'v': protocol.VERSION, 'type': 'recording', 'on': self.recorder.on,
                          'yaml': self.recorder.yaml()})
        for c in self.clients:
            c.put('recording', msg)

    def _apply(self, cmd):
        """Carry out a world-changing command (in a worker thread: rospy calls block)."""
        w, f = self.world, cmd.fields
        t = w.clock
        display = None
        getattr(w, 'links_moved', lambda: None)()     # a link may move: ask at full rate
        if cmd.op == 'set_pose':
            w.set_pose(f['model'], f['position'], f['rpy'])
        elif cmd.op == 'touch':
            display = w.touch(f['model'], f['x'], f['y'], f['duration'],
                              self.display_size(f['model']))
        elif cmd.op == 'press_button':
            w.press_button(f['model'], f['button'], f['duration'])
        elif cmd.op == 'set_environment':
            w.set_environment(f['values'])
        elif cmd.op == 'fault':
            w.fault(f['model'], f['sensor'], f['fault'], f['value'])
        elif cmd.op == 'play':
            w.play()
        elif cmd.op == 'pause':
            w.pause()
        elif cmd.op == 'reset':
            w.reset()
        elif cmd.op == 'step':
            return {'sim_time': w.step(f['until'])}
        entry = self.recorder.add(cmd, t, display)
        if entry is not None:
            self._tell_recording_threadsafe()
        return {'sim_time': t, 'recorded': entry}

    def display_size(self, model):
        """(width, height) px of ``model``'s touch display, from its description."""
        d = next((m.get('display') for m in self.scene_models if m['name'] == model), None)
        if not d:
            raise ValueError('touch: the studio knows no touch display of model %s (it reads '
                             'displays from the descriptions of the models it knows: %s)'
                             % (model, ', '.join(m['name'] for m in self.scene_models
                                                 if m.get('display')) or 'none'))
        return d['width'], d['height']

    def _tell_recording_threadsafe(self):
        loop = getattr(self, 'loop', None)
        if loop is not None:
            loop.call_soon_threadsafe(self._tell_recording)

    # -- scene and streams ----------------------------------------------------------------
    def scene(self):
        """Every model in the world: its pose, its links (pose in the world at the model's
        rest configuration), the visuals the page draws."""
        poses = self.world.poses()
        moving = self._link_poses()
        known = {m['name']: m for m in self.scene_models}
        models = []
        for name, pq in sorted(poses.items()):
            d = known.get(name, {'name': name, 'static': False, 'links': []})
            now = moving.get(name, {})
            models.append(dict(d, pose={'position': pq[:3], 'orientation': pq[3:]},
                               links=[dict(ln, world_pose={'position': now[ln['name']][:3],
                                                           'orientation': now[ln['name']][3:]}
                                           if ln['name'] in now else _compose(pq, ln['pose']))
                                      for ln in d['links']]))
        return {'v': protocol.VERSION, 'sim_time': self.world.clock, 'rtf': self.world.rtf(),
                'models': models}

    def _link_poses(self):
        return self.world.link_poses()

    def poses_message(self):
        return json.dumps({'v': protocol.VERSION, 'type': 'poses', 't': self.world.clock,
                           'rtf': round(self.world.rtf(), 3), 'poses': self.world.poses(),
                           'links': self._link_poses(),
                           'recording': self.recorder.on, 'world_gone': self.world_gone},
                          separators=(',', ':'))

    def check_world(self):
        """Ask ``health()`` (None while the world is there, else (why, [log tail lines]))
        and keep its answer in ``world_gone`` for the stream (the page's banner)."""
        if self.health is None:
            return
        gone = self.health()
        if gone and not self.world_gone:
            self.log('studio: %s' % gone[0])
        self.world_gone = {'error': gone[0], 'log': list(gone[1])} if gone else None

    async def stream(self):
        """Poses to every client at ``rate`` Hz; the camera's JPEG at most camera_rate Hz."""
        loop = asyncio.get_event_loop()
        period = 1.0 / self.rate
        cam_period = 1.0 / self.camera_rate if self.camera_rate > 0 else None
        self._cam = [0.0, -1]          # when the last image went out, its sequence number
        nxt = time.monotonic()
        while True:
            nxt += period
            try:
                await self._stream_once(loop, cam_period)
            except asyncio.CancelledError:
                raise
            except Exception as e:  # noqa: BLE001 - the stream must outlive a bad frame
                self.log('studio: stream: %s: %s' % (type(e).__name__, e))
            await asyncio.sleep(max(0.0, nxt - time.monotonic()))
            if time.monotonic() - nxt > 1.0:
                nxt = time.monotonic()

    async def _stream_once(self, loop, cam_period):
        """One tick: the poses to every client, and the camera image when it is due."""
        if self.health is not None and time.monotonic() - self._health_at > 1.0:
            self._health_at = time.monotonic()
            await loop.run_in_executor(None, self.check_world)
        if self.clients:
            due = getattr(self.world, 'links_due', None)
            if due is None or due():          # no thread hand-off for nothing to do
                await loop.run_in_executor(None, self.world.poll_links)
            msg = self.poses_message()
            for c in self.clients:
                c.put('poses', msg)
            now = time.monotonic()
            last_cam, last_seq = self._cam
            seq = getattr(self.world, 'image_seq', 0)
            if cam_period and (seq != last_seq or self.want_camera) and \
                    now - last_cam >= cam_period:
                # a new client gets the latest image even while the world is paused
                self.want_camera = False
                if seq != last_seq or self.last_jpeg is None:
                    self.last_jpeg = await loop.run_in_executor(None,
                                                                self.world.camera_jpeg)
                self._cam = [now, seq]
                jpeg = self.last_jpeg
                if jpeg:
                    for c in self.clients:
                        c.put('camera', jpeg)
            await self._stream_displays(loop, now)
            await self._stream_device(loop, now)

    def displays(self):
        """[(model, image topic)] of the known phones whose display shows an image topic
        (textvid's video texture: scene.display_of)."""
        return [(m['name'], m['display']['image_topic']) for m in self.scene_models
                if m.get('display') and m['display'].get('image_topic')]

    async def _stream_displays(self, loop, now):
        """Each phone display's image topic as its own stream (``{"type": "display",
        "model", "topic", "t", "jpeg": base64}``, slot ``display:MODEL``, latest wins) at
        most ``display_rate`` Hz, a new image only, at most DISPLAY_WIDTH pixels wide (the
        page draws it 150 px wide); the topics are subscribed (queue size 1) once a client
        watches."""
        shown = self.displays()
        if not shown or not self.display_rate > 0:
            return
        w = self.world
        topics = {t for _m, t in shown}
        if not topics <= self._displays_watched and hasattr(w, 'watch_images'):
            # the phones' displays, also of a phone spawned after the studio started
            new = sorted(topics - self._displays_watched)
            self._displays_watched |= topics
            await loop.run_in_executor(None, w.watch_images, new)
        if self.want_display:
            self.want_display = False
            self._disp.clear()
        seqs = getattr(w, 'image_seqs', {})
        for model, topic in shown:
            last_at, last_seq = self._disp.get(model, (0.0, -1))
            seq = seqs.get(topic, 0)
            if not seq or seq == last_seq or now - last_at < 1.0 / self.display_rate:
                continue
            cached = self._disp_jpeg.get(topic)
            if cached is None or cached[0] != seq:
                jpeg = await loop.run_in_executor(None, w.image_jpeg, topic, DISPLAY_WIDTH)
                cached = self._disp_jpeg[topic] = (seq, base64.b64encode(jpeg).decode()
                                                   if jpeg else None)
            self._disp[model] = (now, seq)
            if cached[1]:
                msg = json.dumps({'v': protocol.VERSION, 'type': 'display', 'model': model,
                                  'topic': topic, 't': w.clock, 'jpeg': cached[1]},
                                 separators=(',', ':'))
                for c in self.clients:
                    c.put('display:' + model, msg)

    async def _stream_device(self, loop, now):
        """The device panel's values to the clients that asked, at ``device_rate`` Hz;
        topics that appeared since are looked for every 2 s."""
        watchers = [c for c in self.clients if c.device]
        if self.device is None or not watchers or now - self._device_at[0] < \
                1.0 / self.device_rate:
            return
        self._device_at[0] = now
        if now - self._device_at[1] > 2.0:
            self._device_at[1] = now
            await loop.run_in_executor(None, self.device.refresh)
        msg = self.device_message()
        for c in watchers:
            c.put('device', msg)

    # -- running a scenario -----------------------------------------------------------------
    async def run_yaml(self, text):
        """Run scenario text with run_scenario (its own world, not this one); the verdicts
        in run_scenario's words."""
        problems = check_yaml(text)
        if problems:
            return {'status': 'ERROR', 'verdicts': [], 'problems': problems, 'output': ''}
        self.runs += 1
        d = os.path.join(self.run_dir, 'run%d' % self.runs)
        os.makedirs(d, exist_ok=True)
        path = os.path.join(d, 'scenario.yaml')
        with open(path, 'w') as f:
            f.write(text)
        env = dict(os.environ)
        env.pop('ROS_MASTER_URI', None)          # the run makes its own master
        env.pop('RAY_ADDRESS', None)
        proc = await asyncio.create_subprocess_exec(
            sys.executable, RUN_SCENARIO, path, cwd=d, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
        out, _ = await proc.communicate()
        text = out.decode('utf-8', 'replace')
        return dict(parse_run(text, proc.returncode), output=text[-4000:])


def parse_run(text, code):
    """run_scenario's output and exit code -> {'status', 'verdicts': [{status, name, line}]}."""
    verdicts = []
    for ln in text.splitlines():
        m = VERDICT.match(ln.strip())
        if m and m.group(2) not in ('scenario',):
            verdicts.append({'status': m.group(1), 'name': m.group(2), 'line': ln.strip()})
    return {'status': STATUS.get(code, 'ERROR'), 'verdicts': verdicts}


def _compose(pq, pose):
    from sim_world.transforms import Pose
    p = Pose(pq[:3], pq[3:]) * Pose(pose['position'], pose['orientation'])
    return {'position': [float(v) for v in p.p], 'orientation': [float(v) for v in p.q]}


# -- the aiohttp application ------------------------------------------------------------------
def make_app(studio):
    # bodies and messages up to 4x the protocol's limit are read and answered with the
    # protocol's error; larger ones are cut off by aiohttp (413, a closed WebSocket)
    app = web.Application(client_max_size=4 * protocol.MAX_BYTES,
                          middlewares=[_token_middleware(studio)])
    app['studio'] = studio

    page = index_html()

    async def index(_request):
        return web.Response(text=page, content_type='text/html')

    async def scene(_request):
        return web.json_response(studio.scene())

    async def cmd(request):
        body = await request.read()
        local = request.remote in ('127.0.0.1', '::1')
        rep = await studio.handle_text(body, None, local=local)
        return web.json_response(rep, status=200 if rep['ok'] else 400)

    async def ws_handler(request):
        ws = web.WebSocketResponse(max_msg_size=4 * protocol.MAX_BYTES, heartbeat=None)
        await ws.prepare(request)
        c = Client(ws, request.remote)
        studio.clients.append(c)
        c.put('hello', json.dumps({'v': protocol.VERSION, 'type': 'hello', 'name': c.name,
                                   'ops': sorted(protocol.OPS),
                                   'holder': studio.holder.name if studio.holder else None,
                                   'recording': studio.recorder.on,
                                   'yaml': studio.recorder.yaml(),
                                   'camera_topic': getattr(studio.world, 'camera_topic',
                                                           None)}))
        studio.want_camera = True
        studio.want_display = True
        pump = asyncio.ensure_future(c.pump())
        try:
            async for msg in ws:
                if msg.type == WSMsgType.TEXT and msg.data == 'ack':
                    c.ack()
                elif msg.type in (WSMsgType.TEXT, WSMsgType.BINARY):
                    # one command at a time per client, but the pump keeps streaming
                    rep = await studio.handle_text(msg.data, c)
                    c.answer(rep)
                elif msg.type == WSMsgType.ERROR:
                    c.answer(protocol.error('message refused: %s' % ws.exception()))
                    break
        finally:
            pump.cancel()
            studio.clients.remove(c)
            if studio.holder is c:         # it let go by leaving (mid-drag: the world has
                studio.holder = None       # the last pose it was sent, nothing half-done)
                studio._tell_control()
        return ws

    async def start_stream(app):
        studio.loop = asyncio.get_event_loop()
        studio.lock = asyncio.Lock()
        app['stream'] = asyncio.ensure_future(studio.stream())

    async def stop_stream(app):
        app['stream'].cancel()
        for c in list(studio.clients):
            await c.ws.close()

    async def favicon(_request):
        return web.Response(status=204)

    def asset(kind):
        cache = {}

        async def get(request):
            n = request.match_info['n']
            if studio.assets is None or not n.isdigit():
                raise web.HTTPNotFound()
            if n not in cache:
                fn = studio.assets.shape_bytes if kind == 'shape' else studio.assets.texture_png
                try:
                    cache[n] = await asyncio.get_event_loop().run_in_executor(None, fn, n)
                except IndexError:
                    raise web.HTTPNotFound()
                except Exception as e:  # noqa: BLE001 - a file gone or broken since
                    studio.log('studio: %s %s: %s' % (kind, n, e))
                    raise web.HTTPNotFound(text=str(e))
            return web.Response(body=cache[n], content_type='application/octet-stream'
                                if kind == 'shape' else 'image/png')
        return get

    app.router.add_get('/', index)
    app.router.add_get('/favicon.ico', favicon)
    app.router.add_get('/ws', ws_handler)
    app.router.add_post('/api/cmd', cmd)
    app.router.add_get('/api/scene', scene)
    app.router.add_get('/shape/{n}', asset('shape'))
    app.router.add_get('/texture/{n}', asset('texture'))
    app.router.add_static('/static/', STATIC)
    if os.path.isdir(THREE):
        app.router.add_static('/three/', THREE)
    for mod in studio.extensions:
        if hasattr(mod, 'routes'):
            mod.routes(app, studio)
        if hasattr(mod, 'attach'):
            mod.attach(studio)
    app.on_startup.append(start_stream)
    app.on_shutdown.append(stop_stream)
    return app


def index_html():
    """index.html with the extensions' scripts and style sheets (static/ext/*.js, *.css,
    sorted by name) in place of its ``<!-- extensions -->`` line."""
    with open(os.path.join(STATIC, 'index.html')) as f:
        text = f.read()
    ext = os.path.join(STATIC, 'ext')
    names = sorted(os.listdir(ext)) if os.path.isdir(ext) else []
    tags = ['<link rel="stylesheet" href="/static/ext/%s">' % n for n in names
            if n.endswith('.css')]
    tags += ['<script src="/static/ext/%s"></script>' % n for n in names if n.endswith('.js')]
    return text.replace('<!-- extensions -->', '\n'.join(tags))


def _token_middleware(studio):
    @web.middleware
    async def check_token(request, handler):
        if studio.token is not None:
            given = request.query.get('token') or request.headers.get('X-Studio-Token') or \
                request.cookies.get('studio_token')
            if not given or not secrets.compare_digest(given, studio.token):
                return web.json_response(protocol.error(
                    'this studio needs its token (printed at its start): ?token=... or the '
                    'X-Studio-Token header'), status=403)
            resp = await handler(request)
            if request.query.get('token') and not resp.prepared:
                resp.set_cookie('studio_token', studio.token, httponly=True, samesite='Strict')
            return resp
        return await handler(request)
    return check_token
