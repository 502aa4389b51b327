"""Time travel (issue 47, parts 5 and 6): open a run_scenario recording (MCAP or rosbag) and
scrub through it; compare two runs; run the open scenario (or its sweep) with its output
streamed to the page and its HTML report served to it.

A recording is read with testing_instance's own reader (``io.mcap_io.open_reader``: the
format told by the file's first bytes, damage as ``RecordingError``), once, into one sorted
list per topic. The page never gets it whole: it asks for the state at one sim time
(``tt_at``: the model poses of the last ``/gazebo/model_states`` at or before it, the URL of
each image topic's frame shown then) and for one plotted field over a window
(``tt_series``: at most ``points`` points, thinned per time bucket with the report's own
``decimate``, spikes kept). Images are JPEG-encoded only when the page asks for one.

Verdicts and expectation windows come from the run's ``report.json`` (``run_scenario
--report``) found beside the recording (its folder, ``report/`` in it, or ``<stem>_report``).
The expectations' topic and field are read from the report's ``expected`` text.

Runs: ``tt_run`` starts ``run_scenario FILE --record run.mcap --report report --live`` (or
``--sweep --jobs N --out ... [--cluster ADDRESS]``) in a folder of the studio's run dir and
answers at once; its output lines, the verdicts parsed from them and, at its end, its status,
report URL and recording path are the ``tt_run`` stream (latest wins: each message holds all
there is so far). The run's copy of the scenario records ``/gazebo/model_states`` too, so its
recording has the poses the 3D view scrubs through."""
import asyncio
import bisect
import json
import os
import re
import signal
import subprocess
import sys
import threading

__all__ = ['OPS', 'handle', 'routes', 'attach', 'Recording', 'find_report', 'run_command',
           'scenario_copy', 'expectation_field', 'Run']

POSES_TOPIC = '/gazebo/model_states'
IMAGE_TYPES = ('sensor_msgs/Image', 'sensor_msgs/CompressedImage')
SLOTS = 2                       # 0: the run opened, 1: the run compared with it
MAX_POINTS = 2000               # of one tt_series reply
MAX_LINES = 400                 # of a run's output kept in its stream message
AT_T = re.compile(r'at t=(-?[\d.]+) s$')
PREFIX = re.compile(r'^\[[^\]]*\] ')


def _slot_check(f):
    from .protocol import ProtocolError
    if f.get('slot', 0) >= SLOTS:
        raise ProtocolError('slot: expected 0 (the run opened) or 1 (the run compared), got %d'
                            % f['slot'])
    if f.get('start') is not None and f.get('end') is not None and not f['start'] < f['end']:
        raise ProtocolError('tt_series: the window needs start < end, got [%g, %g]'
                            % (f['start'], f['end']))


def _run_check(f):
    from .protocol import ProtocolError
    if f['yaml'] is None and f['file'] is None:
        raise ProtocolError('tt_run: needs the scenario: yaml (its text) or file (its path)')
    if f['cluster'] is not None and not f['sweep']:
        raise ProtocolError('tt_run: cluster runs a sweep: give sweep: true with it')


OPS = {
    'tt_open': dict(required={'path': 'str'}, optional={'slot': 0},
                    kinds={'slot': 'int>=0'}, field_check=_slot_check,
                    doc='open a recording (MCAP or rosbag, or a folder holding one) in slot 0 '
                        '(the run) or 1 (the run compared); replies with its summary'),
    'tt_close': dict(required={}, optional={'slot': 0}, kinds={'slot': 'int>=0'},
                     field_check=_slot_check,
                     doc='close the recording of a slot'),
    'tt_at': dict(required={'t': 'num'}, optional={'slot': 0}, kinds={'slot': 'int>=0'},
                  field_check=_slot_check,
                  doc='the recording at sim time t: model poses and image frames (URLs)'),
    'tt_series': dict(required={'topic': 'str', 'field': 'str'},
                      optional={'slot': 0, 'start': None, 'end': None, 'points': 800},
                      kinds={'slot': 'int>=0', 'points': 'int>=0'},
                      field_check=_slot_check,
                      doc='a numeric field of a recorded topic over [start, end] s (default '
                          'the whole recording), at most points points'),
    'tt_run': dict(required={}, optional={'yaml': None, 'file': None, 'sweep': False,
                                          'jobs': 2, 'cluster': None, 'cpus_per_run': 1.0},
                   kinds={'yaml': 'str', 'file': 'str', 'sweep': 'bool', 'jobs': 'int>=0',
                          'cluster': 'str', 'cpus_per_run': 'num>0'},
                   needs_control=True, field_check=_run_check,
                   doc='run a scenario (yaml: its text, file: its path, or both) with run_scenario '
                       '--report --record, or its sweep (sweep: true, on jobs local workers '
                       'or the Ray cluster at cluster); answers at once, the output is the '
                       'tt_run stream'),
}


