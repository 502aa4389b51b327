"""The studio's study mode (sim_studio.study), without a roscore: a task list, a session's
action log through the server's command path (Studio.on_command) with sim and wall times,
time on task, success, error and undo counts per task as CSV, undo of every world change
with a clean inverse (a pose set, a preset, a walk, environment values, a fault, a radio, the
charger), and the replay of a session's world commands (timed against the world's clock,
and step by step)."""
import asyncio
import csv
import io
import json
import sys

import pytest

from sim_studio import extensions, study
from sim_studio.study import parse_tasks

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import run, studio as make_studio  # noqa: E402
from test_studio_moves_ops import phone_desc  # noqa: E402,F401 - a fixture


def cmd(**kw):
    return json.dumps(dict({'v': 1}, **kw))


@pytest.fixture
def s():
    extensions.load()
    st = make_studio()
    study.attach(st)           # make_app does it
    assert st.study.on_command in st.on_command
    return st


def send(st, **kw):
    return run(st.handle_text(cmd(**kw)))


def test_task_lists_from_yaml_json_or_lines():
    assert parse_tasks('- find the desk\n- {name: touch, text: touch the screen}') == [
        {'name': 'find the desk', 'text': 'find the desk'},
        {'name': 'touch', 'text': 'touch the screen'}]
    assert parse_tasks('{"tasks": ["a", "b"]}') == [{'name': 'a', 'text': 'a'},
                                                    {'name': 'b', 'text': 'b'}]
    assert [t['name'] for t in parse_tasks('put the phone down\n\nturn it over: face down\n')] \
        == ['put the phone down', 'turn it over: face down']
    with pytest.raises(ValueError, match='task 2'):
        parse_tasks('- a\n- [1, 2]')
    with pytest.raises(ValueError, match='no tasks'):
        parse_tasks('  \n')


def test_a_session_logs_every_command_and_counts_per_task(s, tmp_path):
    w = s.world
    f = tmp_path / 'tasks.yaml'
    f.write_text('- move the phone\n- touch the screen\n')
    assert send(s, op='study_tasks', tasks_file=str(f))['ok']
    assert not send(s, op='study_task', action='start')['ok']       # no session yet
    assert send(s, op='study_start', person='P1')['session'] == 0
    w.clock = 10.0
    assert send(s, op='study_task', action='start')['task'] == 0
    w.clock = 11.0
    send(s, op='set_pose', model='mobile_device', position=[1, 2, 3])
    w.clock = 11.5
    send(s, op='set_pose', model='nobody', position=[1, 2, 3])      # refused: an error
    send(s, op='fly')                                                # unknown op: an error
    w.clock = 12.0
    send(s, op='set_pose', model='mobile_device', position=[4, 5, 6], rpy=[0, 0, 1])
    rep = send(s, op='study_undo')                                   # back to [1, 2, 3]
    assert rep['ok'] and rep['undone'] == 'set_pose'
    assert rep['applied'][0]['fields']['position'] == [1.0, 2.0, 3.0]
    assert w.calls[-1][:3] == ('set_pose', 'mobile_device', [1.0, 2.0, 3.0])
    rep = send(s, op='study_undo')          # back to the pose when the session started
    assert rep['ok'] and w.calls[-1][:3] == ('set_pose', 'mobile_device', [1.0, 2.0, 3.0])
    assert not send(s, op='study_undo')['ok']                        # nothing left: an error
    w.clock = 14.0
    assert send(s, op='study_task', action='finish')['ok']
    assert send(s, op='study_task', action='start')['task'] == 1
    send(s, op='touch', x=0.5, y=0.5)
    w.clock = 15.0
    assert send(s, op='study_task', action='give_up')['ok']
    assert send(s, op='study_end')['ok']
    log = s.study.sessions[0].log
    assert [e['op'] for e in log] == [
        'study_start', 'study_task', 'set_pose', 'set_pose', 'fly', 'set_pose', 'study_undo', 'study_undo',
        'study_undo', 'study_task', 'study_task', 'touch', 'study_task', 'study_end']
    assert log[2]['sim'] == 11.0 and log[2]['fields']['position'] == [1.0, 2.0, 3.0]
    assert log[2]['wall'] > 1e9 and log[4]['ok'] is False and 'unknown op' in log[4]['error']
    assert log[2]['task'] == 0 and log[0]['task'] is None
    rows = list(csv.DictReader(io.StringIO(s.study.csv())))
    assert [(r['person'], r['task'], r['result'], r['success'], r['actions'], r['errors'],
             r['undos'], r['sim_time_on_task_s']) for r in rows] == [
        ('P1', '1', 'success', '1', '7', '3', '2', '4.000'),
        ('P1', '2', 'gave_up', '0', '1', '0', '0', '1.000')]
    assert float(rows[0]['time_on_task_s']) >= 0
    lines = s.study.log_csv().splitlines()
    assert len(lines) == 1 + len(log) and lines[0].startswith('person,session,i,wall,sim')


