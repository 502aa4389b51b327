"""Every service of the world and of the phone's plugins answers bad values without raising
(issue 45 part 5), through ROS: one office world (its own master, as
test_fuzz_spawn_ros.py's) gets every row of test/fixtures/bad_service_client.py's table
(NaN and inf numbers, zero quaternions, empty and unknown names, negative, infinite and huge
durations and times, unknown keys and kinds) through rospy.ServiceProxy, from a client
process of its own. Each row must be answered ``success: false`` with a status_message that
names the bad value, logged on exactly one line; the phone does not move; no traceback and
no 'internal error' appears in the node's output or log files; good requests are still
taken; afterwards the world steps and every pose and twist of /gazebo/model_states is
finite. The checks themselves: test/unit/test_srvcheck.py."""
import glob
import json
import math
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.bad_service_client import CASES, GOOD  # noqa: E402
from fixtures.rosworld import node_pid, office_world  # noqa: E402

CLIENT = os.path.join(HERE, 'fixtures', 'bad_service_client.py')

pytestmark = pytest.mark.rostest


@pytest.fixture(scope='module')
def run(tmp_path_factory):
    """The client's answers and the world's output, from one world for the whole table."""
    tmp = tmp_path_factory.mktemp('bad_service_input')
    with office_world(tmp) as env:
        pid = node_pid(env, '/sim_world')
        p = subprocess.run([sys.executable, CLIENT], env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, timeout=600)
        lines = [ln for ln in p.stdout.splitlines() if ln.startswith('{')]
        assert p.returncode == 0 and lines, (p.returncode, p.stdout[-2000:], p.stderr[-3000:])
        out = json.loads(lines[-1])
        out['same_pid'] = pid is not None and node_pid(env, '/sim_world') == pid
    out['screen'] = open(str(tmp / 'roslaunch.log'), errors='replace').read()
    out['logs'] = dict((f, open(f, errors='replace').read())
                       for f in glob.glob(str(tmp / 'roslog' / '*' / '*.log')))
    return out


@pytest.mark.parametrize('case', CASES, ids=[c[0] for c in CASES])
def test_bad_value_is_refused_naming_it_in_one_log_line(run, case):
    case_id, service, _type, fields, named = case
    a = run['answers'][case_id]
    assert a['answered'], '%s %r: no answer: %s' % (service, fields, a.get('error'))
    if named is None:                     # std_srvs/Empty: answered, nothing to refuse
        return
    msg = a['message']
    assert a['success'] is False, '%s %r was taken: %s' % (service, fields, msg)
    assert named in msg, 'the answer does not name %s: %s' % (named, msg)
    assert '\n' not in msg and 'internal error' not in msg, msg
    # exactly one line of the node's output says it (a plugin's line starts with its label)
    said = [ln for ln in run['screen'].splitlines() if msg in ln]
    assert len(said) == 1, (msg, said)


def test_every_refusal_says_something_of_its_own(run):
    """(so that one log line per refusal is a check of each row, not of a shared text)"""
    msgs = [run['answers'][c[0]]['message'] for c in CASES if c[4] is not None]
    assert len(set(msgs)) == len(msgs)


def test_good_requests_are_still_taken(run):
    assert run['arm']['success'], run['arm']        # the model of the joint rows
    for case_id, service, _t, fields in GOOD:
        a = run['good'][case_id]
        assert a['answered'] and a['success'] is True, (service, fields, a)


def test_the_phone_did_not_move_and_the_world_still_steps_with_finite_poses(run):
    assert run['phone_before'] == run['phone_after']
    assert all(math.isfinite(v) for v in run['phone_after'])
    s = run['steps']
    assert s['first_success'] and s['success'], s
    assert s['after'] == pytest.approx(s['before'] + 0.25, abs=0.002), s
    assert 'mobile_device' in s['models'] and 'bad_input_arm' in s['models'], s
    assert s['non_finite'] == [], s
    assert run['same_pid']              # the same world process served the whole table


def test_no_traceback_in_the_node_output_or_logs(run):
    texts = dict(run['logs'], screen=run['screen'])
    for name, text in texts.items():
        for bad in ('Traceback', 'Error processing request', 'internal error'):
            assert bad not in text, '%s in %s:\n%s' % (bad, name, text[text.find(bad) - 500:]
                                                       [:3000])
    assert any(os.path.basename(f).startswith('sim_world') for f in run['logs']), \
        sorted(run['logs'])
