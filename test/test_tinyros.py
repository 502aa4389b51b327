"""tinyros_android: the C ROS subscriber, its C tests, sanitizers, fuzzers, and
integration with a real roscore.

  * ctest of the C unit tests from the catkin build (tools/setup);
  * the same C tests built with AddressSanitizer + UndefinedBehaviorSanitizer in
    build/tinyros-asan, whose tinyros_echo also faces the hostile publisher;
  * libFuzzer targets (header, XML-RPC, Image) built with clang in build/tinyros-fuzz
    (fixtures/libfuzzer.py), each run for $MDS_FUZZ_SECONDS (default 3) from the seed
    corpus in the repo; bench/fuzz runs them for 5 minutes each (--only libfuzzer);
  * a real roscore on a free port: frames from a rospy and a roscpp publisher arrive
    byte-identical, a killed and restarted publisher resumes (publisherUpdate), an
    absent master is one clear error, a hostile publisher is survived.
Cost: about 1 minute on 2 cores, 9 s of which are fuzzing (MDS_FUZZ_SECONDS=3; the suite
checks the fuzzers run and find nothing in a short run, bench/fuzz does the long runs).
"""
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import xmlrpc.client

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = os.environ.get('MDS_BUILD', os.path.join(ROOT, 'build'))
BIN = os.path.join(BUILD, 'devel', 'lib', 'mobile_device_sim')
ECHO = os.path.join(BIN, 'tinyros_echo')
PEER = os.path.join(BIN, 'tinyros_roscpp_peer')
CTEST_DIR = os.path.join(BUILD, 'cmake', 'tinyros_android')
ASAN_DIR = os.path.join(BUILD, 'tinyros-asan')
FUZZ_SECONDS = int(os.environ.get('MDS_FUZZ_SECONDS', '3'))
PUB_PY = os.path.join(HERE, 'tinyros', 'image_pub.py')

sys.path.insert(0, os.path.join(HERE, 'tinyros'))
import hostile_publisher as hp  # noqa: E402
from sim_world.netutil import free_port as _free_port, master_port  # noqa: E402
from fixtures import libfuzzer  # noqa: E402

FRAME_RE = re.compile(r'^frame seq=(\d+) stamp=\S+ frame_id=(\S*) (\d+)x(\d+) (\S+) be=(\d) step=(\d+) '
                      r'bytes=(\d+) crc32=([0-9a-f]{8})$')
SANITIZER_RE = re.compile(r'AddressSanitizer|runtime error:|LeakSanitizer|UndefinedBehaviorSanitizer')


def _run(cmd, timeout=600, **kw):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout, **kw)


class Proc:
    """A background process whose stdout lines are collected by a thread."""

    def __init__(self, cmd, env, stderr_separate=True):
        self.p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE if stderr_separate else subprocess.STDOUT,
                                  text=True, start_new_session=True)
        self.lines, self.err = [], []
        self._t = [threading.Thread(target=self._pump, args=(self.p.stdout, self.lines), daemon=True)]
        if stderr_separate:
            self._t.append(threading.Thread(target=self._pump, args=(self.p.stderr, self.err), daemon=True))
        for t in self._t:
            t.start()

    @staticmethod
    def _pump(stream, out):
        for line in stream:
            out.append(line.rstrip('\n'))

    def wait_for(self, pred, timeout):
        end = time.time() + timeout
        while time.time() < end:
            if pred(list(self.lines)):
                return True
            if self.p.poll() is not None:
                time.sleep(0.2)
                return pred(list(self.lines))
            time.sleep(0.05)
        return False

    def stop(self, sig=signal.SIGTERM, timeout=10):
        if self.p.poll() is None:
            try:
                os.killpg(self.p.pid, sig)
            except ProcessLookupError:
                pass
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, signal.SIGKILL)
                self.p.wait(5)
        for t in self._t:
            t.join(5)
        return self.p.returncode

    def wait(self, timeout):
        try:
            rc = self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            self.stop(signal.SIGKILL)
            pytest.fail('%s did not finish within %d s\nstdout:\n%s\nstderr:\n%s' % (
                self.p.args, timeout, '\n'.join(self.lines[-20:]), '\n'.join(self.err[-20:])))
        for t in self._t:
            t.join(5)
        return rc


