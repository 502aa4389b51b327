"""Study mode (issue 47 part 8, the thesis's usability tests): a task list for a test
person, start / finish / give up per task, every command of the session logged with its sim
and wall time, per person and task the time on task, success, error and undo counts (CSV),
and the replay of a session's world commands.

The log hangs on the server's command path (``Studio.on_command``): while a session runs,
every command that reaches ``Studio.handle_text`` (the page's, another WebSocket client's,
``POST /api/cmd``), refused ones too, is one entry {i, wall, sim, op, fields, ok, error,
client, task}. While a task runs it counts for that task: an *action* (any op but the
study's own bookkeeping), an *error* (a command answered with an error) and an *undo*
(``study_undo`` or any op named ``undo`` / ``*_undo`` that succeeded).

``study_undo`` takes back the session's last world-changing command that has a clean
inverse (``UNDOABLE``), by sending that inverse through the studio's handler:

- ``set_pose``: the model back where it was before (its previous ``set_pose``, preset or
  walk in the session, else its pose when the session started);
- ``preset``, ``walk``: the model back to the pose the op found it at (the op's reply
  ``before``, asked of the world); a walk still under way is stopped first;
- ``set_environment``: each value set back to what it was before (the last value the
  studio set, else the world's own from ``/gazebo/environment`` received before the
  command); values never known are left;
- ``fault``: the sensor's previous fault (the last the studio set on it, else none);
- ``radio``, ``charger``: the previous switch state (the last the studio set, else the
  phone's start state: radios on, charger unplugged).

``touch``, ``press_button``, ``reset`` and the time controls have no inverse: undo passes
over them to the last command that has one. A replay re-sends the session's successful world commands (ops that change the
world, but not play, pause and step: sim time is the replay's axis) through the studio's
one handler (``Studio.handle``, so they are checked and recorded like any command, and not
logged again) either at their sim times relative to the first one (``timed``: it waits for
the world's clock, so the world must be playing) or one per ``study_next`` (``step``)."""
import asyncio
import csv
import io
import json
import time

from . import protocol

__all__ = ['OPS', 'handle', 'routes', 'attach', 'Study', 'parse_tasks', 'BOOKKEEPING']

#: the study's own ops: not the tested person's actions
BOOKKEEPING = ('study_tasks', 'study_start', 'study_task', 'study_end', 'study_state',
               'study_replay', 'study_next')
#: world ops a replay does not re-send (the world's time controls)
NOT_REPLAYED = ('play', 'pause', 'step')
RESULTS = ('success', 'gave_up', 'unfinished')
#: world ops study_undo can take back
UNDOABLE = ('set_pose', 'preset', 'walk', 'set_environment', 'fault', 'radio', 'charger')
#: the phone's switches when nothing set them (radios on, charger unplugged)
RADIO_START, CHARGER_START = True, False
CSV_COLUMNS = ('person', 'session', 'task', 'task_name', 'result', 'success',
               'time_on_task_s', 'sim_time_on_task_s', 'actions', 'errors', 'undos',
               'started_wall', 'started_sim')

OPS = {
    'study_tasks': dict(
        optional={'tasks_text': None, 'tasks_file': None},
        kinds={'tasks_text': 'str', 'tasks_file': 'str'},
        doc='set the task list from YAML or JSON text (a list of names or of {name, text}, '
            'or {tasks: [...]}; else one task a line) or from a file on the studio\'s disk'),
    'study_start': dict(
        required={'person': 'str'},
        doc='start a session for a test person (its log starts; a running session ends)'),
    'study_task': dict(
        required={'action': ('start', 'finish', 'give_up')},
        optional={'task': None}, kinds={'task': 'int>=0'},
        doc='start task N (default: the next one not done), or finish (success) / give up '
            'the running one'),
    'study_end': dict(doc='end the session (a running task is unfinished)'),
    'study_undo': dict(
        changes_world=True,
        doc="undo the session's last world change that has an inverse (set_pose, preset, "
            "walk, set_environment, fault, radio, charger): the state before it back"),
    'study_state': dict(doc='the task list, the running session and every session\'s '
                            'summary'),
    'study_replay': dict(
        required={'session': 'int>=0', 'mode': ('timed', 'step', 'stop')},
        changes_world=True,
        doc="replay a session's world commands: timed (at their relative sim times, the "
            'world playing), step (one per study_next) or stop'),
    'study_next': dict(changes_world=True,
                       doc='send the next command of a step-by-step replay'),
}