def test_a_session_replays_its_world_commands_timed_and_step_by_step(s):
    w = s.world
    send(s, op='study_tasks', tasks_text='- one')
    send(s, op='study_start', person='P2')
    w.clock = 5.0
    send(s, op='set_pose', model='mobile_device', position=[1, 0, 0])
    send(s, op='pause')                                    # time control: not replayed
    w.clock = 5.5
    send(s, op='press_button', button='power')
    send(s, op='set_pose', model='nobody', position=[1, 0, 0])      # refused: not replayed
    w.clock = 6.0
    send(s, op='set_environment', values={'temperature': 30})
    send(s, op='study_end')
    w.calls.clear()
    assert send(s, op='study_replay', session=0, mode='step')['replay']['n'] == 3
    rep = send(s, op='study_next')
    assert rep['ok'] and rep['sent']['op'] == 'set_pose' and (rep['i'], rep['n']) == (1, 3)
    assert w.calls == [('set_pose', 'mobile_device', [1.0, 0.0, 0.0], [0.0, 0.0, 0.0])]
    send(s, op='study_next')
    send(s, op='study_next')
    assert [c[0] for c in w.calls] == ['set_pose', 'press_button', 'set_environment']
    assert 'done' in send(s, op='study_next')['error']
    assert not send(s, op='study_replay', session=3, mode='step')['ok']
    # timed: each command when the world's clock reaches its sim time after the first's
    w.calls.clear()

    async def timed():
        w.clock = 100.0
        rep = await s.handle_text(cmd(op='study_replay', session=0, mode='timed'))
        assert rep['ok']
        seen = []
        for t, n in ((100.2, 1), (100.49, 1), (100.5, 2), (100.8, 2), (101.0, 3)):
            w.clock = t
            await asyncio.sleep(0.1)              # not early ...
            for _ in range(100):                  # ... and on time (under load: soon)
                if len(w.calls) >= n:
                    break
                await asyncio.sleep(0.02)
            seen.append([c[0] for c in w.calls])
        return seen
    seen = run(timed())
    assert seen == [['set_pose'], ['set_pose'], ['set_pose', 'press_button'],
                    ['set_pose', 'press_button'],
                    ['set_pose', 'press_button', 'set_environment']]
    # the replayed commands are not logged as actions of a session
    assert len(s.study.sessions) == 1 and s.study.session is None


def test_csv_route(s):
    from test_studio_protocol import serve
    send(s, op='study_tasks', tasks_text='- a\n- b')
    send(s, op='study_start', person='P3')
    send(s, op='study_task', action='start')

    async def fn(c):
        r = await c.get('/api/study/csv')
        return r.status, r.headers['Content-Disposition'], await r.text()
    status, disp, text = serve(s, fn)
    assert status == 200 and 'study.csv' in disp
    rows = list(csv.DictReader(io.StringIO(text)))
    assert [(r['task'], r['result']) for r in rows] == [('1', 'unfinished'),
                                                        ('2', 'not started')]