# -- reading a recording ------------------------------------------------------------------
class Recording(object):
    """A recording read whole with testing_instance's reader: per topic its (t, msg) in
    time order, its meta, events, and the verdicts of a report.json beside it."""

    def __init__(self, path):
        from testing_instance.io.mcap_io import RecordingError, open_reader
        from testing_instance.run.recording import EVENTS_TOPIC, META_TOPIC
        path = self.path = _recording_path(path)
        reader = open_reader(path)
        self.topics, self.types = {}, {}
        self.warning = None
        try:
            try:
                for topic, msg, t in reader.read_messages():
                    self.topics.setdefault(topic, []).append((t.to_sec(), msg))
                    self.types.setdefault(topic, getattr(msg, '_type', type(msg).__name__))
            except RecordingError as e:
                self.warning = '%s; read up to the damage' % e
        finally:
            reader.close()
        self.warning = self.warning or reader.damage
        if not self.topics:
            raise RecordingError('%s holds no messages' % path)
        for rows in self.topics.values():
            rows.sort(key=lambda r: r[0])
        self.times = {k: [r[0] for r in v] for k, v in self.topics.items()}
        self.meta, self.events = {}, []
        for _t, msg in self.topics.pop(META_TOPIC, [])[:1]:
            try:
                self.meta = json.loads(msg.data)
            except (AttributeError, TypeError, ValueError):
                self.meta = {}
        for t, msg in self.topics.pop(EVENTS_TOPIC, []):
            try:
                ev = json.loads(msg.data)
            except (AttributeError, TypeError, ValueError):
                continue
            if isinstance(ev, dict):
                self.events.append({'t': t, 'id': ev.get('id'), 'action': ev.get('action'),
                                    'text': ev.get('text')})
        for k in (META_TOPIC, EVENTS_TOPIC):
            self.times.pop(k, None)
            self.types.pop(k, None)
        if not self.topics:
            raise RecordingError('%s holds no recorded topics (only its meta)' % path)
        self.t0 = min(v[0] for v in self.times.values())
        self.t1 = max(v[-1] for v in self.times.values())
        if isinstance(self.meta.get('duration'), (int, float)):
            self.t1 = max(self.t1, float(self.meta.get('t0') or 0.0) + self.meta['duration'])
        self.report_dir, self.report = find_report(path)
        self._jpeg = {}
        self._lock = threading.Lock()

    # the state at one time
    def check_t(self, t):
        if not self.t0 - 1e-9 <= t <= self.t1 + 1e-9:
            raise ValueError('t: %g s is outside the recording %s (%.3f .. %.3f s)'
                             % (t, os.path.basename(self.path), self.t0, self.t1))

    def index_at(self, topic, t):
        """Index of the last message of topic at or before t (-1: none yet)."""
        return bisect.bisect_right(self.times[topic], t + 1e-9) - 1

    def poses_at(self, t):
        """{model: [x, y, z, qx, qy, qz, qw]} of the last /gazebo/model_states at or before
        t (the first one before it), and its time; ({}, None) without that topic."""
        rows = self.topics.get(POSES_TOPIC)
        if not rows:
            return {}, None
        i = max(0, self.index_at(POSES_TOPIC, t))
        ts, msg = rows[i]
        return {n: [p.position.x, p.position.y, p.position.z, p.orientation.x,
                    p.orientation.y, p.orientation.z, p.orientation.w]
                for n, p in zip(msg.name, msg.pose)}, ts

    def image_topics(self):
        return sorted(k for k, ty in self.types.items() if ty in IMAGE_TYPES)

    def frame_at(self, topic, t):
        """(index, time) of the frame of an image topic shown at t (the first before it)."""
        i = max(0, self.index_at(topic, t))
        return i, self.topics[topic][i][0]

    def jpeg(self, topic, i):
        """JPEG bytes of frame i of an image topic (encoded once, then kept)."""
        with self._lock:
            if (topic, i) in self._jpeg:
                return self._jpeg[(topic, i)]
        rows = self.topics.get(topic)
        if not rows or self.types.get(topic) not in IMAGE_TYPES:
            raise KeyError('no image topic %s in the recording' % topic)
        if not 0 <= i < len(rows):
            raise KeyError('%s has frames 0..%d, not %d' % (topic, len(rows) - 1, i))
        msg = rows[i][1]
        if self.types[topic] == 'sensor_msgs/CompressedImage':
            data = bytes(msg.data)
        else:
            import io
            from PIL import Image
            from simvid.imageconv import image_to_rgb
            buf = io.BytesIO()
            Image.fromarray(image_to_rgb(msg)).save(buf, 'JPEG', quality=80)
            data = buf.getvalue()
        with self._lock:
            if len(self._jpeg) > 256:
                self._jpeg.clear()
            self._jpeg[(topic, i)] = data
        return data

    def series(self, topic, field, start=None, end=None, points=800):
        """[(label, [[t, v]...])] of a numeric field (vectors: one per component) over
        [start, end], thinned to about ``points`` points per line."""
        from testing_instance.report import decimate, numeric_value
        from testing_instance.scenario.expect import FieldError, get_field
        if topic not in self.topics:
            raise ValueError('tt_series: no topic %s in the recording (topics: %s)'
                             % (topic, ', '.join(sorted(self.topics))))
        rows = self.topics[topic]
        times = self.times[topic]
        lo = 0 if start is None else bisect.bisect_left(times, start - 1e-9)
        hi = len(rows) if end is None else bisect.bisect_right(times, end + 1e-9)
        lines = {}
        for t, msg in rows[lo:hi]:
            try:
                v = numeric_value(get_field(msg, field))
            except FieldError as e:
                raise ValueError('tt_series: %s.%s: %s' % (topic, field, e))
            if v is None:
                raise ValueError('tt_series: %s.%s is not numeric (%s)' % (
                    topic, field, type(get_field(msg, field)).__name__))
            if isinstance(v, list):
                for k, x in enumerate(v):
                    lines.setdefault('%s[%d]' % (field, k), []).append((t, x))
            else:
                lines.setdefault(field, []).append((t, v))
        n = max(8, min(points or 800, MAX_POINTS))
        return [[label, [[round(t, 6), x] for t, x in decimate(pts, n)]]
                for label, pts in sorted(lines.items())]

    def fields(self, topic, limit=24):
        """The numeric fields of a topic's first message (device.flatten's paths)."""
        from .device import flatten
        rows = self.topics.get(topic)
        if not rows or self.types.get(topic) in IMAGE_TYPES:
            return []
        _stamp, fl = flatten(rows[0][1], limit)
        return [p for p, v in fl if isinstance(v, float)]

    def summary(self):
        return {'path': self.path, 'name': os.path.basename(self.path), 't0': self.t0,
                't1': self.t1, 'meta': {k: v for k, v in self.meta.items()
                                        if k not in ('inputs', 'types')},
                'topics': {k: {'type': self.types[k], 'n': len(v),
                               'fields': self.fields(k)}
                           for k, v in sorted(self.topics.items())},
                'images': self.image_topics(), 'poses': POSES_TOPIC in self.topics,
                'events': self.events, 'verdicts': self.verdicts(),
                'status': (self.report or {}).get('status'),
                'warning': self.warning}

    def verdicts(self):
        """The report's verdicts: name, status, t, expected, actual, window, topic, field."""
        out = []
        rep = self.report or {}
        plots = rep.get('plots') or {}
        for v in rep.get('verdicts') or []:
            if not isinstance(v, dict) or 'name' not in v:
                continue
            topic, field = expectation_field(v.get('expected') or '')
            p = plots.get(v['name']) or {}
            out.append({'name': v['name'], 'status': v.get('status'), 't': v.get('t'),
                        'expected': v.get('expected'), 'actual': v.get('actual'),
                        'window': p.get('window'), 'band': p.get('band'),
                        'topic': topic, 'field': field})
        return out