def parse_tasks(text):
    """[{name, text}] from YAML/JSON text: a list of names or of {name, text}, or {tasks:
    [...]}; other text: one task a non-empty line. ValueError says what is wrong."""
    import yaml
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError:
        data = None
    if isinstance(data, dict) and 'tasks' in data:
        data = data['tasks']
    if not isinstance(data, list):
        data = [ln.strip() for ln in text.splitlines() if ln.strip()]
    out = []
    for i, t in enumerate(data):
        if isinstance(t, dict) and t.get('name') is not None:
            out.append({'name': str(t['name']), 'text': str(t.get('text', t['name']))})
        elif isinstance(t, (str, int, float)) and not isinstance(t, bool) and str(t).strip():
            out.append({'name': str(t).strip(), 'text': str(t).strip()})
        else:
            raise ValueError('study_tasks: task %d: expected a name or {name, text}, got %s'
                             % (i + 1, json.dumps(t, default=str)[:80]))
    if not out:
        raise ValueError('study_tasks: no tasks in the text')
    return out


def _quat_rpy(q):
    from sim_world.transforms import rpy_from_quat
    return [float(v) for v in rpy_from_quat(q)]


def _rpy_quat(rpy):
    from sim_world.transforms import quat_from_rpy
    return [float(v) for v in quat_from_rpy(*rpy)]


class Session(object):
    def __init__(self, n, person, tasks, sim, wall, poses):
        self.n = n
        self.person = person
        self.tasks = [dict(t, result=None, start_sim=None, start_wall=None, end_sim=None,
                           end_wall=None, actions=0, errors=0, undos=0) for t in tasks]
        self.start_sim, self.start_wall = sim, wall
        self.end_wall = None
        self.log = []
        self.current = None          # index of the running task
        self.last = {m: (list(p[:3]), list(p[3:])) for m, p in (poses or {}).items()}
        # [{op, commands: [(op, fields)] (the inverse), stop_walk: model or None}]
        self.undo = []

    def summary(self):
        return {'session': self.n, 'person': self.person, 'running': self.end_wall is None,
                'current': self.current, 'commands': len(self.log),
                'tasks': [{k: t[k] for k in ('name', 'text', 'result', 'actions', 'errors',
                                                'undos')} for t in self.tasks]}

    def rows(self):
        for i, t in enumerate(self.tasks):
            done = t['end_wall'] is not None
            yield {'person': self.person, 'session': self.n, 'task': i + 1,
                   'task_name': t['name'],
                   'result': t['result'] or ('unfinished' if t['start_wall'] is not None
                                             else 'not started'),
                   'success': '' if t['start_wall'] is None else
                   (1 if t['result'] == 'success' else 0),
                   'time_on_task_s': '%.3f' % (t['end_wall'] - t['start_wall']) if done
                   else '',
                   'sim_time_on_task_s': '%.3f' % (t['end_sim'] - t['start_sim']) if done
                   else '',
                   'actions': t['actions'], 'errors': t['errors'], 'undos': t['undos'],
                   'started_wall': time.strftime('%Y-%m-%dT%H:%M:%S', time.gmtime(
                       t['start_wall'])) + 'Z' if t['start_wall'] is not None else '',
                   'started_sim': '%.3f' % t['start_sim'] if t['start_sim'] is not None
                   else ''}


