"""Runner pieces that need no ROS master: JUnit XML, field probing, invalid files, shards."""
import xml.etree.ElementTree as ET

import pytest
from sensor_msgs.msg import Imu

from testing_instance.farm import cli
from testing_instance.scenario.expect import FieldError, Verdict
from testing_instance.run.runner import EXIT_ERROR, EXIT_FAIL, EXIT_PASS, Result, _probe_field, \
    run_file, write_junit


def test_junit_counts_failures_and_errors(tmp_path):
    vs = [Verdict('a', True, 'x', 'x', 1.0), Verdict('b', False, 'y', 'z', 2.0),
          Verdict('c', False, 'w', 'topic /q never appeared', None, error=True)]
    r = Result('demo', vs)
    assert r.status == 'ERROR' and r.exit_code == EXIT_ERROR
    assert Result('d', vs[:2]).exit_code == EXIT_FAIL
    assert Result('d', vs[:1]).exit_code == EXIT_PASS
    write_junit(r, str(tmp_path / 'j.xml'))
    root = ET.parse(str(tmp_path / 'j.xml')).getroot()
    assert root.tag == 'testsuite' and root.get('name') == 'demo'
    assert (root.get('tests'), root.get('failures'), root.get('errors')) == ('3', '1', '1')
    cases = root.findall('testcase')
    assert [c.get('name') for c in cases] == ['a', 'b', 'c']
    assert cases[1].find('failure').get('message').startswith('FAIL b: expected y; actual z')
    assert cases[2].find('error') is not None


def test_probe_field_names_the_missing_part():
    _probe_field(Imu(), 'linear_acceleration.z')
    _probe_field(Imu(), 'orientation_covariance[3]')
    with pytest.raises(FieldError) as e:
        _probe_field(Imu(), 'linear_acceleraton.z')
    assert "Imu has no field 'linear_acceleraton'" in str(e.value)
    assert 'linear_acceleration' in str(e.value)
    with pytest.raises(FieldError):
        _probe_field(Imu(), 'linear_acceleration.w')


def test_invalid_file_is_an_error_before_anything_starts(tmp_path):
    f = tmp_path / 'x.yaml'
    f.write_text('duration: -1\n')
    lines = []
    r = run_file(str(f), out=lines.append, junit=str(tmp_path / 'j.xml'))
    assert r.exit_code == EXIT_ERROR and r.status == 'ERROR'
    assert lines[0].startswith('ERROR scenario file')
    assert 'x.yaml:1: scenario.duration: expected a number > 0, got -1' in lines[1]
    assert (tmp_path / 'j.xml').exists()


def test_pipeline_must_be_true_or_false(tmp_path):
    from testing_instance.scenario.format import load
    f = tmp_path / 'p.yaml'
    f.write_text('duration: 1\npipeline: true\n')
    assert load(str(f)).pipeline is True
    f.write_text('duration: 1\n')
    assert load(str(f)).pipeline is False
    f.write_text('duration: 1\npipeline: sometimes\n')
    lines = []
    r = run_file(str(f), out=lines.append)
    assert r.exit_code == EXIT_ERROR
    assert "p.yaml:2: scenario.pipeline: expected true or false, got 'sometimes'" in lines[1]


def test_shards_deal_the_sorted_files_round_robin():
    files = ['e', 'a', 'c', 'b', 'd']
    assert cli._shard(files, '0/2') == ['a', 'c', 'e']
    assert cli._shard(files, '1/2') == ['b', 'd']
    assert sorted(cli._shard(files, '0/3') + cli._shard(files, '1/3') +
                  cli._shard(files, '2/3')) == sorted(files)
    with pytest.raises(SystemExit):
        cli._shard(files, '2/2')


def test_junit_holds_log_tails_with_colour_codes_and_control_characters(tmp_path):
    """A world's log tail carries roslaunch's ANSI colours: the JUnit file stays valid XML
    (found by the process-fault tests: the file was not well-formed)."""
    import xml.etree.ElementTree as ET
    from testing_instance.scenario.results import Result, write_junit
    r = Result('s', [], 'the world died', ['\x1b[1m[spawn_phone-3] finished\x1b[0m', 'bell\x07'])
    write_junit(r, str(tmp_path / 'j.xml'))
    err = ET.parse(str(tmp_path / 'j.xml')).getroot().find('testcase/error')
    assert err.text.splitlines()[1:] == ['[spawn_phone-3] finished', 'bell']


def test_a_farm_run_gets_the_options_that_apply_to_each_run(tmp_path):
    from testing_instance.farm.cli import farm_argv
    from testing_instance.farm.command import parser as _parser
    a = _parser('run_scenario').parse_args([
        'x.yaml', '--jobs', '2', '--seed', '3', '--set', 'heading=30', '--set', 'seed=4',
        '--world-node', '--junit', str(tmp_path / 'j'), '--record', str(tmp_path / 'r')])
    argv = farm_argv('dir/compass_sweep.yaml', a)
    assert argv == ['dir/compass_sweep.yaml', '--seed', '3', '--set', 'heading=30',
                    '--set', 'seed=4', '--world-node',
                    '--junit', str(tmp_path / 'j' / 'compass_sweep.xml'),
                    '--record', str(tmp_path / 'r' / 'compass_sweep.bag')]
    assert (tmp_path / 'j').is_dir() and (tmp_path / 'r').is_dir()
    # what a run does with it: the same parsed options as a single run's
    b = _parser('run_scenario').parse_args(argv)
    assert b.set == ['heading=30', 'seed=4'] and b.world_node and b.seed == 3
    assert farm_argv('y.yaml', _parser('run_scenario').parse_args(['y.yaml'])) == ['y.yaml']


