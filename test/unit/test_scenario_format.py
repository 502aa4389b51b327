"""The scenario format: every example scenario validates; each bad input is refused with
file, line and what was expected (never a traceback)."""
import glob
import os

import pytest

from testing_instance.scenario import format as sc

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXAMPLES = sorted(glob.glob(os.path.join(ROOT, 'testing_instance', 'examples', '*.yaml')))

GOOD = """\
name: demo
seed: 3
duration: 4.0
world: {launch: office, physics: ode, args: {camera_rate: 10}}
apps:
  - {name: app, script: app.py}
timeline:
  - {id: warm, at: 0.5, action: set_environment, values: {temperature: 30.0}, ramp: 1.0}
  - {at: 1.0, action: move_model, model: mobile_device, waypoints: [[1, 2, 1], [2, 2, 1]],
     speed: 0.5}
  - {when: {reach: {model: mobile_device, position: [2, 2, 1], tolerance: 0.1}},
     action: charger, plugged: true}
  - {after: warm, delay: 0.2, action: fault, sensor: imu, fault: noise, value: 3}
expect:
  - name: upright
    topic: /mobile_device/imu_sensor_data
    field: linear_acceleration.z
    always: {near: 9.81, tol: 0.5}
    window: [0.1, 3.0]
  - {name: imu_rate, topic: /mobile_device/imu_sensor_data, rate: {near: 100, tol: 2}}
  - {name: code, topic: /mobile_device/image_raw, eventually: {barcode: "x"}, after: warm,
     window: [0, 1]}
"""


def problems(text):
    with pytest.raises(sc.ScenarioError) as e:
        sc.loads(text, 'bad.yaml')
    return e.value.problems


def test_good_scenario_loads_with_defaults():
    s = sc.loads(GOOD, 'good.yaml')
    assert s.name == 'demo' and s.seed == 3 and s.duration == 4.0
    assert s.timeline[0]['id'] == 'warm' and s.timeline[1]['id'] == 'event1'
    assert [e['name'] for e in s.expect] == ['upright', 'imu_rate', 'code']
    assert s.real_time_factor == 0.0
    assert s.phones == [{'ns': 'mobile_device'}]


@pytest.mark.parametrize('path', EXAMPLES, ids=[os.path.basename(p) for p in EXAMPLES])
def test_every_example_validates(path):
    s = sc.load(path)
    assert s.expect, 'an example without expectations checks nothing'


def test_examples_exist():
    assert len(EXAMPLES) >= 2


@pytest.mark.parametrize('edit, line, words', [
    # a typo in an action name: line of the action, a suggestion, the allowed list
    (('action: move_model', 'action: mvoe_model'), 9, ["unknown action 'mvoe_model'",
                                                        "did you mean 'move_model'"]),
    # an unknown top-level key
    (('seed: 3', 'sed: 3'), 2, ["scenario.sed: unknown key (did you mean 'seed'?)"]),
    # a wrong type
    (('duration: 4.0', 'duration: soon'), 3, ['scenario.duration: expected a number > 0, got '
                                               "'soon'"]),
    # an environment name that does not exist
    (('{temperature: 30.0}', '{temprature: 30.0}'), 8, ['environment names', "'temprature'"]),
    # a window in the past (end before start)
    (('window: [0.1, 3.0]', 'window: [3.0, 0.1]'), 19, ['expected 0 <= start < end']),
    # a window after the scenario's end
    (('window: [0.1, 3.0]', 'window: [0.1, 30.0]'), 19, ['after the scenario (duration 4 s)']),
    # two modes
    (('always: {near: 9.81, tol: 0.5}', 'always: {near: 9.81}\n    never: {gt: 1}'), 15,
     ['expected exactly one of eventually, always, never']),
    # tol without near
    (('rate: {near: 100, tol: 2}', 'rate: {gt: 100, tol: 2}'), 20,
     ['tol goes with near, equals or colour']),
    # an event that is referenced but not defined
    (('after: warm, delay', 'after: wram, delay'), 13, ["expected the id of a timeline event",
                                                        "'wram'"]),
    # no trigger
    (('  - {at: 1.0, action: move_model', '  - {action: move_model'), 9,
     ['expected exactly one trigger']),
    # an action time after the end
    (('at: 1.0, action: move_model', 'at: 9.0, action: move_model'), 9,
     ['within the scenario (0 .. duration 4 s), got 9']),
    # a missing required field of an action
    (('speed: 0.5}', 'speed: 0.5, model2: x}'), 10, ["timeline[1].model2: unknown key"]),
    # bad fault kind
    (('fault: noise', 'fault: nosie'), 13, ['expected one of none, drop, freeze, noise']),
    # an image predicate without a region
    (('eventually: {barcode: "x"}', 'eventually: {colour: [1, 2, 3]}'), 21,
     ['a colour needs a region']),
])
def test_bad_input_names_file_line_and_expectation(edit, line, words):
    old, new = edit
    assert old in GOOD
    probs = problems(GOOD.replace(old, new, 1))
    text = '\n'.join(probs)
    assert any(p.startswith('bad.yaml:%d: ' % line) for p in probs), text
    for w in words:
        assert w in text, text


def test_missing_required_key_and_not_yaml():
    probs = problems('name: x\n')
    assert probs == ["bad.yaml:1: scenario: missing 'duration' (expected a number > 0)"]
    probs = problems('duration: 1\nexpect: [\n')
    assert len(probs) == 1 and probs[0].startswith('bad.yaml:3: not valid YAML')
    probs = problems('- 1\n- 2\n')
    assert 'expected a mapping' in probs[0]


def test_missing_action_field_and_duplicate_key():
    probs = problems('duration: 1\ntimeline:\n  - {at: 0.5, action: charger}\n')
    assert probs == ["bad.yaml:3: timeline[0]: missing 'plugged' (expected true or false)"]
    probs = problems('duration: 1\nduration: 2\n')
    assert 'appears twice' in probs[0] and probs[0].startswith('bad.yaml:2:')


def test_unreadable_file():
    with pytest.raises(sc.ScenarioError) as e:
        sc.load('/nonexistent/x.yaml')
    assert 'cannot read the scenario file' in str(e.value)


def test_unnamed_expectations_get_names_and_do_not_clash():
    s = sc.loads('duration: 1\nexpect:\n  - {topic: /a, always: {gt: 0}}\n'
                 '  - {topic: /b, never: {gt: 0}}\n', 'ok.yaml')
    assert [e['name'] for e in s.expect] == ['expect0', 'expect1']
    probs = problems('duration: 1\nexpect:\n  - {name: x, topic: /a, always: {gt: 0}}\n'
                     '  - {name: x, topic: /b, never: {gt: 0}}\n')
    assert probs == ["bad.yaml:4: expect[1].name: expectation name 'x' used twice"]
