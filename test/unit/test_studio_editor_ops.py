"""The studio's scenario editor (sim_studio.editor), without a roscore: opening and saving
scenario files (the text as typed, valid or not, atomically), bad paths as one error, and
merging a recording into an opened scenario through ruamel.yaml's round trip without losing
its comments or formatting."""
import json
import os
import stat
import sys

import pytest

from sim_studio import editor
from sim_studio.protocol import Command
from sim_studio.recorder import Recorder, check

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import run, serve, studio  # noqa: E402

SCENARIO = """\
# the phone on the desk (a comment the studio must keep)
name: desk_check   # trailing comment
description: 'quoted, as typed'
real_time_factor: 0
duration: 2.0
world:
  launch: office
timeline:
  - {id: a1, at: 0.5, action: set_model_state, model: mobile_device,
     position: [3.3, -2.1, 1.0]}      # wrapped by hand

# what we expect
expect:
  - name: flat
    topic: /mobile_device/imu_sensor_data
    field: linear_acceleration.z
    always: {near: 9.81, tol: 0.5}
"""


def cmd(**kw):
    return json.dumps(dict({'v': 1}, **kw))


def recording():
    r = Recorder()
    r.start(10.0)
    r.add(Command('set_pose', {'model': 'mobile_device', 'position': [3.4, -2.0, 1.0],
                               'rpy': [0.0, 0.0, 1.5]}), 12.5)
    r.add(Command('press_button', {'model': 'mobile_device', 'button': 'power',
                                   'duration': 0.1}), 13.0)
    r.expect({'topic': '/mobile_device/battery_state', 'field': 'percentage',
              'mode': 'eventually', 'check': 'near', 'target': 0.9, 'tol': 0.1,
              'lo': None, 'hi': None, 'start': None, 'end': None, 'name': 'flat'})
    return r


def test_merging_a_recording_keeps_every_line_comment_and_wrap_of_the_file():
    out, added, expects = editor.merge(SCENARIO, recording(), offset=1.0)
    assert (added, expects) == (2, 1)
    assert check(out) == [], out
    new = out.splitlines()
    old = SCENARIO.splitlines()
    # every line of the file is still there, in order, byte for byte (but the duration)
    rest = iter(new)
    for ln in old:
        if ln.startswith('duration:'):
            continue
        assert any(ln == x for x in rest), (ln, out)
    assert 'duration: 5.0' in new          # the last action at 3.0 + 1.0 s offset, + 1 s
    # the recording's actions come after a1 and before the comment of the expectations
    i = new.index('# what we expect')
    tail = [x for x in new[:i] if x.strip()]
    assert tail[-2].startswith('  - {id: a2, at: 3.5, action: set_model_state'), out
    assert tail[-1].startswith('  - {id: a3, at: 4'), out      # a1 was taken: renamed
    assert 'press_button' in tail[-1]
    # the expectation of the same name is renamed, appended last
    assert new[-1].startswith('  - {name: flat_2, topic: /mobile_device/battery_state'), out


def test_merging_into_a_scenario_without_a_timeline_puts_one_before_expect():
    text = 'name: x\nduration: 5   # long enough\n# expectations\nexpect: []\n'
    out, added, _ = editor.merge(text, recording())
    assert check(out) == [], out
    lines = out.splitlines()
    assert lines[1] == 'duration: 5   # long enough'       # 5 > 4: kept as typed
    assert lines[2] == 'timeline:' and lines[3].startswith('  - {id: a1, at: 2.5,'), out
    assert lines[5:8] == ['# expectations', 'expect:', '  - {name: flat, topic: '
                          '/mobile_device/battery_state, field: percentage, eventually: '
                          '{near: 0.9, tol: 0.1}}'], out


def test_merge_refuses_invalid_yaml_and_an_empty_recording():
    with pytest.raises(editor.EditorError, match='not valid YAML'):
        editor.merge('name: [unclosed\n', recording())
    with pytest.raises(editor.EditorError, match='nothing recorded'):
        editor.merge(SCENARIO, Recorder())
    with pytest.raises(editor.EditorError, match='timeline of the scenario is not a list'):
        editor.merge('duration: 1\ntimeline: 3\n', recording())


