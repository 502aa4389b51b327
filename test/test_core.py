"""procs.Core with real processes: the run's own rosmaster and rosout, started directly.
The master answers with its own pid, /use_sim_time and roscore's parameters are set before
rosout starts, rosout serves /rosout_agg but takes no /clock, a node on that master gets
sim time, and ``kill`` leaves neither process behind."""
import os
import time

import pytest

from testing_instance.world import procs

pytestmark = pytest.mark.rostest


def test_a_core_of_its_own_with_sim_time_and_a_rosout_without_it(tmp_path):
    import rosgraph
    port = procs.free_port()
    env = procs.ros_env(str(tmp_path / 'log'), port)
    core = procs.Core(port, env, str(tmp_path))
    try:
        m = rosgraph.Master('/test_core', master_uri=env['ROS_MASTER_URI'])
        assert core.wait_up(m, time.monotonic() + 30.0), procs.tail(core.master.log_path)
        assert m.getPid() == core.master.p.pid
        core.up(m)
        assert m.getParam('/use_sim_time') is True
        assert m.getParam('/rosdistro').endswith('\n')
        assert m.getParam('/rosversion').strip().count('.') == 2
        assert m.getParam('/run_id')

        def rosout():
            pubs = m.getSystemState()[0]
            return any(t == '/rosout_agg' and '/rosout' in ns for t, ns in pubs)
        assert procs.poll(rosout, time.monotonic() + 30.0, first=0.005), \
            procs.tail(core.rosout.log_path)
        # a node that reads /use_sim_time (as every node of the run does) is on /clock;
        # rosout, started after it was set, is not
        node = procs.Proc(['rostopic', 'echo', '-n', '1', '/clock'], env,
                          str(tmp_path / 'echo.log'))

        def on_clock():
            subs = m.getSystemState()[1]
            return [ns for t, ns in subs if t == '/clock']
        assert procs.poll(on_clock, time.monotonic() + 30.0, first=0.01)
        time.sleep(0.2)
        clock = on_clock()[0]
        assert len(clock) == 1 and clock[0].startswith('/rostopic_'), clock
        assert '/rosout' not in clock
        node.stop(grace=5.0)
        pids = [core.master.p.pid, core.rosout.p.pid]
        assert core.pids() == {procs.MASTER: pids[0]}
    finally:
        core.kill()
    assert not any(procs.alive(p) for p in pids)
    assert not core.alive()
    assert os.path.exists(str(tmp_path / 'rosmaster.log'))


def test_a_master_whose_port_is_taken_is_known_at_once_not_at_the_deadline(tmp_path):
    """rosmaster does not exit when it cannot bind its port: it prints "Unable to start
    XML-RPC server" and waits for its server for ever. wait_up sees that (another master's
    pid on the port, or that line) and returns False within seconds, so the run starts
    again on a new port instead of waiting until its deadline (the cluster sweep's lost
    120 s)."""
    import socket
    import rosgraph
    port = procs.free_port()
    env = procs.ros_env(str(tmp_path / 'log'), port)
    first = procs.Core(port, env, str(tmp_path))
    os.makedirs(str(tmp_path / 'second'))
    os.makedirs(str(tmp_path / 'third'))
    cores = [first]
    listener = socket.socket()
    try:
        m = rosgraph.Master('/test_core', master_uri=env['ROS_MASTER_URI'])
        assert first.wait_up(m, time.monotonic() + 30.0), procs.tail(first.master.log_path)
        # a second master on the first one's port
        second = procs.Core(port, env, str(tmp_path / 'second'))
        cores.append(second)
        t0 = time.monotonic()
        assert not second.wait_up(m, time.monotonic() + 60.0)
        assert second.taken == 'another master (pid %d) answers there' % first.master.p.pid
        assert second.alive()
        assert time.monotonic() - t0 < 10.0
        # a port held by something that is not a master: the rosmaster's own line
        listener.bind(('', 0))
        listener.listen(1)
        other = listener.getsockname()[1]
        third = procs.Core(other, env, str(tmp_path / 'third'))
        cores.append(third)
        m3 = rosgraph.Master('/test_core', master_uri='http://localhost:%d' % other)
        t0 = time.monotonic()
        assert not third.wait_up(m3, time.monotonic() + 60.0)
        assert third.taken == third.port_taken() == \
            'Unable to start XML-RPC server, port %d is already in use' % other
        assert time.monotonic() - t0 < 15.0
        assert any('already in use' in line for line in third.log_tail())
    finally:
        listener.close()
        for c in cores:
            c.kill()
    assert not any(c.alive() for c in cores)


def test_a_run_whose_master_port_is_taken_starts_again_on_another(tmp_path):
    """run_scenario handed a port another master holds (two jobs that picked the same port
    at once): its master cannot bind, the run sees that at once and starts a master on a new
    port, and the scenario passes within seconds (it used to be an ERROR "no ROS master ...
    after 300 s" after 120 s of waiting)."""
    import subprocess
    import sys
    import rosgraph
    from fixtures.scenario_cli import EX, NODE, scenario_env
    port = procs.free_port()
    env = procs.ros_env(str(tmp_path / 'log'), port)
    holder = procs.Core(port, env, str(tmp_path))
    try:
        m = rosgraph.Master('/test_core', master_uri=env['ROS_MASTER_URI'])
        assert holder.wait_up(m, time.monotonic() + 30.0)
        t0 = time.monotonic()
        p = subprocess.run(
            [sys.executable, os.path.join(os.path.dirname(__file__), 'fixtures',
                                          'taken_port_run.py'), str(port), NODE,
             os.path.join(EX, 'compass_declination.yaml')],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300,
            env=scenario_env())
        wall = time.monotonic() - t0
        assert p.returncode == 0, p.stdout
        assert 'PASS points_to_true_north' in p.stdout
        assert wall < 60.0, (wall, p.stdout)
        # the holder's master saw no node of the run
        nodes = {n for _t, ns in m.getSystemState()[0] for n in ns}
        assert nodes <= {'/rosout'}, nodes
    finally:
        holder.kill()
