"""procs.Core with real processes: the run's own rosmaster and rosout, started directly.
The master answers with its own pid, /use_sim_time and roscore's parameters are set before
rosout starts, rosout serves /rosout_agg but takes no /clock, a node on that master gets
sim time, and ``kill`` leaves neither process behind."""
import os
import time

import pytest

from testing_instance import procs

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
