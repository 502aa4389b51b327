"""The pipelined lockstep (`pipeline: true`, StepWorld's pipeline), with a real roscore,
world and app: the QR app decides on one slice's frames while the world steps the next.

- what the app answers lands exactly one slice later than in the plain lockstep, and the
  world's own messages are the same;
- two embedded runs, one of them while two CPU hogs run (stress-ng --cpu 2), give
  identical recordings message by message, and the sim_world node
  the same world messages and app answers as the embedded world;
- replaying a pipelined recording times the app's answers as the live run did (the
  recording's meta says so, whatever the scenario file).
"""
import contextlib
import os
import re

import pytest

from fixtures.hogs import cpu_hogs
from fixtures.scenario_cli import run_scenario
from test_scenarios import EX, bag_messages, verdicts

pytestmark = pytest.mark.rostest

WORLD = ['/mobile_device/image_raw', '/mobile_device/camera_info']


def qr_texts():
    """The QR example (its app found from anywhere), plain and pipelined, 1 s of sim time
    instead of 2 (the app answers in the first 0.1 s; each second is ten camera frames
    rendered)."""
    text = open(os.path.join(EX, 'qr_code.yaml')).read()
    assert '\nduration: 2.0\n' in text
    text = text.replace('\nduration: 2.0\n', '\nduration: 1.0\n')
    # 11 frames over [0, 1] s are 10.01 Hz by the rate's count (21 over [0, 2], 10.005): the
    # frames are counted exactly below
    assert 'rate: {near: 10, tol: 0.01}' in text
    text = text.replace('rate: {near: 10, tol: 0.01}', 'rate: {near: 10, tol: 0.02}')
    text = text.replace('script: qr_app.py', 'script: %s' % os.path.join(EX, 'qr_app.py'))
    return text, text.replace('\nduration: ', '\npipeline: true\nduration: ', 1)


def test_pipelined_app_answers_one_slice_later_the_same_every_run(tmp_path):
    text, piped = qr_texts()
    text = text.replace('record: [', 'record: [/mobile_device/camera_info, ')
    lock, pipe = tmp_path / 'lock.yaml', tmp_path / 'pipe.yaml'
    lock.write_text(text)
    pipe.write_text(piped.replace('record: [', 'record: [/mobile_device/camera_info, '))
    runs = {'lock': (lock, '--embedded'), 'pipe1': (pipe, '--embedded'),
            'pipe2': (pipe, '--embedded'), 'node': (pipe, '--world-node')}
    bags = {}
    for name, (f, mode) in runs.items():
        bag = tmp_path / (name + '.bag')
        # pipe2 while two CPU hogs compete for the cores
        with cpu_hogs() if name == 'pipe2' else contextlib.nullcontext():
            rc, out = run_scenario(f, mode, '--record', bag, timeout=300)
        assert rc == 0, out
        assert set(verdicts(out).values()) == {'PASS'}, out
        bags[name] = bag_messages(bag)
    # the plain lockstep times the answer to the first frame's slice, 0.05 s; pipelined the
    # app gets that frame when the next slice begins, and its answer lands at that one's end.
    # (The plain run's answer once came a slice late in a fresh-clone CI run: the app's
    # first decode pages in library code, its thread waits in state D, and the app watch
    # took that for idle. It counts state D as busy now: test_appwatch.)
    result = '/qr_app/result'
    assert [t for t, _b in bags['lock'][result]] == [50000000]
    assert [t for t, _b in bags['pipe1'][result]] == [100000000]
    assert bags['pipe1'][result][0][1] == bags['lock'][result][0][1]
    for topic in WORLD:               # the world's own messages do not change
        assert len(bags['pipe1'][topic]) == 11, topic      # 10 Hz over [0, 1] s
        assert bags['pipe1'][topic] == bags['lock'][topic], topic
    a, b = bags['pipe1'], bags['pipe2']
    assert sorted(a) == sorted(b)
    for topic in a:
        if topic != '/scenario/meta':
            assert a[topic] == b[topic], '%s differs between two pipelined runs' % topic
    for topic in WORLD + [result]:
        assert bags['node'][topic] == a[topic], '%s differs with the sim_world node' % topic
    # the recording says it was pipelined: replayed with the plain scenario file too
    rep = tmp_path / 'replay.bag'
    rc, out = run_scenario(lock, '--replay', tmp_path / 'pipe1.bag', '--record', rep,
                           timeout=300)
    assert rc == 0 and 'PASS app_decodes' in out, out
    assert bag_messages(rep, [result])[result] == a[result]


def test_a_warm_farm_mixes_pipelined_and_plain_scenarios(tmp_path):
    """One warm world runs a pipelined scenario, a plain one, a pipelined one: each app's
    answer lands where its own mode puts it (the plain one's is not held back by the
    pipelined one before it)."""
    text, pipe = qr_texts()
    for name, t in (('a_pipe', pipe), ('b_plain', text), ('c_pipe', pipe)):
        (tmp_path / (name + '.yaml')).write_text(t)
    rc, out = run_scenario(tmp_path, '--jobs', '1', timeout=300)
    assert rc == 0, out
    got = dict(re.findall(r"^\[(\w+)\.yaml\] PASS app_decodes: .* at t=([\d.]+) s$", out, re.M))
    assert got == {'a_pipe': '0.100', 'b_plain': '0.050', 'c_pipe': '0.100'}, out