def _frames(lines):
    return [m.groups() for m in (FRAME_RE.match(x) for x in lines) if m]


def _pub_crcs(lines):
    out = {}
    for x in lines:
        parts = x.split()
        if len(parts) == 3 and parts[0] == 'pub':
            out[int(parts[1])] = parts[2]
    return out


# ---- builds -------------------------------------------------------------------------------
def test_ctest_catkin_build():
    """C unit tests (XML-RPC, TCPROS header, Image decoding, NV21) from the catkin build."""
    assert os.path.isfile(os.path.join(CTEST_DIR, 'CTestTestfile.cmake')), 'run tools/setup first'
    r = _run(['ctest', '--test-dir', CTEST_DIR, '--output-on-failure'], timeout=120)
    assert r.returncode == 0, r.stdout[-6000:]
    assert re.search(r'100% tests passed, 0 tests failed out of [1-9]', r.stdout), r.stdout[-3000:]


def _cmake_build(build_dir, *defs, targets=()):
    try:
        libfuzzer.cmake_build(build_dir, *defs, targets=targets)
    except libfuzzer.BuildError as e:
        pytest.fail(str(e))


@pytest.fixture(scope='module')
def asan_build():
    _cmake_build(ASAN_DIR, '-DTINYROS_SANITIZE=ON')
    return ASAN_DIR


def test_ctest_under_asan_ubsan(asan_build):
    """The C tests again, with AddressSanitizer + UndefinedBehaviorSanitizer (abort on any report)."""
    env = dict(os.environ, ASAN_OPTIONS='detect_leaks=1:abort_on_error=1',
               UBSAN_OPTIONS='halt_on_error=1:print_stacktrace=1')
    r = _run(['ctest', '--test-dir', asan_build, '--output-on-failure'], timeout=300, env=env)
    assert r.returncode == 0, r.stdout[-6000:]
    assert '100% tests passed' in r.stdout
    assert not SANITIZER_RE.search(r.stdout), r.stdout[-6000:]


@pytest.fixture(scope='module')
def fuzz_build():
    try:
        return libfuzzer.build()
    except libfuzzer.BuildError as e:
        pytest.fail(str(e))


@pytest.mark.slow
@pytest.mark.parametrize('target', libfuzzer.TARGETS)
def test_fuzz(fuzz_build, target):
    """libFuzzer (with ASan+UBSan) on one parser for MDS_FUZZ_SECONDS from the repo's seed corpus."""
    assert len(os.listdir(libfuzzer.seeds(target))) >= 3
    r = libfuzzer.run(target, FUZZ_SECONDS)
    assert r.returncode == 0, r.tail
    assert not r.crashes, 'crash inputs %s\n%s' % (r.crashes, r.tail)
    assert r.executions > 1000, r.tail