def expectation_field(expected):
    """(topic, field) named in a verdict's ``expected`` text ('always /a/b.c.d == 1 in ...'),
    (None, None) when it names none."""
    m = re.search(r'(/[A-Za-z0-9_/]+)(?:\.([A-Za-z0-9_.\[\]]+))?', expected)
    if not m:
        return None, None
    return m.group(1), m.group(2)


def _recording_path(path):
    """The recording a path names: the file, or the first .mcap (else .bag) in a folder."""
    from testing_instance.io.mcap_io import RecordingError
    path = os.path.abspath(os.path.expanduser(path))
    if os.path.isdir(path):
        names = sorted(os.listdir(path))
        for ext in ('.mcap', '.bag'):
            hit = [n for n in names if n.endswith(ext)]
            if hit:
                return os.path.join(path, hit[0])
        raise RecordingError('%s is a folder without a recording (.mcap or .bag)' % path)
    if not os.path.exists(path):
        raise RecordingError('no such recording: %s' % path)
    return path


def find_report(path):
    """(folder, decoded report.json) of the run a recording belongs to, or (None, None)."""
    d = os.path.dirname(path)
    stem = os.path.splitext(os.path.basename(path))[0]
    for cand in (d, os.path.join(d, 'report'), os.path.join(d, stem + '_report'),
                 os.path.join(d, stem)):
        f = os.path.join(cand, 'report.json')
        if os.path.isfile(f):
            try:
                with open(f) as fh:
                    rep = json.load(fh)
            except (OSError, ValueError):
                continue
            if isinstance(rep, dict):
                return cand, rep
    return None, None


