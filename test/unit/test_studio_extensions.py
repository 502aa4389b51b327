"""The studio's extension hooks (sim_studio.extensions): an extension's ops are checked like
the core's, carried out by its handler, under control when they change the world; its page
script is on the page; its routes are served. A stand-in extension module is registered
for the test and taken out again."""
import json
import sys
import types

import pytest

from sim_studio import extensions, protocol
from sim_studio.protocol import ProtocolError, parse
from sim_studio.server import Client, index_html

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import FakeWs, MODELS, run, serve, studio  # noqa: E402


@pytest.fixture
def ext(monkeypatch):
    """sim_studio.fake_ext: one world op (wave, on a model) and one read op (count)."""
    mod = types.ModuleType('sim_studio.fake_ext')
    seen = []

    def wave_check(f):
        if f['times'] > 5:
            raise ProtocolError('wave: at most 5 times, got %d' % f['times'])

    mod.OPS = {
        'wave': dict(required={'model': 'str', 'times': 'int>=0'},
                     optional={'path': []}, kinds={'path': 'list'}, changes_world=True,
                     takes_model=True, field_check=wave_check, doc='wave a model'),
        'count': dict(doc='how many waves so far'),
    }

    async def handle(s, cmd, client):
        if cmd.op == 'count':
            return {'n': len(seen)}
        if cmd['times'] == 0:
            raise ValueError('wave: nothing to do')
        seen.append((cmd['model'], cmd['times'], cmd['path']))
        return {'waved': cmd['times']}
    mod.handle = handle

    def routes(app, s):
        from aiohttp import web

        async def get(_request):
            return web.json_response({'n': len(seen)})
        app.router.add_get('/api/fake_ext/n', get)
    mod.routes = routes
    sys.modules['sim_studio.fake_ext'] = mod
    before = (dict(protocol.OPS), set(protocol.WORLD_OPS), set(protocol.MODEL_OPS))
    extensions.load(['fake_ext'])
    monkeypatch.setattr(extensions, 'NAMES', extensions.NAMES + ('fake_ext',))
    yield seen
    protocol.OPS.clear()
    protocol.OPS.update(before[0])
    protocol.WORLD_OPS.clear()
    protocol.WORLD_OPS.update(before[1])
    protocol.MODEL_OPS.clear()
    protocol.MODEL_OPS.update(before[2])
    protocol.FIELD_CHECKS.pop('wave', None)
    extensions._HANDLERS.pop('wave', None)
    extensions._HANDLERS.pop('count', None)
    del extensions._LOADED['fake_ext']
    del sys.modules['sim_studio.fake_ext']


def cmd(**kw):
    return json.dumps(dict({'v': 1}, **kw))


def test_an_extensions_op_is_checked_like_the_cores(ext):
    c = parse(cmd(op='wave', model='desk', times=2), MODELS)
    assert c.fields == {'model': 'desk', 'times': 2, 'path': []}
    for bad, words in [(dict(op='wave', model='desk'), 'missing field times'),
                       (dict(op='wave', model='desk', times=1.5), 'whole number'),
                       (dict(op='wave', model='desk', times=2, path={}), 'JSON array'),
                       (dict(op='wave', model='desk', times=9), 'at most 5'),
                       (dict(op='wave', model='cupboard', times=1), 'no model'),
                       (dict(op='wave', model='desk', times=1, speed=2), 'unknown field')]:
        with pytest.raises(ProtocolError, match=words):
            parse(cmd(**bad), MODELS)


def test_an_op_defined_twice_is_refused(ext):
    with pytest.raises(ValueError, match='twice'):
        protocol.register('set_pose', {}, {}, True, 'again')
    with pytest.raises(ValueError, match='no kind'):
        protocol.register('shrug', {}, {'how_much': 1}, False, 'shrug')


def test_the_handler_carries_out_an_extensions_op_under_control(ext):
    s = studio()
    rep = run(s.handle_text(cmd(op='wave', model='desk', times=2, id=4)))
    assert rep == {'v': 1, 'type': 'reply', 'ok': True, 'op': 'wave', 'id': 4, 'waved': 2}
    assert ext == [('desk', 2, [])]
    bad = run(s.handle_text(cmd(op='wave', model='desk', times=0)))
    assert not bad['ok'] and bad['error'] == 'wave: nothing to do' and len(ext) == 1
    a, b = Client(FakeWs(), '127.0.0.1'), Client(FakeWs(), '127.0.0.1')
    s.clients += [a, b]
    assert run(s.handle_text(cmd(op='wave', model='desk', times=1), a))['ok']
    refused = run(s.handle_text(cmd(op='wave', model='desk', times=1), b))
    assert not refused['ok'] and 'read-only' in refused['error'] and len(ext) == 2
    # an op that changes nothing needs no control
    assert run(s.handle_text(cmd(op='count'), b)) == {'v': 1, 'type': 'reply', 'ok': True,
                                                       'op': 'count', 'n': 2}


def test_broadcast_puts_a_latest_wins_message_in_each_clients_slot(ext):
    s = studio()
    a, b = Client(FakeWs(), '127.0.0.1'), Client(FakeWs(), '127.0.0.1')
    s.clients += [a, b]
    s.broadcast('fake', {'n': 1})
    s.broadcast('fake', {'n': 2}, clients=[a])
    assert json.loads(a.slots['fake']) == {'n': 2, 'v': 1, 'type': 'fake'}
    assert json.loads(b.slots['fake']) == {'n': 1, 'v': 1, 'type': 'fake'}


def test_the_page_loads_every_extension_script_after_studio_js(tmp_path, monkeypatch):
    from sim_studio import server
    static = tmp_path / 'static'
    (static / 'ext').mkdir(parents=True)
    with open(server.os.path.join(server.STATIC, 'index.html')) as f:
        (static / 'index.html').write_text(f.read())
    for n in ('b.js', 'a.js', 'a.css', 'notes.txt'):
        (static / 'ext' / n).write_text('')
    monkeypatch.setattr(server, 'STATIC', str(static))
    page = index_html()
    core = page.index('/static/studio.js')
    a, b = page.index('/static/ext/a.js'), page.index('/static/ext/b.js')
    assert core < a < b and '<link rel="stylesheet" href="/static/ext/a.css">' in page
    assert 'notes.txt' not in page and '<!-- extensions -->' not in page


def test_an_extensions_routes_are_served(ext):
    s = studio()

    async def fn(c):
        await c.post('/api/cmd', data=cmd(op='wave', model='desk', times=3))
        r = await c.get('/api/fake_ext/n')
        return r.status, await r.json()
    assert serve(s, fn) == (200, {'n': 1})