class Study(object):
    """The study's state on one studio (``studio.study``)."""

    def __init__(self, studio):
        self.studio = studio
        self.tasks = []
        self.sessions = []
        self.session = None          # the running Session
        self.replay = None           # {'session', 'mode', 'i', 'task', 'entries'}
        self._ended = None           # the session study_end just ended (its last entry)
        # what the studio last set (any session or none): the inverses' previous states
        self.known_env = {}          # name -> value
        self.known_fault = {}        # (model, sensor) -> (fault, value)
        self.known_radio = {}        # (model, radio) -> enabled
        self.known_charger = {}      # model -> plugged
        self.env_seen = []           # [(wall, {name: value})] of /gazebo/environment
        self.env_sub = None

    def watch_environment(self, rospy):
        """Keep the world's environment values (``/gazebo/environment``, latched): the
        values a set_environment's undo goes back to when the studio set none before."""
        from mobile_device_sim.msg import Environment
        self.env_sub = rospy.Subscriber('/gazebo/environment', Environment, self.on_environment,
                                        queue_size=5)

    def on_environment(self, msg, wall=None):
        values = {v.name: float(v.value) for v in msg.values}
        self.env_seen = (self.env_seen + [(time.time() if wall is None else wall, values)])[-20:]

    def _env_before(self, name, wall):
        if name in self.known_env:
            return self.known_env[name]
        seen = [v for w, v in self.env_seen if w < wall]
        return seen[-1].get(name) if seen else None

    def _track(self, op, f, rep, s=None):
        """Keep the state a carried-out command left (``s``: the session's poses too)."""
        if op == 'set_environment':
            self.known_env.update(f['values'])
        elif op == 'fault':
            self.known_fault[(f['model'], f['sensor'])] = (f['fault'], f['value'])
        elif op == 'radio':
            self.known_radio[(f['model'], f['radio'])] = f['enabled']
        elif op == 'charger':
            self.known_charger[f['model']] = f['plugged']
        if s is None:
            return
        if op == 'set_pose':
            s.last[f['model']] = (list(f['position']), _rpy_quat(f['rpy']))
        elif op == 'preset':
            s.last[f['model']] = (list(rep['position']), _rpy_quat(rep['rpy']))
        elif op == 'walk':
            end = rep.get('end_pose')
            s.last[f['model']] = (list(end['position']), _rpy_quat(end['rpy'])) if end \
                else None

    def _inverse(self, op, f, rep, s, wall):
        """The undo entry of a carried-out command (None: it has no clean inverse)."""
        cmds, stop = [], None
        if op in ('set_pose', 'preset', 'walk'):
            m = f['model']
            if op == 'set_pose':
                before = s.last.get(m)
                before = before and {'position': before[0], 'rpy': _quat_rpy(before[1])}
            else:
                before = rep.get('before')
            if not before:
                return None
            cmds.append(('set_pose', {'model': m, 'position': list(before['position']),
                                      'rpy': list(before['rpy'])}))
            stop = m if op == 'walk' else None
        elif op == 'set_environment':
            # daylight follows time_of_day (the last of the two set wins): an hour's undo
            # puts back the daylight before it too, after the hour
            names = sorted(k for k in f['values'] if k != 'daylight')
            if 'daylight' in f['values'] or 'time_of_day' in f['values']:
                names.append('daylight')
            old = {k: self._env_before(k, wall) for k in names}
            old = {k: v for k, v in old.items() if v is not None}
            if not old:
                return None
            cmds.append(('set_environment', {'values': old}))
        elif op == 'fault':
            fault, value = self.known_fault.get((f['model'], f['sensor']), ('none', 0.0))
            cmds.append(('fault', {'model': f['model'], 'sensor': f['sensor'], 'fault': fault,
                                   'value': value}))
        elif op == 'radio':
            cmds.append(('radio', {'model': f['model'], 'radio': f['radio'], 'enabled':
                                   self.known_radio.get((f['model'], f['radio']), RADIO_START)}))
        elif op == 'charger':
            cmds.append(('charger', {'model': f['model'], 'plugged':
                                     self.known_charger.get(f['model'], CHARGER_START)}))
        else:
            return None
        return {'op': op, 'commands': cmds, 'stop_walk': stop}

    # -- the action log (Studio.on_command) ------------------------------------------------
    def on_command(self, cmd, raw, rep, client, sim, wall):
        s = self.session or (self._ended if cmd is not None and cmd.op == 'study_end'
                             else None)
        self._ended = None
        if s is None:
            if cmd is not None and rep.get('ok'):
                self._track(cmd.op, cmd.fields, rep)
            return
        if cmd is not None:
            op, fields = cmd.op, dict(cmd.fields)
        else:
            op = raw.get('op') if isinstance(raw, dict) else None
            fields = {k: v for k, v in raw.items() if k not in ('v', 'op', 'id')} \
                if isinstance(raw, dict) else {}
        entry = {'i': len(s.log), 'wall': wall, 'sim': sim, 'op': op, 'fields': fields,
                 'ok': bool(rep.get('ok')), 'error': rep.get('error'),
                 'client': client.name if client is not None else 'POST /api/cmd',
                 'task': s.current}
        if op == 'study_undo' and rep.get('ok'):
            entry['applied'] = rep.get('applied')
            entry['stop_walk'] = rep.get('stop_walk')
        s.log.append(entry)
        if s.current is not None and op not in BOOKKEEPING:
            t = s.tasks[s.current]
            t['actions'] += 1
            if not entry['ok']:
                t['errors'] += 1
            elif op is not None and (op == 'undo' or op.endswith('_undo')):
                t['undos'] += 1
        if entry['ok'] and op in UNDOABLE and cmd is not None:
            u = self._inverse(op, fields, rep, s, wall)
            if u is not None:
                s.undo.append(u)
        if entry['ok'] and cmd is not None:
            self._track(op, fields, rep, s)
        self._tell()

    # -- ops ---------------------------------------------------------------------------------
    def set_tasks(self, text=None, path=None):
        if (text is None) == (path is None):
            raise ValueError('study_tasks: give tasks_text or tasks_file')
        if path is not None:
            with open(path) as f:
                text = f.read()
        self.tasks = parse_tasks(text)
        return {'tasks': self.tasks}

    def start(self, person):
        if not self.tasks:
            raise ValueError('study_start: no task list yet (study_tasks)')
        if self.session is not None:
            self.end()
        w = self.studio.world
        s = Session(len(self.sessions), person, self.tasks, w.clock, time.time(), w.poses())
        self.sessions.append(s)
        self.session = s
        return {'session': s.n}

    def task(self, action, n=None):
        s = self._running('study_task')
        w = self.studio.world
        if action == 'start':
            if s.current is not None:
                raise ValueError('study_task: task %d (%s) is running; finish it or give up '
                                 'first' % (s.current + 1, s.tasks[s.current]['name']))
            if n is None:
                n = next((i for i, t in enumerate(s.tasks) if t['start_wall'] is None), None)
                if n is None:
                    raise ValueError('study_task: every task was started')
            if n >= len(s.tasks):
                raise ValueError('study_task.task: no task %d (tasks 0..%d)'
                                 % (n, len(s.tasks) - 1))
            t = s.tasks[n]
            t.update(result=None, start_sim=w.clock, start_wall=time.time(), end_sim=None,
                     end_wall=None, actions=0, errors=0, undos=0)
            s.current = n
        else:
            if s.current is None:
                raise ValueError('study_task: no task is running (start one)')
            n = s.current
            s.tasks[n].update(result='success' if action == 'finish' else 'gave_up',
                              end_sim=w.clock, end_wall=time.time())
            s.current = None
        return {'task': n, 'session': s.summary()}

    def end(self):
        s = self._running('study_end')
        if s.current is not None:
            s.tasks[s.current].update(result='unfinished', end_sim=self.studio.world.clock,
                                      end_wall=time.time())
            s.current = None
        s.end_wall = time.time()
        self.session, self._ended = None, s
        return {'session': s.summary()}

    def _running(self, op):
        if self.session is None:
            raise ValueError('%s: no session is running (study_start)' % op)
        return self.session

    def undo_entry(self):
        """The undo entry of the session's last world change with an inverse (taken off
        the stack): {op, commands [(op, fields)], stop_walk}."""
        s = self._running('study_undo')
        if not s.undo:
            raise ValueError('study_undo: nothing to undo (no %s in this session yet, or '
                             'all undone)' % ', '.join(UNDOABLE))
        return s.undo.pop()

    async def apply_undo(self, u, client):
        """Carry out an undo entry's commands through the studio's handler; the applied
        [{op, fields}]."""
        studio, applied = self.studio, []
        if u.get('stop_walk'):
            from . import moves
            moves.stop_walk(studio, u['stop_walk'])
        for op, fields in u['commands']:
            c = protocol.check(dict(fields, v=protocol.VERSION, op=op), models=studio._models())
            rep = await studio.handle(c, client, True)
            if not rep.get('ok'):
                raise ValueError('study_undo: %s of the %s: %s' % (op, u['op'], rep.get('error')))
            self._track(op, c.fields, rep, self.session)
            applied.append({'op': op, 'fields': c.fields})
        return applied

    def state(self):
        return {'tasks': self.tasks,
                'running': self.session.summary() if self.session else None,
                'sessions': [s.summary() for s in self.sessions],
                'replay': None if self.replay is None else
                {k: self.replay[k] for k in ('session', 'mode', 'i', 'n')}}

    # -- CSV ----------------------------------------------------------------------------------
    def csv(self):
        out = io.StringIO()
        w = csv.DictWriter(out, CSV_COLUMNS, lineterminator='\n')
        w.writeheader()
        for s in self.sessions:
            for row in s.rows():
                w.writerow(row)
        return out.getvalue()

    def log_csv(self):
        out = io.StringIO()
        w = csv.writer(out, lineterminator='\n')
        w.writerow(('person', 'session', 'i', 'wall', 'sim', 'task', 'client', 'op', 'ok',
                    'error', 'fields'))
        for s in self.sessions:
            for e in s.log:
                w.writerow((s.person, s.n, e['i'], '%.3f' % e['wall'], '%.3f' % e['sim'],
                            '' if e['task'] is None else e['task'] + 1, e['client'],
                            e['op'], int(e['ok']), e['error'] or '',
                            json.dumps(e['fields'], separators=(',', ':'))[:2000]))
        return out.getvalue()

    # -- replay -------------------------------------------------------------------------------
    def replay_entries(self, n):
        if n >= len(self.sessions):
            raise ValueError('study_replay.session: no session %d (sessions 0..%d)'
                             % (n, len(self.sessions) - 1))
        out = []
        for e in self.sessions[n].log:
            if not e['ok']:
                continue
            if e['op'] == 'study_undo' and e.get('applied'):
                for k, a in enumerate(e['applied']):
                    out.append(dict(e, op=a['op'], fields=a['fields'],
                                    stop_walk=e.get('stop_walk') if k == 0 else None))
            elif e['op'] in protocol.OPS and protocol.OPS[e['op']][2] and \
                    e['op'] not in NOT_REPLAYED and e['op'] not in (
                        'study_undo', 'study_replay', 'study_next'):
                out.append(e)
        return out

    async def send(self, e):
        """Carry out one logged command through the studio's handler (not logged again)."""
        if e.get('stop_walk'):
            from . import moves
            moves.stop_walk(self.studio, e['stop_walk'])
        cmd = protocol.check(dict(e['fields'], v=protocol.VERSION, op=e['op']),
                             models=self.studio._models())
        rep = await self.studio.handle(cmd, None, True)
        if not rep.get('ok'):
            self.studio.log('studio: replay of %s: %s' % (e['op'], rep.get('error')))
        else:
            self._track(e['op'], cmd.fields, rep)
        return rep

    def _tell(self):
        self.studio.broadcast('study', self.state())

    async def start_replay(self, n, mode):
        self.stop_replay()
        entries = self.replay_entries(n)
        self.replay = {'session': n, 'mode': mode, 'i': 0, 'n': len(entries),
                       'entries': entries, 'task': None, 't0': self.studio.world.clock}
        if mode == 'timed':
            self.replay['task'] = asyncio.ensure_future(self._timed(self.replay))
        self._tell()
        return {'replay': {'session': n, 'mode': mode, 'n': len(entries)}}

    def stop_replay(self):
        r, self.replay = self.replay, None
        if r is not None and r['task'] is not None and not r['task'].done():
            r['task'].cancel()
        return {'replay': None}

    async def _timed(self, r):
        w = self.studio.world
        entries = r['entries']
        if not entries:
            return
        t0, first = r['t0'], entries[0]['sim']
        try:
            for i, e in enumerate(entries):
                while w.clock < t0 + (e['sim'] - first) - 1e-9:
                    await asyncio.sleep(0.005)
                await self.send(e)
                r['i'] = i + 1
                self._tell()
        except asyncio.CancelledError:
            raise
        except Exception as e:  # noqa: BLE001 - a replay must say why it stopped
            self.studio.log('studio: replay of session %d stopped: %s: %s'
                            % (r['session'], type(e).__name__, e))

    async def next(self):
        r = self.replay
        if r is None or r['mode'] != 'step':
            raise ValueError('study_next: no step-by-step replay (study_replay mode step)')
        if r['i'] >= r['n']:
            raise ValueError('study_next: the replay of session %d is done (%d commands)'
                             % (r['session'], r['n']))
        e = r['entries'][r['i']]
        rep = await self.send(e)
        r['i'] += 1
        self._tell()
        return {'sent': {'op': e['op'], 'fields': e['fields'], 'sim': e['sim']},
                'i': r['i'], 'n': r['n'], 'result': rep}


