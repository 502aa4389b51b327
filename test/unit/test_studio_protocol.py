"""The studio's command protocol, its handler, control and recording (sim_studio), without
a roscore: a stand-in world records what the handler asks of it."""
import asyncio
import json
import math

import pytest

from sim_studio import protocol
from sim_studio.protocol import ProtocolError, parse
from sim_studio.recorder import Recorder, check
from sim_studio.server import Client, Studio, parse_run

MODELS = {'mobile_device', 'desk'}


class FakeWorld(object):
    def __init__(self):
        self.calls = []
        self.clock = 2.5
        self.image_seq = 0

    def model_names(self):
        return set(MODELS)

    def poses(self):
        return {'mobile_device': [1, 2, 3, 0, 0, 0, 1], 'desk': [0, 0, 0, 0, 0, 0, 1]}

    def rtf(self):
        return 1.0

    def link_poses(self):
        return {}

    def poll_links(self):
        pass

    def set_pose(self, *a):
        self.calls.append(('set_pose',) + a)

    def touch(self, *a):
        self.calls.append(('touch',) + a)
        return a[-1]

    def press_button(self, *a):
        self.calls.append(('press_button',) + a)

    def set_environment(self, *a):
        self.calls.append(('set_environment',) + a)

    def fault(self, *a):
        self.calls.append(('fault',) + a)

    def play(self):
        self.calls.append(('play',))

    def pause(self):
        self.calls.append(('pause',))

    def reset(self):
        self.calls.append(('reset',))

    def step(self, until):
        self.calls.append(('step', until))
        return until

    def camera_jpeg(self):
        return b'\xff\xd8 a jpeg'


class FakeWs(object):
    closed = False


def cmd(**kw):
    return json.dumps(dict({'v': 1}, **kw))


def test_a_set_pose_is_checked_and_its_numbers_are_floats():
    c = parse(cmd(op='set_pose', model='mobile_device', position=[1, 2, 3], id='a'), MODELS)
    assert c.op == 'set_pose' and c.id == 'a'
    assert c['position'] == [1.0, 2.0, 3.0] and c['rpy'] == [0.0, 0.0, 0.0]
    assert all(isinstance(v, float) for v in c['position'])


@pytest.mark.parametrize('text, words', [
    (cmd(op='fly'), 'unknown op "fly"'),
    ('{"v": 1, "op": "set_pose", "model": "mobile_device", "position": [NaN, 0, 0]}',
     'NaN is not a number'),
    ('{"v": 1, "op": "set_pose", "model": "mobile_device", "position": [Infinity, 0, 0]}',
     'Infinity is not a number'),
    ('{"v": 1, "op": "set_pose", "model": "mobile_device", "position": [1e999, 0, 0]}',
     'three finite numbers'),
    (cmd(op='set_pose', model='nobody', position=[0, 0, 0]), 'no model "nobody"'),
    (cmd(op='set_pose', model='mobile_device', position=[0, 0]), 'three finite numbers'),
    (cmd(op='set_pose', model='mobile_device', position='here'), 'three finite numbers'),
    (cmd(op='set_pose', model='mobile_device'), 'missing field position'),
    (cmd(op='set_pose', model='mobile_device', position=[0, 0, 0], speed=1),
     'unknown field speed'),
    (cmd(op='touch', x=1.5, y=0.5), 'in 0..1'),
    (cmd(op='touch', x=True, y=0.5), 'finite number'),
    (cmd(op='press_button', button='home'), 'one of power, volume_up, volume_down'),
    (cmd(op='step', until=-1), '>= 0'),
    (cmd(op='set_environment', values={'temperature': 'hot'}), 'finite numbers'),
    (json.dumps({'v': 2, 'op': 'play'}), 'protocol version 1'),
    ('[1, 2]', 'expected a JSON object'),
    ('{"v": 1, "op": ', 'not JSON'),
    (cmd(op='check', yaml='x' * (protocol.MAX_BYTES + 1)), 'larger than'),
], ids=lambda v: v if len(v) < 40 else v[:40])
def test_bad_commands_are_named(text, words):
    with pytest.raises(ProtocolError) as e:
        parse(text, MODELS)
    assert words in str(e.value)


def run(coro):
    return asyncio.new_event_loop().run_until_complete(coro)


PHONE = {'name': 'mobile_device', 'static': False, 'links': [],
         'display': {'link': 'mobile_display', 'width': 512, 'height': 300,
                     'image_topic': None}}


