"""Raw sockets against the world's TCPROS server (issue 19 item 3): silent connections, half
headers, a header announcing 4 GB, a subscriber that half-closes and never reads, garbage, a
wrong md5sum, headers cut short, service requests of garbage or a huge length, many at once
(test/fixtures/tcpros_abuse.py; the endpoints come from the master's lookupNode, the node's
requestTopic and lookupService). Meanwhile a proper rospy client
(test/fixtures/tcpros_monitor.py) keeps receiving /clock and the IMU and calling
/gazebo/get_model_state (a new connection per call) at >= 50 % of the rate it had before the
abuse, and a subscriber that connects during the abuse gets its first message within 5 s.

Found: rospy reads a connection's header in its accept loop (TCPServer.run ->
TCPROSServer._tcp_server_callback -> read_ros_handshake_header, blocking, no timeout), so
one client that connects and says nothing stalls every later subscriber and every service
call of the node. sim_world.transport.tcpros_guard reads each header on its own thread, with a
timeout and a size bound."""
import json
import os
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from fixtures.rosworld import node_pid, office_world  # noqa: E402
from fixtures.tcpros_abuse import Abuse, endpoints  # noqa: E402

MONITOR = os.path.join(HERE, 'fixtures', 'tcpros_monitor.py')
PHASE = float(os.environ.get('MDS_FUZZ_TCPROS_PHASE', '4'))

pytestmark = pytest.mark.rostest


def measure_under_abuse(env, phase, seed=1):
    """(baseline, during, abuse counts) of one monitor run with the abuse in its 2nd phase."""
    mon = subprocess.Popen([sys.executable, MONITOR, str(phase)], env=env,
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    abuse = None
    try:
        line = mon.stdout.readline()
        assert line.startswith('BASELINE '), (line, mon.stderr.read()[-3000:]
                                              if mon.poll() is not None else '')
        base = json.loads(line.split(' ', 1)[1])
        abuse = Abuse(endpoints(env['ROS_MASTER_URI']), seed=seed).start()
        time.sleep(0.5)                    # the held connections are in place
        mon.stdin.write('go\n')
        mon.stdin.flush()
        line = mon.stdout.readline()
        assert line.startswith('ABUSE '), (line, mon.stderr.read()[-3000:])
        during = json.loads(line.split(' ', 1)[1])
        mon.wait(30)
    finally:
        if abuse is not None:
            abuse.stop()
        if mon.poll() is None:
            mon.kill()
            mon.wait()
    return base, during, (dict(abuse.counts) if abuse else {})


def test_raw_socket_abuse_does_not_stall_the_world(tmp_path):
    with office_world(tmp_path) as env:
        pid = node_pid(env, '/sim_world')
        base, during, counts = measure_under_abuse(env, PHASE)
        print('baseline', base)
        print('during abuse', during)
        print('abuse connections', counts)
        assert all(counts[k] > 0 for k in Abuse.KINDS), counts
        for k in ('clock_per_s', 'imu_per_s', 'calls_per_s'):
            assert base[k] > 0, base
            assert during[k] >= 0.5 * base[k], (k, base, during)
        assert during['new_subscriber_first_message_s'] is not None, during
        assert during['new_subscriber_first_message_s'] < 5.0, during
        assert node_pid(env, '/sim_world') == pid
        os.kill(pid, 0)
