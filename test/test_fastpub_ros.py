"""sim_world.fastpub under a real roscore: a publisher (as the camera's image_raw and sim_world's
/clock use it) serves a remote rospy subscriber every message intact, hands a subscriber in
its own node the very message objects (no serialization, no socket), respects that
subscriber's queue, and drops the local connection once the subscriber unregisters (so the
camera stops rendering for nobody)."""
import json
import os
import subprocess
import sys
import textwrap
import time

import pytest
from sim_world.netutil import free_port as _free_port  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PUBLISHER = textwrap.dedent('''
    import json, sys, time, threading
    sys.path.insert(0, %(src)r)
    import rospy
    from sensor_msgs.msg import Image
    from sim_world import fastpub
    rospy.init_node('fastpub_probe', disable_signals=True)
    pub = fastpub.publisher('/probe', Image, queue_size=50)
    sent, got, got_slow = [], [], []
    sub = rospy.Subscriber('/probe', Image, lambda m: got.append(m), queue_size=100)
    # a slow local subscriber with queue 1 on a second topic: sees only the newest
    pub2 = fastpub.publisher('/probe_slow', Image, queue_size=10)
    gate = threading.Event()
    def slow(m):
        gate.wait(10)
        got_slow.append(int(m.data[0]))
    sub2 = rospy.Subscriber('/probe_slow', Image, slow, queue_size=1)
    # inline_local (sim_world's /clock): the callback runs in the publishing thread
    pub3 = fastpub.publisher('/probe_inline', Image, queue_size=10, inline_local=True)
    inline_threads = []
    sub3 = rospy.Subscriber('/probe_inline', Image,
                            lambda m: inline_threads.append(threading.current_thread().name))
    deadline = time.time() + 30
    while (pub.get_num_connections() < 2 or pub2.get_num_connections() < 1
           or pub3.get_num_connections() < 1) and time.time() < deadline:
        time.sleep(0.05)
    conns_before = pub.get_num_connections()
    for i in range(40):
        m = Image(height=1, width=4, encoding='mono8', step=4, data=bytes([i, 1, 2, 3]))
        m.header.frame_id = 'f%%d' %% i
        sent.append(m)
        pub.publish(m)
        pub2.publish(m)
        pub3.publish(m)
        time.sleep(0.01)
    deadline = time.time() + 10
    while len(got) < 40 and time.time() < deadline:
        time.sleep(0.05)
    gate.set()
    time.sleep(0.5)
    same = sum(1 for a, b in zip(sent, got) if a is b)
    sub.unregister()
    time.sleep(0.5)
    for i in range(3):                      # the first publish finds the subscriber gone
        pub.publish(Image(height=1, width=1, encoding='mono8', step=1, data=b'x'))
        time.sleep(0.2)
    print(json.dumps(dict(conns_before=conns_before, local=len(got), same_objects=same,
                          order=[m.header.frame_id for m in got] == ['f%%d' %% i for i in range(40)],
                          slow=got_slow, conns_after=pub.get_num_connections(),
                          inline=inline_threads, me=threading.current_thread().name)),
          flush=True)
    time.sleep(2.0)
''')

REMOTE = textwrap.dedent('''
    import json, sys, time
    import rospy
    from sensor_msgs.msg import Image
    got = []
    rospy.init_node('fastpub_remote', disable_signals=True)
    rospy.Subscriber('/probe', Image, lambda m: got.append((m.header.frame_id, list(m.data))),
                     queue_size=100)
    deadline = time.time() + 60
    while len(got) < 40 and time.time() < deadline:
        time.sleep(0.05)
    print(json.dumps(got[:40]), flush=True)
    time.sleep(8.0)                          # stay connected while the publisher checks
''')


@pytest.fixture
def roscore():
    port = _free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port,
               ROS_HOSTNAME='localhost')
    core = subprocess.Popen(['roscore', '-p', str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    import xmlrpc.client
    deadline = time.time() + 60
    while True:
        try:
            xmlrpc.client.ServerProxy(env['ROS_MASTER_URI']).getPid('/t')
            break
        except OSError:
            if time.time() > deadline:
                core.kill()
                pytest.fail('roscore did not start')
            time.sleep(0.2)
    yield env
    core.terminate()
    try:
        core.wait(15)
    except subprocess.TimeoutExpired:
        core.kill()


def test_local_objects_remote_bytes_and_cleanup(roscore):
    remote = subprocess.Popen([sys.executable, '-c', REMOTE], env=roscore,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pub = subprocess.Popen([sys.executable, '-c',
                            PUBLISHER % dict(src=os.path.join(ROOT, 'sim_world', 'src'))],
                           env=roscore, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True)
    try:
        out, err = pub.communicate(timeout=120)
        rout, rerr = remote.communicate(timeout=60)
    finally:
        for p in (pub, remote):
            if p.poll() is None:
                p.kill()
    assert pub.returncode == 0, err[-3000:]
    res = json.loads(out.strip().splitlines()[-1])
    assert res['conns_before'] == 2                 # the remote node and the local subscriber
    assert res['local'] == 40 and res['order']
    assert res['same_objects'] == 40                # handed over as objects, not re-read
    # queue_size 1 of the slow local subscriber: while its callback blocked on the first
    # message, later ones replaced each other; it got the first and the newest
    assert res['slow'][0] == 0 and res['slow'][-1] == 39 and len(res['slow']) < 10, res['slow']
    assert res['conns_after'] == 1                  # the unregistered local one was dropped
    assert res['inline'] == [res['me']] * 40        # inline_local: in the publishing thread
    got = json.loads(rout.strip().splitlines()[-1])
    assert got == [['f%d' % i, [i, 1, 2, 3]] for i in range(40)], rerr[-2000:]