def studio():
    s = Studio(FakeWorld(), [PHONE], rate=40)
    s.log = lambda text: None
    return s


def test_the_handler_carries_out_commands_through_the_world():
    s = studio()
    rep = run(s.handle_text(cmd(op='set_pose', model='mobile_device', position=[1, 2, 0.5],
                                rpy=[0, 0, 1.5], id=7)))
    assert rep['ok'] and rep['id'] == 7 and rep['op'] == 'set_pose'
    run(s.handle_text(cmd(op='touch', x=0.5, y=0.25, duration=0.2)))
    run(s.handle_text(cmd(op='step', until=3.0)))
    assert s.world.calls == [('set_pose', 'mobile_device', [1.0, 2.0, 0.5], [0.0, 0.0, 1.5]),
                             ('touch', 'mobile_device', 0.5, 0.25, 0.2, (512, 300)),
                             ('step', 3.0)]


def test_an_invalid_command_changes_nothing_and_the_next_one_works():
    s = studio()
    bad = run(s.handle_text('{"v": 1, "op": "set_pose", "model": "mobile_device", '
                            '"position": [NaN, 0, 0], "id": "x"}'))
    assert not bad['ok'] and bad['id'] == 'x' and 'NaN' in bad['error']
    assert s.world.calls == []
    good = run(s.handle_text(cmd(op='pause')))
    assert good['ok'] and s.world.calls == [('pause',)]


def test_a_refused_service_is_one_error_back():
    s = studio()

    def refuse(*_a):
        raise RuntimeError('/gazebo/set_environment: unknown name temprature')
    s.world.set_environment = refuse
    rep = run(s.handle_text(cmd(op='set_environment', values={'temprature': 20})))
    assert not rep['ok'] and 'temprature' in rep['error']


def test_one_client_holds_control_the_others_read_until_it_lets_go():
    s = studio()

    async def go():
        a, b = Client(FakeWs(), '127.0.0.1'), Client(FakeWs(), '127.0.0.1')
        s.clients += [a, b]
        r1 = await s.handle_text(cmd(op='play'), a)
        r2 = await s.handle_text(cmd(op='pause'), b)
        r3 = await s.handle_text(cmd(op='scene'), b)          # reading is allowed
        r4 = await s.handle_text(cmd(op='pause'), None, local=True)   # POST from loopback
        r5 = await s.handle_text(cmd(op='control', take=False), a)
        r6 = await s.handle_text(cmd(op='pause'), b)
        return r1, r2, r3, r4, r5, r6, a, b
    r1, r2, r3, r4, r5, r6, a, b = run(go())
    assert r1['ok'] and not r2['ok'] and 'read-only' in r2['error'] and a.name in r2['error']
    assert r3['ok'] and [m['name'] for m in r3['scene']['models']] == ['desk', 'mobile_device']
    assert r4['ok'] and r5['ok'] and r6['ok'] and s.holder is b
    assert s.world.calls == [('play',), ('pause',), ('pause',)]


def test_post_from_elsewhere_is_refused_while_a_client_holds_control():
    s = studio()

    async def go():
        a = Client(FakeWs(), '127.0.0.1')
        s.clients.append(a)
        await s.handle_text(cmd(op='play'), a)
        return await s.handle_text(cmd(op='pause'), None, local=False)
    rep = run(go())
    assert not rep['ok'] and 'read-only' in rep['error']


def test_a_slow_client_gets_the_latest_pose_and_loses_the_rest():
    c = Client(FakeWs(), '127.0.0.1')
    for i in range(5):
        c.put('poses', 'pose %d' % i)
    c.answer({'ok': True})
    c.put('camera', b'jpeg')
    assert c.slots == {'poses': 'pose 4', 'camera': b'jpeg'} and len(c.replies) == 1