def test_the_world_side_of_the_subscriptions_is_awaited_in_a_namespace(monkeypatch):
    """Before its timeline the runner waits until the world's publishers count it as a
    subscriber (a connection still being accepted would cost the first message in one run
    and not another). The world node is the one serving step_world, /lab/sim_world in a
    namespace: that node is asked, not a /sim_world that is not there."""
    import rosgraph
    import xmlrpc.client
    from testing_instance.run.inbox import Inbox
    from testing_instance.run.intake import Intake
    from testing_instance.run.recording import Recorder
    asked, calls = [], []

    class Master(object):
        def __init__(self, *a, **k):
            pass

        def getSystemState(self):
            return ([('/mobile_device/camera_info', ['/lab/sim_world']),
                     ('/lab/imu', ['/lab/sim_world'])], [], [])

        def lookupNode(self, name):
            asked.append(name)
            if name != '/lab/sim_world':
                raise rosgraph.MasterError('unknown node [%s]' % name)
            return 'http://localhost:1/'

    class Proxy(object):
        def __init__(self, uri):
            pass

        def getBusInfo(self, me):
            calls.append(me)
            out = [[1, '/runner', 'o', 'TCPROS', '/lab/imu', True]]
            if len(calls) >= 3:             # the camera_info connection, accepted later
                out.append([2, '/runner', 'o', 'TCPROS', '/mobile_device/camera_info', True])
            return [1, '', out]
    monkeypatch.setattr(rosgraph, 'Master', Master)
    monkeypatch.setattr(xmlrpc.client, 'ServerProxy', Proxy)
    r = Intake(Inbox(), Recorder())
    r.world_node = '/lab/sim_world'
    r.start(type('R', (), {'get_name': staticmethod(lambda: '/runner')}))
    import time
    r.wait_publisher_side(['/mobile_device/camera_info', '/lab/imu'], time.monotonic() + 5)
    assert asked == ['/lab/sim_world']
    assert len(calls) == 3                  # waited until both were accepted


def test_the_start_up_is_told_by_its_phases_which_add_up_to_the_figure():
    """The start-up line's breakdown: what came before the run (the command's Python start),
    then each phase's own seconds; phases under 5 ms left out; nothing in a replay."""
    from types import SimpleNamespace
    from testing_instance.run.runner import Runner
    r = SimpleNamespace(wall0=100.0, startup=1.5,
                        phases=[('master', 100.6), ('node and world', 101.0),
                                ('phones', 101.002), ('first step', 101.3)])
    got = Runner.startup_phases(r)
    assert [n for n, _s in got] == ['Python and imports', 'master', 'node and world',
                                    'first step']
    assert [round(s, 3) for _n, s in got] == [0.2, 0.6, 0.4, 0.298]
    assert abs(sum(s for _n, s in got) + 0.002 - r.startup) < 1e-9
    # a farm's later run: its start-up is from its own start, nothing before it
    r.startup = 1.3
    assert Runner.startup_phases(r)[0][0] == 'master'
    assert Runner.startup_phases(SimpleNamespace(wall0=0.0, startup=None, phases=[])) == []


def test_a_replays_slice_waits_for_exactly_what_it_published_then_for_the_apps(monkeypatch):
    """ReplayClock.handshake: the replay's own messages on the topics subscribed before it
    began are waited for by count (they come back through this node's own subscriptions),
    not by a quiet period; then the apps (appwatch), then the held messages are timed. What
    never comes back is an ERROR naming the topic and the counts."""
    import threading
    import time
    from types import SimpleNamespace
    from testing_instance.run import clock as clock_mod
    from testing_instance.run.inbox import Inbox
    from testing_instance.run.runner import Runner
    from testing_instance.scenario.results import RunError
    order = []
    r = SimpleNamespace(inbox=Inbox(), intake=SimpleNamespace(subs={'/a': 1, '/b': 1}),
                        apps=SimpleNamespace(wait_answered=lambda wake: order.append('apps')),
                        stamp_held=lambda: order.append('stamped'), sync_wall=0.0, t=0.05,
                        sc=SimpleNamespace(slice=0.05),
                        recorder=SimpleNamespace(flush=lambda: order.append('recorded')))
    r.answered = lambda w0: Runner.answered(r, w0)
    c = clock_mod.ReplayClock([], None, None, None, '/ev', run=r)
    r.inbox.put(0.01, '/a', 'a1')

    def late():
        time.sleep(0.1)
        order.append('b arrives')
        r.inbox.put(0.02, '/b', 'b1')
    threading.Thread(target=late).start()
    t0 = time.monotonic()
    c.counts = {'/a': 1, '/b': 1, '/not_subscribed': 7}
    c.handshake()
    assert time.monotonic() - t0 >= 0.09
    # the slice goes to the recording once its held messages are timed (one order)
    assert order == ['b arrives', 'apps', 'stamped', 'recorded']
    assert c.replayed_subs == {'/a', '/b'}
    # a topic subscribed later (it missed the earlier messages) is not counted
    r.intake.subs['/c'] = 1
    c.counts = {'/a': 1, '/b': 1, '/c': 5}
    c.handshake()
    monkeypatch.setattr(clock_mod, 'HANDSHAKE_WATCHDOG', 0.05)
    r.t = 0.1
    c.counts = {'/a': 3, '/b': 1}
    with pytest.raises(RunError) as e:
        c.handshake()
    assert str(e.value) == ('slice handshake: 0 s of wall time after the replay reached sim '
                            'time 0.100 s, messages it published have not come back: /a (1 of 3)')