def attach(studio):
    """The study of ``studio`` (made once): its log hangs on ``studio.on_command``."""
    if getattr(studio, 'study', None) is None:
        studio.study = Study(studio)
        studio.on_command.append(studio.study.on_command)
        rospy = getattr(studio.world, 'rospy', None)
        if rospy is not None:
            try:
                studio.study.watch_environment(rospy)
            except Exception as e:  # noqa: BLE001 - undo of set_environment then knows less
                studio.log('studio: study: cannot watch /gazebo/environment: %s' % e)
    return studio.study


_study = attach


async def handle(studio, cmd, client):
    st = _study(studio)
    f = cmd.fields
    op = cmd.op
    if op == 'study_tasks':
        out = st.set_tasks(f['tasks_text'], f['tasks_file'])
    elif op == 'study_start':
        out = st.start(f['person'])
    elif op == 'study_task':
        out = st.task(f['action'], f['task'])
    elif op == 'study_end':
        out = st.end()
    elif op == 'study_state':
        return st.state()
    elif op == 'study_undo':
        u = st.undo_entry()
        out = {'undone': u['op'], 'applied': await st.apply_undo(u, client),
               'stop_walk': u['stop_walk']}
    elif op == 'study_replay':
        out = st.stop_replay() if f['mode'] == 'stop' else \
            await st.start_replay(f['session'], f['mode'])
    else:
        out = await st.next()
    if op != 'study_replay':
        st._tell()
    return out


def routes(app, studio):
    from aiohttp import web

    async def get_csv(_request):
        return web.Response(text=_study(studio).csv(), content_type='text/csv', headers={
            'Content-Disposition': 'attachment; filename="study.csv"'})

    async def get_log(_request):
        return web.Response(text=_study(studio).log_csv(), content_type='text/csv', headers={
            'Content-Disposition': 'attachment; filename="study_log.csv"'})

    async def get_state(_request):
        st = _study(studio)
        return web.json_response(dict(st.state(), logs=[s.log for s in st.sessions]))
    app.router.add_get('/api/study/csv', get_csv)
    app.router.add_get('/api/study/log.csv', get_log)
    app.router.add_get('/api/study/sessions', get_state)