# -- running a scenario ---------------------------------------------------------------------
def scenario_copy(text, path, run_dir):
    """Write the run's copy of a scenario into run_dir (with the files beside ``path``
    linked there, so its apps and models are found) recording /gazebo/model_states too;
    returns the copy's path."""
    import yaml
    name = os.path.basename(path) if path else 'scenario.yaml'
    if text is None:
        with open(path) as f:
            text = f.read()
    if path:
        src = os.path.dirname(os.path.abspath(path))
        for n in os.listdir(src):
            if n != name and not os.path.exists(os.path.join(run_dir, n)):
                os.symlink(os.path.join(src, n), os.path.join(run_dir, n))
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError:
        data = None                      # run_scenario names the problem
    if isinstance(data, dict):
        rec = data.get('record')
        if rec is None and not re.search(r'^record\s*:', text, re.M):
            text = text.rstrip('\n') + '\nrecord: [%s]\n' % POSES_TOPIC
        elif isinstance(rec, list) and POSES_TOPIC not in rec:
            data['record'] = rec + [POSES_TOPIC]
            text = yaml.safe_dump(data, sort_keys=False)
    out = os.path.join(run_dir, name)
    with open(out, 'w') as f:
        f.write(text)
    return out


def run_command(scenario, run_dir, sweep=False, jobs=2, cluster=None, cpus_per_run=1.0,
                runner=None):
    """run_scenario's command line for one run (recorded, reported) or a sweep (on ``jobs``
    local workers, or on the Ray cluster at ``cluster``)."""
    from .server import RUN_SCENARIO
    cmd = [sys.executable, runner or RUN_SCENARIO, scenario]
    if not sweep:
        return cmd + ['--record', os.path.join(run_dir, 'run.mcap'),
                      '--report', os.path.join(run_dir, 'report'), '--live']
    cmd += ['--sweep', '--out', os.path.join(run_dir, 'sweep'),
            '--json', os.path.join(run_dir, 'sweep.json'),
            '--report', os.path.join(run_dir, 'report')]
    if cluster:
        return cmd + ['--cluster', cluster, '--cpus-per-run', '%g' % cpus_per_run]
    return cmd + ['--jobs', str(max(1, jobs))]