# ---- a real roscore ---------------------------------------------------------------------------
@pytest.fixture(scope='module')
def master():
    assert os.path.isfile(ECHO), 'tinyros_echo is not built: run tools/setup'
    port = master_port()
    uri = 'http://localhost:%d/' % port
    env = dict(os.environ, ROS_MASTER_URI=uri, ROS_HOSTNAME='localhost')
    core = subprocess.Popen(['roscore', '-p', str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    proxy = xmlrpc.client.ServerProxy(uri)
    end = time.time() + 30
    while True:
        try:
            proxy.getPid('/test')
            break
        except OSError:
            if time.time() > end or core.poll() is not None:
                core.kill()
                pytest.fail('roscore -p %d did not come up' % port)
            time.sleep(0.2)
    yield env
    os.killpg(core.pid, signal.SIGINT)
    try:
        core.wait(15)
    except subprocess.TimeoutExpired:
        os.killpg(core.pid, signal.SIGKILL)
        core.wait(5)


def _rospy_pub(env, topic, *args):
    return Proc([sys.executable, PUB_PY, topic] + list(args), env)


def _check_identical(echo_lines, pub_lines, shape, min_frames):
    frames = _frames(echo_lines)
    crcs = _pub_crcs(pub_lines)
    assert len(frames) >= min_frames, echo_lines[-10:]
    for seq, frame_id, w, h, enc, be, step, nbytes, crc in frames:
        assert (int(w), int(h), enc) == shape
        assert int(step) * int(h) == int(nbytes)
        assert frame_id.startswith('frame_'), frame_id
        i = int(frame_id[6:])
        assert i in crcs, 'frame %d was never published' % i
        assert crc == crcs[i], 'frame %d: received crc %s, published %s' % (i, crc, crcs[i])


def _echo_20_frames_byte_identical(master, pub, topic, shape):
    """tinyros echoes 20 frames of ``topic``, each byte-identical to one ``pub`` (stopped
    after) published."""
    try:
        echo = Proc([ECHO, topic, '-v', '-q', '-n', '20', '-t', '30'], master)
        rc = echo.wait(40)
    finally:
        pub.stop()
    assert rc == 0, echo.err
    _check_identical(echo.lines, pub.lines, shape, 20)


def test_rospy_frames_byte_identical(master):
    pub = _rospy_pub(master, '/tr_rospy', '--width', '160', '--height', '120', '--rate', '30')
    _echo_20_frames_byte_identical(master, pub, '/tr_rospy', (160, 120, 'rgb8'))


def test_roscpp_frames_byte_identical(master):
    if not os.path.isfile(PEER):
        pytest.fail('tinyros_roscpp_peer is not built although libroscpp-dev is a dependency')
    pub = Proc([PEER, 'pub', '/tr_roscpp', '--width', '640', '--height', '480', '--rate', '30'], master)
    _echo_20_frames_byte_identical(master, pub, '/tr_roscpp', (640, 480, 'rgb8'))


def test_echo_line_and_camera_shim(master, tmp_path):
    """The per-second line people read, and the camera shim's NV21 preview + takePicture JPEG."""
    jpg = str(tmp_path / 'picture.jpg')
    pub = _rospy_pub(master, '/tr_line', '--width', '160', '--height', '120', '--rate', '30')
    try:
        echo = Proc([ECHO, '/tr_line', '-t', '3.5', '--nv21', '320x240', '--jpeg', jpg, '--stats'], master)
        rc = echo.wait(30)
    finally:
        pub.stop()
    assert rc == 0, echo.err
    per_second = [x for x in echo.lines if re.match(r'^160x120 rgb8 \d+\.\d fps$', x)]
    assert len(per_second) >= 2, echo.lines
    stats = [x for x in echo.lines if x.startswith('stats ')]
    assert stats and int(re.search(r'frames=(\d+)', stats[0]).group(1)) > 0
    from PIL import Image
    with Image.open(jpg) as im:
        assert im.format == 'JPEG' and im.size == (160, 120)


def test_publisher_killed_and_restarted(master):
    """SIGKILL the publisher, start another under the same name with another size:
    the master's publisherUpdate brings tinyros to the new one."""
    env = dict(master)
    pub1 = _rospy_pub(env, '/tr_restart', '--width', '64', '--height', '48', '--rate', '30',
                      '__name:=tr_restart_pub')
    echo = Proc([ECHO, '/tr_restart', '-v', '-q', '-t', '40', '-n', '100000'], env)
    pub2 = None
    try:
        assert echo.wait_for(lambda ls: len(_frames(ls)) >= 10, 20), echo.err
        pub1.stop(signal.SIGKILL)
        n_before = len(_frames(echo.lines))
        pub2 = _rospy_pub(env, '/tr_restart', '--width', '80', '--height', '60', '--rate', '30',
                          '__name:=tr_restart_pub')
        assert echo.wait_for(lambda ls: sum(1 for f in _frames(ls) if f[2] == '80') >= 10, 25), \
            'no frames after the restart\n' + '\n'.join(echo.err[-10:])
    finally:
        echo.stop(signal.SIGINT)
        if pub2:
            pub2.stop()
        pub1.stop()
    frames = _frames(echo.lines)
    shapes = [f[2] for f in frames]
    assert shapes[:n_before] == ['64'] * n_before
    assert shapes[-1] == '80' and '64' not in shapes[shapes.index('80'):]
    crcs2 = _pub_crcs(pub2.lines)
    for f in frames[shapes.index('80'):]:
        assert f[8] == crcs2[int(f[1][6:])]
    assert sum('subscribed to /tr_restart from' in x for x in echo.err) >= 2, echo.err
    assert echo.p.returncode == 0, echo.err


def test_rosrun_finds_tinyros_echo():
    """`rosrun mobile_device_sim tinyros_echo` reaches the compiled program (through the relay
    in tinyros_android/nodes/, since rosrun skips the package's build/ folder)."""
    r = _run(['rosrun', 'mobile_device_sim', 'tinyros_echo', '--help', '__name:=ignored'], timeout=60)
    assert r.returncode == 0, r.stdout
    assert r.stdout.startswith('usage: tinyros_echo'), r.stdout


def test_master_absent_is_one_clear_error():
    port = _free_port()
    r = _run([ECHO, '--master', 'http://127.0.0.1:%d/' % port, '/tr_nomaster', '-t', '5'], timeout=20)
    assert r.returncode == 1
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1, lines
    assert 'cannot register /tr_nomaster at the ROS master http://127.0.0.1:%d/' % port in lines[0]
    assert 'Connection refused' in lines[0]
    r = _run([ECHO, '--master', 'ftp://somewhere/', '/x'], timeout=20)
    assert r.returncode == 1 and 'bad ROS master URI' in r.stdout and 'http://' in r.stdout


EXPECTED_ERRORS = [
    'requestTopic: XML-RPC parse error',
    'requestTopic: XML-RPC fault: hostile fault',
    'requestTopic answered no usable ["TCPROS", host, port]',
    'wrong md5sum 0123456789abcdef0123456789abcdef',
    'publisher refused the connection: hostile says no',
    "TCPROS header: field without '='",
    'connection header length 2147483647 exceeds the limit',
    'message length 4294967280 exceeds the limit of 16777216 bytes',
    'connection closed mid-frame (10 of 1000 bytes received)',
    'dropped a bad frame: Image:',
]


@pytest.mark.parametrize('build', ['release', 'asan'])
def test_hostile_publisher(master, build, request):
    """Garbage XML-RPC, faults, wrong protocol, wrong md5, refusal, garbage and huge headers,
    a 4 GiB frame length, a truncated frame, a garbage frame: one clear error line each,
    no crash, and the valid frames that follow arrive byte-identical."""
    echo_bin = ECHO
    env = dict(master)
    if build == 'asan':
        echo_bin = os.path.join(request.getfixturevalue('asan_build'), 'tinyros_echo')
        env.update(ASAN_OPTIONS='detect_leaks=1:abort_on_error=1', UBSAN_OPTIONS='halt_on_error=1')
    topic = '/tr_hostile_' + build
    pub = hp.HostilePublisher(env['ROS_MASTER_URI'], topic, hp.HOSTILE_RPC, hp.HOSTILE_TCP,
                              caller_id='/hostile_pub_' + build)
    try:
        echo = Proc([echo_bin, topic, '-v', '-q', '-n', '5', '-t', '60', '--retry-ms', '100',
                     '--max-bytes', str(16 << 20)], env)
        rc = echo.wait(90)
    finally:
        pub.close()
    err = '\n'.join(echo.err)
    assert rc == 0, 'exit %s\n%s' % (rc, err[-6000:])
    assert not SANITIZER_RE.search(err), err[-6000:]
    for e in EXPECTED_ERRORS:
        assert e in err, 'missing error %r in\n%s' % (e, err)
    for line in echo.err:                      # one line per event, each names the publisher
        if 'ERROR' in line and 'publisher' in line:
            assert pub.uri in line, line
    frames = _frames(echo.lines)
    assert len(frames) == 5
    for f in frames:
        assert f[8] in pub.sent_crcs and f[1].startswith('valid_')
    assert pub.tcp_connections[:len(hp.HOSTILE_TCP)] == [name for name, _ in hp.HOSTILE_TCP]


def _raw_http(uri, payload, timeout=5):
    host, port = uri[len('http://'):].rstrip('/').rsplit(':', 1)
    with socket.create_connection((host, int(port)), timeout=timeout) as c:
        c.sendall(payload)
        c.shutdown(socket.SHUT_WR)
        data = b''
        while True:
            chunk = c.recv(65536)
            if not chunk:
                return data
            data += chunk


def test_slave_api_and_bad_requests(master):
    """The node's own XML-RPC server: the slave API calls rosnode/rostopic and the master
    use, and garbage requests each logged once while frames keep flowing."""
    pub = _rospy_pub(master, '/tr_slave', '--width', '32', '--height', '24', '--rate', '30')
    echo = Proc([ECHO, '/tr_slave', '-v', '-q', '-t', '40', '--caller-id', '/tr_slave_echo'], master)
    try:
        assert echo.wait_for(lambda ls: len(_frames(ls)) >= 3, 20), echo.err
        master_proxy = xmlrpc.client.ServerProxy(master['ROS_MASTER_URI'])
        code, _, node_uri = master_proxy.lookupNode('/test', '/tr_slave_echo')
        assert code == 1 and node_uri.startswith('http://localhost:')
        node = xmlrpc.client.ServerProxy(node_uri)
        assert node.getPid('/test') == [1, '', echo.p.pid]
        assert node.getSubscriptions('/test')[2] == [['/tr_slave', 'sensor_msgs/Image']]
        assert node.getPublications('/test')[2] == []
        assert node.getMasterUri('/test')[2] == master['ROS_MASTER_URI']
        bus = node.getBusInfo('/test')[2]
        assert len(bus) == 1 and bus[0][3] == 'TCPROS' and bus[0][4] == '/tr_slave'
        assert node.publisherUpdate('/test', '/other_topic', [])[0] == 0
        assert node.publisherUpdate('/test', '/tr_slave', 'not a list')[0] == -1
        assert node.noSuchMethod('/test')[0] == -1
        # garbage on the wire: no answer or an error answer, never a dead node
        _raw_http(node_uri, b'\x00\xff garbage\r\n\r\n')
        _raw_http(node_uri, b'POST / HTTP/1.0\r\nContent-Length: 99999999\r\n\r\n')
        ans = _raw_http(node_uri, b'POST / HTTP/1.0\r\nContent-Length: 14\r\n\r\n<methodCall/>x')
        assert b'<int>-1</int>' in ans
        n = len(_frames(echo.lines))
        assert node.getPid('/test')[2] == echo.p.pid
        assert echo.wait_for(lambda ls: len(_frames(ls)) >= n + 10, 10), 'frames stopped after bad requests'
    finally:
        echo.stop(signal.SIGINT)
        pub.stop()
    assert echo.p.returncode == 0
    warns = [x for x in echo.err if 'XML-RPC server' in x]
    assert any('not an HTTP POST request' in x for x in warns), echo.err
    assert any('larger than' in x for x in warns), echo.err
    assert any('XML-RPC parse error' in x for x in warns), echo.err
    assert any('unknown method noSuchMethod' in x for x in warns), echo.err
    assert any('publisherUpdate with bad parameters' in x for x in echo.err), echo.err