def test_recording_makes_a_scenario_run_scenario_check_accepts(tmp_path):
    s = studio()
    run(s.handle_text(cmd(op='set_pose', model='mobile_device', position=[0, 0, 1])))
    rep = run(s.handle_text(cmd(op='record', on=True)))
    assert rep['recording'] and 'timeline: []' in rep['yaml']
    s.world.clock = 3.25
    run(s.handle_text(cmd(op='set_pose', model='mobile_device', position=[3.3, -2.1, 1.05],
                          rpy=[0, 0, math.pi / 2])))
    s.world.clock = 4.0
    run(s.handle_text(cmd(op='touch', x=0.5, y=0.25)))
    run(s.handle_text(cmd(op='play')))                       # not a scenario action
    run(s.handle_text(cmd(op='press_button', button='power')))
    run(s.handle_text(cmd(op='fault', sensor='imu', fault='freeze')))
    run(s.handle_text(cmd(op='set_environment', values={'temperature': 30})))
    rep = run(s.handle_text(cmd(op='record', on=False)))
    y = rep['yaml']
    assert not rep['recording']
    assert ('{id: a1, at: 0.75, action: set_model_state, model: mobile_device, '
            'position: [3.3, -2.1, 1.05], rpy: [0, 0, 1.570796]}') in y
    assert ('{id: a2, at: 1.5, action: touch, ns: mobile_device, x: 256, y: 75, '
            'duration: 0.1}') in y
    assert 'action: press_button' in y and 'action: fault' in y and 'temperature: 30' in y
    assert 'play' not in y.split('timeline:')[1]
    assert 'duration: 2.5' in y
    assert check(y) == []
    from testing_instance.farm.cli import check as cli_check
    f = tmp_path / 'rec.yaml'
    f.write_text(y)
    out = []
    assert cli_check([str(f)], out=out.append) == 0, out


def test_the_validator_names_file_and_line():
    problems = check('duration: 1\ntimeline:\n  - {at: 0.5, action: set_model_stat, '
                     'model: m}\n', 'studio.yaml')
    assert problems and problems[0].startswith('studio.yaml:3:')
    assert 'set_model_stat' in problems[0]


def test_run_scenario_output_becomes_verdicts():
    out = ('noise\nPASS flat_no_rotation: always ok\nFAIL portrait: never 0\n'
           'ERROR run: the world died\n')
    r = parse_run(out, 1)
    assert r['status'] == 'FAIL'
    assert [(v['status'], v['name']) for v in r['verdicts']] == [
        ('PASS', 'flat_no_rotation'), ('FAIL', 'portrait'), ('ERROR', 'run')]
    assert parse_run('', 0)['status'] == 'PASS' and parse_run('', 2)['status'] == 'ERROR'


def test_a_recorder_that_is_off_records_nothing():
    r = Recorder()
    c = parse(cmd(op='set_pose', model='m', position=[0, 0, 0]))
    assert r.add(c, 1.0) is None and r.actions == []


def test_a_drag_while_paused_is_one_action_with_the_last_pose():
    r = Recorder()
    r.start(10.0)
    for x in (1.0, 1.1, 1.2):
        r.add(parse(cmd(op='set_pose', model='m', position=[x, 0, 0])), 10.5)
    r.add(parse(cmd(op='set_pose', model='m', position=[1.3, 0, 0])), 10.6)
    assert [(e['id'], e['at'], e['position'][0]) for e in r.actions] == [
        ('a1', 0.5, 1.2), ('a2', 0.6, 1.3)]


# -- the aiohttp application, in this process (no roscore) --------------------------------
def serve(s, fn):
    """Run ``fn(client)`` against the studio's app on a test server."""
    from aiohttp.test_utils import TestClient, TestServer
    from sim_studio.server import make_app

    async def go():
        async with TestClient(TestServer(make_app(s))) as c:
            return await fn(c)
    return run(go())


def test_the_token_guards_every_route_when_set():
    s = studio()
    s.token = 'sekrit'

    async def fn(c):
        r1 = await c.get('/api/scene')
        r2 = await c.get('/api/scene?token=sekrit')
        r3 = await c.post('/api/cmd', data=cmd(op='pause'),
                          headers={'X-Studio-Token': 'sekrit'})
        r4 = await c.post('/api/cmd', data=cmd(op='pause'), headers={'X-Studio-Token': 'x'})
        return r1.status, (await r1.json())['error'], r2.status, r3.status, r4.status
    st1, err, st2, st3, st4 = serve(s, fn)
    assert (st1, st2, st3, st4) == (403, 200, 200, 403) and 'token' in err
    assert s.world.calls == [('pause',)]