class Run(object):
    """One run of the studio's: its output so far, verdicts, and at its end its status."""

    def __init__(self, n, d, sweep, base):
        self.n, self.dir, self.sweep, self.base = n, d, sweep, base
        self.lines, self.verdicts = [], []
        self.state, self.status, self.code = 'running', None, None
        self.proc = None

    def feed(self, line):
        from .server import VERDICT
        line = line.rstrip('\n')
        self.lines.append(line)
        del self.lines[:-MAX_LINES]
        text = PREFIX.sub('', line.strip())
        # run_scenario --live says each verdict when it is decided ('decided PASS x: ...'),
        # and all of them again at the end: one entry per expectation, the latest line
        live = text.startswith('decided ')
        m = VERDICT.match(text[len('decided '):] if live else text)
        if m and m.group(2) != 'scenario':
            t = AT_T.search(text)
            v = {'status': m.group(1), 'name': m.group(2), 'line': m.group(0),
                 't': float(t.group(1)) if t else None, 'live': live}
            old = [i for i, x in enumerate(self.verdicts) if x['name'] == v['name']]
            if old:
                self.verdicts[old[0]] = v
            else:
                self.verdicts.append(v)

    def message(self, url):
        out = {'run': self.n, 'state': self.state, 'sweep': self.sweep, 'lines': self.lines,
               'verdicts': self.verdicts, 'status': self.status, 'code': self.code}
        if self.state == 'done':
            rep = os.path.join(self.dir, 'report', 'index.html')
            out['report'] = url + os.path.relpath(rep, self.base) \
                if os.path.isfile(rep) else None
            rec = os.path.join(self.dir, 'run.mcap')
            out['recording'] = rec if os.path.isfile(rec) else None
            summ = os.path.join(self.dir, 'sweep.json')
            if os.path.isfile(summ):
                try:
                    with open(summ) as f:
                        s = json.load(f)
                    out['summary'] = {k: s.get(k) for k in ('total', 'passed', 'failed',
                                                            'errors', 'pass_rate')}
                    out['runs'] = [{k: r.get(k) for k in ('name', 'status', 'values',
                                                          'reproduce')}
                                   for r in s.get('runs') or []][:200]
                except (OSError, ValueError):
                    pass
        return out


RUNS_URL = '/api/timetravel/runs/'


async def _run(studio, run, cmd):
    env = dict(os.environ)
    env.pop('ROS_MASTER_URI', None)          # the run makes its own master
    if not run.sweep or '--cluster' not in cmd:
        env.pop('RAY_ADDRESS', None)
    tell = lambda: studio.broadcast('tt_run', run.message(RUNS_URL))  # noqa: E731
    try:
        run.proc = await asyncio.create_subprocess_exec(
            *cmd, cwd=run.dir, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            start_new_session=True)
        tell()
        while True:
            raw = await run.proc.stdout.readline()
            if not raw:
                break
            run.feed(raw.decode('utf-8', 'replace'))
            tell()
        run.code = await run.proc.wait()
    except Exception as e:  # noqa: BLE001 - the run could not start
        run.feed('ERROR the run could not start: %s' % e)
        run.code = 2
    from .server import STATUS
    run.status = STATUS.get(run.code, 'ERROR')
    run.state = 'done'
    studio.log('studio: run %d ended: %s' % (run.n, run.status))
    tell()


# -- the extension's ops and routes -----------------------------------------------------------
def attach(studio):
    if not hasattr(studio, 'timetravel'):
        studio.timetravel = {'slots': [None] * SLOTS, 'runs': {}, 'n': 0, 'tasks': set()}


def _state(studio):
    if not hasattr(studio, 'timetravel'):
        attach(studio)
    return studio.timetravel


def _rec(studio, slot):
    r = _state(studio)['slots'][slot]
    if r is None:
        raise ValueError('no recording open in slot %d (open one with tt_open)' % slot)
    return r


async def handle(studio, cmd, client):
    f = cmd.fields
    st = _state(studio)
    loop = asyncio.get_event_loop()
    if cmd.op == 'tt_open':
        from testing_instance.io.mcap_io import RecordingError
        try:
            rec = await loop.run_in_executor(None, Recording, f['path'])
        except RecordingError as e:
            raise ValueError('tt_open: %s' % e)
        st['slots'][f['slot']] = rec
        summary = rec.summary()
        summary['report'] = '/api/timetravel/report/%d/index.html' % f['slot'] \
            if rec.report_dir and os.path.isfile(os.path.join(rec.report_dir, 'index.html')) \
            else None
        return {'slot': f['slot'], 'recording': summary}
    if cmd.op == 'tt_close':
        st['slots'][f['slot']] = None
        return {'slot': f['slot']}
    if cmd.op == 'tt_at':
        rec = _rec(studio, f['slot'])
        rec.check_t(f['t'])
        poses, pt = rec.poses_at(f['t'])
        frames = {}
        for topic in rec.image_topics():
            i, ft = rec.frame_at(topic, f['t'])
            frames[topic] = {'t': ft, 'url': '/api/timetravel/frame/%d/%d%s' % (
                f['slot'], i, topic)}
        return {'slot': f['slot'], 't': f['t'], 'poses': poses, 'poses_t': pt,
                'frames': frames}
    if cmd.op == 'tt_series':
        rec = _rec(studio, f['slot'])
        for k in ('start', 'end'):
            if f[k] is not None:
                rec.check_t(f[k])
        series = await loop.run_in_executor(None, rec.series, f['topic'], f['field'],
                                            f['start'], f['end'], f['points'])
        return {'slot': f['slot'], 'topic': f['topic'], 'field': f['field'], 'series': series}
    if cmd.op == 'tt_run':
        return _start_run(studio, st, f)
    raise ValueError('timetravel: no op %s' % cmd.op)


