"""sim_world.transport (fastpub before issue 45) under a real roscore: a publisher (as the
camera's image_raw and sim_world's /clock use it) serves a remote rospy subscriber every
message intact, hands a subscriber in its own node the very message objects (no serialization, no socket), respects that
subscriber's queue, and drops the local connection once the subscriber unregisters (so the
camera stops rendering for nobody)."""
import json
import os
import subprocess
import sys
import textwrap
import time

import pytest
from sim_world.netutil import master_port  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PUBLISHER = textwrap.dedent('''
    import json, sys, time, threading
    sys.path.insert(0, %(src)r)
    import rospy
    from sensor_msgs.msg import Image
    from sim_world import transport
    rospy.init_node('fastpub_probe', disable_signals=True)
    pub = transport.publisher('/probe', Image, queue_size=50)
    sent, got, got_slow = [], [], []
    sub = rospy.Subscriber('/probe', Image, lambda m: got.append(m), queue_size=100)
    # a slow local subscriber with queue 1 on a second topic: sees only the newest
    pub2 = transport.publisher('/probe_slow', Image, queue_size=10)
    gate = threading.Event()
    def slow(m):
        gate.wait(10)
        got_slow.append(int(m.data[0]))
    sub2 = rospy.Subscriber('/probe_slow', Image, slow, queue_size=1)
    # inline_local (sim_world's /clock): the callback runs in the publishing thread
    pub3 = transport.publisher('/probe_inline', Image, queue_size=10, inline_local=True)
    inline_threads = []
    sub3 = rospy.Subscriber('/probe_inline', Image,
                            lambda m: inline_threads.append(threading.current_thread().name))
    # deliver_inline (an embedded world's runner): one callback of a topic in the publishing
    # thread, the other one's in the delivery thread; unstamped messages timed by sim time
    from std_msgs.msg import String
    me = rospy.get_caller_id()
    clock = [0.0]
    transport.set_sim_clock(lambda: clock[0])
    transport.take_times(me)
    pub4 = transport.publisher('/probe_mixed', String, queue_size=10)
    mixed_inline, mixed_thread = [], []
    def cb_inline(m):
        mixed_inline.append((m.data, threading.current_thread().name))
    def cb_thread(m):
        mixed_thread.append((m.data, threading.current_thread().name))
    transport.deliver_inline(cb_inline)
    sub4a = rospy.Subscriber('/probe_mixed', String, cb_inline)
    sub4b = rospy.Subscriber('/probe_mixed', String, cb_thread)
    deadline = time.time() + 30
    while (pub.get_num_connections() < 2 or pub2.get_num_connections() < 1
           or pub3.get_num_connections() < 1 or pub4.get_num_connections() < 1) and \
            time.time() < deadline:
        time.sleep(0.05)
    for i in range(5):
        clock[0] = 0.5 * i
        pub4.publish(String('m%%d' %% i))
    mixed_inline_now = len(mixed_inline)
    mixed_times = transport.take_times(me).get('/probe_mixed')
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
    counts = transport.handed_to(me)
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
                          inline=inline_threads, me=threading.current_thread().name,
                          counts=counts, mixed_inline=mixed_inline,
                          mixed_inline_now=mixed_inline_now, mixed_thread=mixed_thread,
                          mixed_times=mixed_times, other=transport.handed_to('/someone_else'))),
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
    port = master_port()
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
    # this node's own subscribers are counted as a remote one is (the slice handshake of
    # an embedded world): handed, and of those dropped by the subscriber's full queue
    assert res['counts']['/probe'] == [40, 0]
    assert res['counts']['/probe_slow'] == [40, 40 - len(res['slow'])], res
    assert res['counts']['/probe_mixed'] == [5, 0]
    assert '/probe' not in res['other']             # only this node's own are local
    # deliver_inline: that callback had every message before publish() returned, in the
    # publishing thread; the topic's other callback in the delivery thread, in order
    assert res['mixed_inline_now'] == 5
    assert res['mixed_inline'] == [['m%d' % i, res['me']] for i in range(5)]
    assert [d for d, _t in res['mixed_thread']] == ['m%d' % i for i in range(5)]
    assert all(t.startswith('local delivery') for _d, t in res['mixed_thread'])
    assert res['mixed_times'] == [0.0, 0.5, 1.0, 1.5, 2.0]   # the sim time at hand-over
    got = json.loads(rout.strip().splitlines()[-1])
    assert got == [['f%d' % i, [i, 1, 2, 3]] for i in range(40)], rerr[-2000:]


LOCAL_ONLY = textwrap.dedent('''
    import json, sys, time
    sys.path.insert(0, %(src)r)
    import rospy
    import rospy.topics
    from sensor_msgs.msg import Imu
    from sim_world import transport
    serialized = []
    real = rospy.topics.serialize_message
    def counting(b, seq, msg):
        serialized.append(seq)
        return real(b, seq, msg)
    rospy.topics.serialize_message = counting
    rospy.init_node('fastpub_local_only', disable_signals=True)
    pub = transport.publisher('/local_only', Imu, queue_size=50)
    got = []
    sub = rospy.Subscriber('/local_only', Imu, lambda m: got.append(m), queue_size=100)
    deadline = time.time() + 30
    while pub.get_num_connections() < 1 and time.time() < deadline:
        time.sleep(0.05)
    sent = []
    for i in range(20):
        m = Imu()
        m.header.frame_id = None if i %% 2 else 'imu'
        sent.append(m)
        pub.publish(m)
    deadline = time.time() + 10
    while len(got) < 20 and time.time() < deadline:
        time.sleep(0.05)
    print(json.dumps(dict(serialized=len(serialized), got=len(got),
                          same=sum(1 for a, b in zip(sent, got) if a is b),
                          seq=[m.header.seq for m in got],
                          frames=[m.header.frame_id for m in got],
                          counts=transport.handed_to(rospy.get_caller_id()))), flush=True)
''')


def test_a_topic_only_this_node_subscribes_is_not_serialized(roscore):
    """Messages only this node's own subscribers get (an embedded world's runner) are
    handed over without rospy serializing them for its loopback connection, and carry
    the header rospy's publish would have given them: the topic's sequence number, and
    '0' for a frame_id of None (recordings the same as through the world node)."""
    p = subprocess.run([sys.executable, '-c',
                        LOCAL_ONLY % dict(src=os.path.join(ROOT, 'sim_world', 'src'))],
                       env=roscore, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr[-3000:]
    res = json.loads(p.stdout.strip().splitlines()[-1])
    assert res['got'] == 20 and res['same'] == 20
    assert res['serialized'] == 0
    assert res['seq'] == list(range(1, 21))
    assert res['frames'] == ['imu', '0'] * 10
    assert res['counts']['/local_only'] == [20, 0]