def test_save_writes_invalid_yaml_as_typed_atomically_and_open_reads_it_back(tmp_path):
    path = tmp_path / 'broken.yaml'
    text = '# keep me\nname: x\nduration: [unclosed\n'
    rep = editor.save_file(str(path), text)
    assert path.read_text() == text
    assert rep['bytes'] == len(text.encode()) and rep['path'] == str(path)
    assert rep['problems'] and rep['problems'][0].startswith('broken.yaml:'), rep
    assert [p.name for p in tmp_path.iterdir()] == ['broken.yaml']     # no temporary left
    got = editor.open_file(str(path))
    assert got['yaml'] == text and got['problems'] == rep['problems']
    assert 'not valid YAML' in got['problems'][0]
    assert min(editor.problem_lines(got['problems'])) >= 3     # from the unclosed list on


def test_save_keeps_crlf_line_ends_permissions_and_a_symbolic_link(tmp_path):
    real = tmp_path / 'real.yaml'
    real.write_bytes(b'name: x\r\nduration: 1\r\n')
    os.chmod(str(real), 0o640)
    link = tmp_path / 'link.yaml'
    link.symlink_to(real)
    opened = editor.open_file(str(link))
    assert opened['yaml'] == 'name: x\nduration: 1\n' and opened['crlf']
    editor.save_file(str(link), opened['yaml'] + '# more\n')
    assert link.is_symlink()
    assert real.read_bytes() == b'name: x\r\nduration: 1\r\n# more\r\n'
    assert stat.S_IMODE(real.stat().st_mode) == 0o640


def test_bad_paths_are_one_error_each_and_nothing_is_written(tmp_path):
    cases = [
        ('open_scenario', {'path': str(tmp_path / 'missing.yaml')}, 'no such file'),
        ('open_scenario', {'path': str(tmp_path)}, 'not a file'),
        ('save_scenario', {'path': str(tmp_path / 'nope' / 'x.yaml'), 'yaml': 'a: 1\n'},
         'no such folder'),
        ('save_scenario', {'path': str(tmp_path / 'x.txt'), 'yaml': 'a: 1\n'},
         'ends in .yaml or .yml'),
        ('save_scenario', {'path': '', 'yaml': 'a: 1\n'}, 'non-empty string'),
    ]
    (tmp_path / 'bin.yaml').write_bytes(b'\xff\xfe')
    cases.append(('open_scenario', {'path': str(tmp_path / 'bin.yaml')}, 'not UTF-8'))
    s = studio()
    logged = []
    s.log = logged.append
    for op, fields, why in cases:
        n = len(logged)
        rep = run(s.handle_text(cmd(op=op, **fields)))
        assert not rep['ok'] and why in rep['error'], (op, rep)
        assert len(logged) == n + 1, logged[n:]                # one line each
    assert sorted(p.name for p in tmp_path.iterdir()) == ['bin.yaml']
    # the studio keeps serving
    assert run(s.handle_text(cmd(op='check', yaml='duration: 1\n')))['ok']


def test_the_ops_open_save_and_merge_through_the_handler(tmp_path):
    path = tmp_path / 'desk.yaml'
    path.write_text(SCENARIO)
    s = studio()
    s.recorder = recording()
    rep = run(s.handle_text(cmd(op='open_scenario', path=str(path))))
    assert rep['ok'] and rep['yaml'] == SCENARIO and rep['problems'] == [], rep
    rep = run(s.handle_text(cmd(op='merge_recording', yaml=rep['yaml'])))
    assert rep['ok'] and rep['added'] == 2 and rep['problems'] == [], rep
    merged = rep['yaml']
    rep = run(s.handle_text(cmd(op='save_scenario', path=str(path), yaml=merged)))
    assert rep['ok'] and rep['bytes'] == len(merged.encode())
    assert path.read_text() == merged and '# wrapped by hand' in merged


def test_codemirror_is_served_by_the_studio():
    if not os.path.isdir(editor.CODEMIRROR):
        pytest.skip("Debian's libjs-codemirror is not installed (tools/setup)")

    async def fn(c):
        r = await c.get('/codemirror/mode/yaml/yaml.js')
        page = await (await c.get('/')).text()
        return r.status, await r.text(), page
    status, js, page = serve(studio(), fn)
    assert status == 200 and 'defineMode("yaml"' in js
    assert '/static/ext/editor.js' in page and '/static/ext/editor.css' in page