def _start_run(studio, st, f):
    import yaml
    if f['file'] is not None and not os.path.isfile(f['file']):
        raise ValueError('tt_run: no scenario file %s' % f['file'])
    text = f['yaml']
    if f['sweep']:
        try:
            if text is None:
                with open(f['file']) as fh:
                    text = fh.read()
            data = yaml.safe_load(text)
        except (yaml.YAMLError, OSError) as e:
            raise ValueError('tt_run: the scenario does not read: %s' % str(e).splitlines()[0])
        if not isinstance(data, dict) or not data.get('sweep'):
            raise ValueError('tt_run: this scenario has no sweep: block (see testing_instance'
                             "'s README, Parameters and sweeps); run it without sweep")
    if any(r.state == 'running' for r in st['runs'].values()):
        raise ValueError('tt_run: a run is going on; wait for its end')
    st['n'] += 1
    base = os.path.join(studio.run_dir, 'timetravel')
    d = os.path.join(base, 'run%d' % st['n'])
    os.makedirs(d, exist_ok=True)
    scenario = scenario_copy(text, f['file'], d)
    run = Run(st['n'], d, f['sweep'], base)
    st['runs'][run.n] = run
    cmd = run_command(scenario, d, f['sweep'], f['jobs'], f['cluster'], f['cpus_per_run'],
                      runner=st.get('runner'))
    run.command = cmd
    task = asyncio.ensure_future(_run(studio, run, cmd))
    st['tasks'].add(task)
    task.add_done_callback(st['tasks'].discard)
    return {'run': run.n, 'dir': d, 'command': cmd[1:]}


def stop_runs(studio):
    """Kill the runs still going (their process groups): the studio is stopping."""
    for run in _state(studio)['runs'].values():
        p = run.proc
        if p is not None and p.returncode is None:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass


def routes(app, studio):
    from aiohttp import web

    def inside(root, tail):
        root = os.path.realpath(root)
        p = os.path.realpath(os.path.join(root, tail))
        if p != root and not p.startswith(root + os.sep) or not os.path.isfile(p):
            raise web.HTTPNotFound()
        return p

    async def frame(request):
        slot, i = int(request.match_info['slot']), int(request.match_info['i'])
        topic = '/' + request.match_info['topic']
        st = _state(studio)
        rec = st['slots'][slot] if slot < SLOTS else None
        if rec is None:
            raise web.HTTPNotFound(text='no recording in slot %d' % slot)
        try:
            data = await asyncio.get_event_loop().run_in_executor(None, rec.jpeg, topic, i)
        except KeyError as e:
            raise web.HTTPNotFound(text=str(e))
        return web.Response(body=data, content_type='image/jpeg',
                            headers={'Cache-Control': 'max-age=3600'})

    async def runs(request):
        return web.FileResponse(inside(os.path.join(studio.run_dir, 'timetravel'),
                                       request.match_info['tail']))

    async def report(request):
        slot = int(request.match_info['slot'])
        rec = _state(studio)['slots'][slot] if slot < SLOTS else None
        if rec is None or not rec.report_dir:
            raise web.HTTPNotFound()
        return web.FileResponse(inside(rec.report_dir, request.match_info['tail']))

    async def shutdown(_app):
        stop_runs(studio)

    app.router.add_get(r'/api/timetravel/frame/{slot:\d+}/{i:\d+}/{topic:.+}', frame)
    app.router.add_get('/api/timetravel/runs/{tail:.+}', runs)
    app.router.add_get(r'/api/timetravel/report/{slot:\d+}/{tail:.+}', report)
    app.on_shutdown.append(shutdown)
