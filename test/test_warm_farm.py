"""Warm worlds (issue 18 item 3): a farm's worker keeps its master and world, and resets
the world between scenarios with /gazebo/reload_world.

- a scenario run after another in one warm world records exactly what it records alone in
  a fresh world, message by message with its times, though the first one changed
  everything a scenario can change (environment, faults, charger, radio, models spawned,
  deleted and moved, the phone's start pose, an app parameter, a latched topic);
- the warm farm's verdicts on the examples are the cold farm's (the warm farm: the
  session's, fixtures/example_farm.py);
- the world node's reload service refuses bad requests with one line and keeps serving.
"""
import os
import re
import subprocess

import pytest

from fixtures.scenario_cli import run_scenario
from test_scenarios import EX, bag_messages, verdicts

pytestmark = pytest.mark.rostest

#: changes everything a scenario can change (shared with test_embedded and bench/load)
MESSY = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'data', 'messy.yaml')


def messy_text():
    """messy.yaml's text with absolute paths (for a changed copy written elsewhere)."""
    with open(MESSY) as f:
        return f.read().replace('../../testing_instance/examples', EX)


def test_warm_world_gives_the_cold_recording(tmp_path, auto_rotate_recording):
    b = os.path.join(EX, 'auto_rotate.yaml')
    # one worker: messy, then auto_rotate in the same world
    rc, out = run_scenario('--jobs', '1', MESSY, b, '--record', tmp_path / 'warm',
                           timeout=600)
    assert rc == 0, out
    assert re.search(r'\[messy.yaml\] scenario messy .*: PASS', out), out
    assert re.search(r'\[auto_rotate.yaml\] start-up: \d', out), out
    # cold: auto_rotate alone in a fresh world, the session's run (fixtures/example_farm.py)
    rc, out_cold, cold_bag = auto_rotate_recording
    assert rc == 0, out_cold
    assert verdicts(out, '[auto_rotate.yaml] ') == verdicts(out_cold)
    warm = bag_messages(tmp_path / 'warm' / 'auto_rotate.bag')
    cold = bag_messages(cold_bag)
    assert '/mobile_device/imu_sensor_data' in cold and '/rotate_app/rotation' in cold
    assert '/probe' not in warm
    assert sorted(warm) == sorted(cold)
    for topic in cold:        # the meta too: same scenario, seed and real-time factor
        assert len(warm[topic]) == len(cold[topic]), topic
        for i, (x, y) in enumerate(zip(warm[topic], cold[topic])):
            assert x == y, '%s message %d (time, bytes) differs warm and cold' % (topic, i)


def test_warm_and_cold_farms_agree_on_the_examples(example_farm):
    """The warm farm is the session's over every example (fixtures/example_farm.py); a cold
    farm runs five of them: compass (and its failing variant), the in-call app, the
    battery world's own launch file, two phones."""
    files = [os.path.join(EX, f) for f in ('compass.yaml', 'compass_fails.yaml',
                                           'incall_proximity.yaml', 'battery_saver.yaml',
                                           'nfc_vcard.yaml')]
    warm = example_farm.out
    rc_c, cold = run_scenario('--jobs', '2', '--cold', *files, timeout=900)
    assert example_farm.rc == rc_c == 1, warm + cold           # compass_fails fails
    for f in files:
        name = os.path.basename(f)
        w, c = example_farm.verdicts(name), verdicts(cold, '[%s] ' % name)
        assert w and w == c, (name, warm, cold)
    # warm: a start-up per scenario, all of them printed
    n = len([f for f in os.listdir(EX) if f.endswith('.yaml')])
    assert len(re.findall(r'^\[\S+\] start-up: ', warm, re.M)) == n, warm


def test_reload_world_refuses_bad_requests_and_keeps_serving(tmp_path):
    from fixtures.rosworld import office_world

    def ros(*cmd):
        p = subprocess.run(list(cmd), env=env, capture_output=True, text=True, timeout=60)
        return re.sub(r'\\\n\s*\\', '', p.stdout + p.stderr)   # rosservice's folded lines

    def reload(req):
        return ros('rosservice', 'call', '--wait', '/gazebo/reload_world', req)
    with office_world(tmp_path, 'paused:=true') as env:
        ros('rosservice', 'call', '--wait', '/gazebo/step_world', '{until: 0.01}')
        before = ros('rosservice', 'call', '/gazebo/get_model_state',
                     '{model_name: mobile_device}')
        bad = {
            '{seed: -5}': 'seed must be >= 0',
            '{seed: 1, real_time_factor: -1, start_poses: "{nope: {x: 1}}"}':
                "no remembered model 'nope'",
            '{seed: 1, real_time_factor: -1, start_poses: "{mobile_device: {q: 1}}"}':
                'give a mapping of x, y, z, R, P, Y',
            '{seed: 1, real_time_factor: -1, start_poses: "{mobile_device: {x: abc}}"}':
                'must be a finite number',
            '{seed: 1, real_time_factor: -1, start_poses: "[1, 2"}': 'start_poses is not YAML',
        }
        for req, why in bad.items():
            out = reload(req)
            assert 'success: False' in out and why in out and 'nothing changed' in out, out
        # nothing changed: the same world, at the same time
        seq = re.compile(r'seq: \d+')
        assert seq.sub('', ros('rosservice', 'call', '/gazebo/get_model_state',
                               '{model_name: mobile_device}')) == seq.sub('', before)
        out = reload('{seed: 8, real_time_factor: -1, '
                     'start_poses: "{mobile_device: {x: 2.5, Y: 1.0}}"}')
        assert 'success: True' in out and 'seed 8' in out, out
        st = ros('rosservice', 'call', '/gazebo/get_model_state',
                 '{model_name: mobile_device}')
        assert re.search(r'x: 2\.5\b', st) and re.search(r'y: -2\.11\b', st), st
        assert 'secs: 0\n' in st, st                       # sim time 0 again
        assert ros('rosparam', 'get', '/sim_world/seed').strip().strip("'") == '8'
        st = ros('rosservice', 'call', '/gazebo/step_world', '{until: 0.2}')
        assert 'sim_time: 0.2' in st, st