def test_undo_takes_back_each_world_change_that_has_an_inverse(phone_desc):
    """set_environment, fault, radio, charger, preset and walk are undone to the state
    before them (the environment's from /gazebo/environment when the studio set none);
    a touch has no inverse and is passed over; every undo counts for the task and is
    replayed as the commands it sent."""
    import types
    from test_studio_moves_ops import OFFICE, Services
    from test_studio_protocol import FakeWorld
    from sim_studio import moves

    class World(FakeWorld):
        def __init__(self):
            FakeWorld.__init__(self)
            self.pose, self.sets, self.proxy = [1.0, 2.0, 3.0], [], Services(self)

        def poses(self):
            return {'mobile_device': self.pose + [0, 0, 0, 1], 'desk': [0, 0, 0, 0, 0, 0, 1]}

        def get_pose(self, model):
            return list(self.pose), [0, 0, 0, 1]

        def set_pose(self, model, position, rpy):
            FakeWorld.set_pose(self, model, position, rpy)
            self.pose = list(position)

    extensions.load()
    w = World()
    st = make_studio()
    st.world = w
    st.scene_models = [phone_desc]
    st.world_file = OFFICE
    study.attach(st)
    published = []
    moves._hands(st, 'mobile_device').publish = lambda topic, m: published.append(
        (topic, m.data))
    # the world's environment as /gazebo/environment had it before the session
    st.study.on_environment(types.SimpleNamespace(values=[
        types.SimpleNamespace(name='temperature', value=15.0),
        types.SimpleNamespace(name='daylight', value=10000.0),
        types.SimpleNamespace(name='time_of_day', value=12.0)]), wall=1.0)
    send(st, op='study_tasks', tasks_text='- change everything')
    send(st, op='study_start', person='P4')
    send(st, op='study_task', action='start')
    changes = [dict(op='set_environment', values={'temperature': 30, 'humidity': 80}),
               dict(op='set_environment', values={'temperature': 25}),
               dict(op='fault', sensor='/mobile_device/magnetic', fault='drop'),
               dict(op='fault', sensor='/mobile_device/magnetic', fault='noise', value=3),
               dict(op='radio', radio='wifi', enabled=False),
               dict(op='charger', plugged=True),
               dict(op='preset', model='mobile_device', name='flat_on_desk'),
               dict(op='touch', x=0.5, y=0.5)]
    for c in changes:
        assert send(st, **c)['ok'], c
    on_desk = list(w.pose)
    assert 0.75 < on_desk[2] < 0.77
    w.calls.clear()

    def undo():
        rep = send(st, op='study_undo')
        assert rep['ok'], rep
        return rep['undone'], [(a['op'], a['fields']) for a in rep['applied']]
    # the touch is passed over: the preset is the last change with an inverse
    assert undo() == ('preset', [('set_pose', {'model': 'mobile_device',
                                               'position': [1.0, 2.0, 3.0],
                                               'rpy': [0.0, 0.0, 0.0]})])
    assert w.pose == [1.0, 2.0, 3.0]
    assert undo() == ('charger', [('charger', {'model': 'mobile_device', 'plugged': False})])
    assert undo() == ('radio', [('radio', {'model': 'mobile_device', 'radio': 'wifi',
                                           'enabled': True})])
    assert published[-2:] == [('/mobile_device/charger', False),
                              ('/mobile_device/wifi/enable', True)]
    assert undo()[1][0][1]['fault'] == 'drop'                       # the fault before noise
    assert undo()[1][0][1] == {'model': 'mobile_device', 'sensor': '/mobile_device/magnetic',
                               'fault': 'none', 'value': 0.0}      # none before the first
    assert undo() == ('set_environment', [('set_environment', {'values': {'temperature': 30.0}})])
    # the world's own temperature; humidity was never known: left as it is
    assert undo() == ('set_environment', [('set_environment', {'values': {'temperature': 15.0}})])
    assert [c[0] for c in w.calls] == ['set_pose', 'fault', 'fault', 'set_environment',
                                       'set_environment']
    assert 'nothing to undo' in send(st, op='study_undo')['error']
    # daylight follows the hour: an hour's undo puts the daylight before it back, after it
    assert send(st, op='set_environment', values={'time_of_day': 6})['ok']
    done, applied = undo()
    assert done == 'set_environment'
    assert list(applied[0][1]['values'].items()) == [('time_of_day', 12.0),
                                                     ('daylight', 10000.0)]
    # a walk under way: stopped, and the phone back where the walk found it
    rep = send(st, op='walk', model='mobile_device', waypoints=[[2, 2, 3], [2, 4, 3]],
               speed=1.0)
    assert rep['ok'] and rep['before']['position'] == [1.0, 2.0, 3.0]
    assert rep['end_pose']['position'] == pytest.approx([2, 4, 3], abs=1e-6)
    w.clock += 1.0
    st._moves.mover.run_due()
    assert w.pose != [1.0, 2.0, 3.0]
    assert undo()[0] == 'walk'
    assert st._moves.mover.pending() == 0 and w.pose == [1.0, 2.0, 3.0]
    # a pose set after a finished walk goes back to the walk's end
    send(st, op='walk', model='mobile_device', waypoints=[[2, 2, 3], [2, 4, 3]], speed=1.0)
    w.clock += 100.0
    st._moves.mover.run_due()
    send(st, op='set_pose', model='mobile_device', position=[9, 9, 9])
    assert undo()[1][0][1]['position'] == pytest.approx([2, 4, 3], abs=1e-6)
    send(st, op='study_task', action='finish')
    send(st, op='study_end')
    row = next(csv.DictReader(io.StringIO(st.study.csv())))
    assert (row['undos'], row['errors']) == ('10', '1')     # the undo with nothing left
    # a replay sends what each undo sent
    ops = [e['op'] for e in st.study.replay_entries(0)]
    assert ops[:9] == [c['op'] for c in changes] + ['set_pose']
    assert ops[9:] == ['charger', 'radio', 'fault', 'fault', 'set_environment',
                       'set_environment', 'set_environment', 'set_environment', 'walk',
                       'set_pose', 'walk', 'set_pose', 'set_pose']