def test_topics_are_looked_at_again_when_something_can_have_made_new_ones():
    """The periodic look at the master's topics (every TOPIC_RECHECK s of sim time) where
    another process can publish: a sim_world node, apps, other nodes of the launch file. An
    embedded run without them makes it only when this process declared a publisher since
    the last look (at the same sim time: recordings equal the sim_world node's); after a
    spawn (Hands.spawned) and while an expectation's topic is not subscribed, always."""
    from types import SimpleNamespace
    from testing_instance.run.clock import TOPIC_RECHECK, WorldClock
    from testing_instance.scenario.timeline import Conditions

    def clock(embedded, apps=(), launch_procs=()):
        r = SimpleNamespace(embedded=embedded, sc=SimpleNamespace(apps=list(apps), slice=0.05),
                            world=SimpleNamespace(launch_procs=list(launch_procs)),
                            hands=SimpleNamespace(spawned=False), t=0.05,
                            intake=SimpleNamespace(subs={'/a': 1}), expectations=[],
                            conditions=Conditions([]))
        return WorldClock(r)
    for c, periodic in ((clock(False), True), (clock(True), False),
                        (clock(True, apps=[{'name': 'app'}]), True),
                        (clock(True, launch_procs=[SimpleNamespace(alive=lambda: True)]),
                         True),
                        (clock(True, launch_procs=[SimpleNamespace(alive=lambda: False)]),
                         False)):
        r = c.run
        assert not c.topics_stale()                  # within TOPIC_RECHECK
        r.t = TOPIC_RECHECK
        assert c.topics_stale() is periodic
        r.hands.spawned = True
        assert c.topics_stale()
        r.hands.spawned = False
        r.expectations = [SimpleNamespace(topic='/b', verdict=None)]   # not subscribed yet
        assert c.topics_stale()
        r.expectations[0].verdict = 'pass'
        assert c.topics_stale() is periodic
    # a publisher this process declares: the next periodic look is made, not one at once
    c = clock(True)
    c.new_own_topic('/mobile_device/new_sensor')
    assert c.topics_new and not c.topics_stale()
    c.run.t = TOPIC_RECHECK
    assert c.topics_stale()


def test_live_says_each_verdict_the_moment_it_is_decided():
    """run_scenario --live: Runner.drain says 'decided <verdict line>' once, when an
    expectation is decided (an eventually met, an always broken), and nothing for one still
    open; without --live it says nothing."""
    import types
    from testing_instance.run.runner import Runner
    from testing_instance.scenario.expect import Expectation
    from testing_instance.scenario.timeline import Conditions
    from std_msgs.msg import Float64

    def runner(live):
        said = []
        es = [Expectation({'name': 'up', 'topic': '/x', 'field': 'data',
                           'eventually': {'gt': 2}}),
              Expectation({'name': 'low', 'topic': '/x', 'field': 'data',
                           'always': {'lt': 3}}),
              Expectation({'name': 'open', 'topic': '/x', 'field': 'data',
                           'eventually': {'gt': 100}})]
        for e in es:
            e.begin(0.0)
        batches = [[(0.1, 0, '/x', Float64(1.0))], [(0.2, 0, '/x', Float64(2.5))],
                   [(0.3, 0, '/x', Float64(3.5)), (0.4, 0, '/x', Float64(9.0))]]
        fake = types.SimpleNamespace(
            live=live, say=said.append, by_topic={'/x': es}, conditions=Conditions([]),
            collector=None, inbox=types.SimpleNamespace(take=lambda: batches.pop(0)))
        for _ in range(3):
            Runner.drain(fake)
        return said, es
    said, es = runner(True)
    assert said == ['decided PASS up: ' + es[0].verdict.line().split(': ', 1)[1],
                    'decided FAIL low: ' + es[1].verdict.line().split(': ', 1)[1]]
    assert es[0].verdict.t == 0.2 and es[1].verdict.t == 0.3 and es[2].verdict is None
    assert runner(False)[0] == []