def test_websocket_clients_stream_poses_and_one_holds_control():
    s = studio()

    async def fn(c):
        a = await c.ws_connect('/ws')
        b = await c.ws_connect('/ws')
        hello = await a.receive_json()
        got = {'poses': 0, 'images': []}

        async def reply(ws):
            while True:
                msg = await ws.receive(timeout=10)
                if isinstance(msg.data, bytes):
                    got['images'].append(msg.data)
                    continue
                m = json.loads(msg.data)
                if m.get('type') == 'poses':
                    got['poses'] += 1
                if m['type'] == 'reply':
                    return m
        await a.send_str(cmd(op='play', id=1))
        ra = await reply(a)
        await b.send_str(cmd(op='pause', id=2))
        rb = await reply(b)
        await b.send_str('{"v": 1, "op": "set_pose", "model": "mobile_device", '
                         '"position": [0, 0, NaN], "id": 3}')
        rbad = await reply(b)
        await a.close()
        await asyncio.sleep(0.1)
        await b.send_str(cmd(op='pause', id=4))
        rb2 = await reply(b)
        await b.close()
        return hello, ra, rb, rbad, rb2, got['poses'], got['images']
    hello, ra, rb, rbad, rb2, poses, images = serve(s, fn)
    assert hello['type'] == 'hello' and 'set_pose' in hello['ops']
    assert ra['ok'] and not rb['ok'] and 'read-only' in rb['error']
    assert not rbad['ok'] and rbad['id'] == 3 and 'NaN' in rbad['error']
    assert rb2['ok'], 'control did not pass on when its holder left'
    assert s.world.calls == [('play',), ('pause',)]
    assert poses >= 1 and images and images[0].startswith(b'\xff\xd8')


def test_a_gone_world_is_in_the_stream_with_its_log_tail():
    s = studio()
    assert json.loads(s.poses_message())['world_gone'] is None
    s.health = lambda: ('the world exited (roslaunch 1)', ['[sim_world-1] process has died'])
    s.check_world()
    gone = json.loads(s.poses_message())['world_gone']
    assert gone == {'error': 'the world exited (roslaunch 1)',
                    'log': ['[sim_world-1] process has died']}
    s.health = lambda: None
    s.check_world()
    assert json.loads(s.poses_message())['world_gone'] is None


def test_a_touch_on_a_model_without_a_known_display_is_one_error():
    s = studio()
    rep = run(s.handle_text(cmd(op='touch', model='desk', x=0.5, y=0.5)))
    assert not rep['ok'] and 'no touch display of model desk' in rep['error']
    assert 'mobile_device' in rep['error'] and s.world.calls == []


def test_an_expectation_becomes_an_expect_entry_the_validator_accepts():
    s = studio()
    rep = run(s.handle_text(cmd(op='expect', topic='/mobile_device/magnetic',
                                field='magnetic_field.z', mode='eventually', check='near',
                                target=-4.4e-05, tol=4e-06)))
    assert rep['ok'], rep
    rep = run(s.handle_text(cmd(op='expect', topic='/mobile_device/magnetic',
                                field='magnetic_field.z', mode='always', check='between',
                                lo=-1, hi=1, start=0, end=2)))
    y = rep['yaml']
    assert ('- {name: magnetic_field_z, topic: /mobile_device/magnetic, field: '
            'magnetic_field.z, eventually: {near: -4.4e-05, tol: 4.0e-06}}') in y, y
    assert ('- {name: magnetic_field_z_2, topic: /mobile_device/magnetic, field: '
            'magnetic_field.z, always: {between: [-1, 1]}, window: [0, 2]}') in y, y
    assert 'duration: 2' in y
    assert check(y) == [], check(y)
    from testing_instance.scenario.format import loads
    sc = loads(y, 'studio.yaml')
    assert sc is not None
    import yaml
    e = yaml.safe_load(y)['expect'][0]
    assert e['eventually'] == {'near': -4.4e-05, 'tol': 4e-06}


@pytest.mark.parametrize('fields, words', [
    (dict(check='near', target=1.0), 'near needs the field tol'),
    (dict(check='equals'), 'equals needs the field target'),
    (dict(check='between', lo=2, hi=1), 'lo <= hi'),
    (dict(check='equals', target=1, start=1), 'both start and end'),
    (dict(check='equals', target=1, start=2, end=1), 'start < end'),
    (dict(check='about', target=1), 'expected one of equals, near, between'),
])
def test_bad_expectations_are_named(fields, words):
    s = studio()
    rep = run(s.handle_text(cmd(op='expect', topic='/t', field='data', mode='always',
                                **fields)))
    assert not rep['ok'] and words in rep['error'], rep
    assert s.recorder.expects == []
