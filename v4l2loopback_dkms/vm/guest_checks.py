#!/usr/bin/env python3
"""The checks that run inside the test VM (called by guest_test.sh, as root, in the chroot).

The ROS core (rosmaster + rosout), a publisher of known frames (frames.py) and two
image_sinks start at once (the Python ones forked from this process after it imported
OpenCV and rospy once: see ``Forked``): one for the pristine module (loaded as
/dev/video5), one for /dev/video0, which does not exist until the patched module is loaded.

Phase 1, the pristine Debian module (exclusive_caps=1, max_buffers=2): image_sink with
io_method write streams, a reader stays open, a second image_sink (mmap) is refused while
the first runs (one error line) and must take over when the first stops; then a fast
writer against a slow mmap reader. Both bugs are EXPECTED to show here: that is what
proves the patches.
Phase 2, the patched DKMS module, same parameters: the no-such-device retry, formats and
rate seen by readers (v4l2-ctl --list-formats-ext), frames read back byte-exact in write
and mmap I/O (v4l2-ctl --stream-mmap, an mmap reader), OpenCV VideoCapture, the restart
with a reader open, rate and latency figures, no torn frames over 300 frames from a fast
publisher, and the fast writer against the slow reader.
Prints 'VMTEST check NAME: ok|FAIL', 'VMTEST metric NAME: VALUE', 'VMTEST RESULT: PASS|FAIL'.
"""
import glob
import os
import re
import signal
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import frames  # noqa: E402
from simvid.v4l2 import CaptureDevice, DeviceError, OutputDevice  # noqa: E402

DEV = '/dev/video0'           # the patched module
DEV_UNPATCHED = '/dev/video5'  # the pristine module
ROOT = os.path.dirname(os.path.dirname(HERE))
RUNNING = []
EXP = EXP_SMALL = None
W, H, FPS = 640, 480, 30
TW, TH = 320, 240            # tearing tests: smaller frames, many of them
PORT = 11411
TMP = '/tmp/vmtest'
T0 = time.monotonic()
RESULTS = []


def say(kind, text):
    print('VMTEST %s %s' % (kind, text), flush=True)


def check(name, ok, detail=''):
    RESULTS.append((name, bool(ok)))
    say('check', '%s: %s%s  [t=%.0fs]' % (name, 'ok' if ok else 'FAIL',
                                       (' - ' + detail) if detail else '',
                                       time.monotonic() - T0))


def note(text):
    say('note', '[t=%.0fs] %s' % (time.monotonic() - T0, text))


def metric(name, value):
    say('metric', '%s: %s' % (name, value))


class Proc(object):
    """A process of the test, its output in TMP/NAME.log. ``argv``: a command, run with
    subprocess; ``script``: a Python file, run as __main__ in a child forked from this
    process (see ``preload``) with ``args`` as its sys.argv[1:]."""

    def __init__(self, name, argv=None, script=None, args=()):
        self.name = name
        self.log = os.path.join(TMP, name + '.log')
        if script:
            self.p = Forked(script, list(args), self.log)
        else:
            self.p = subprocess.Popen(argv, stdout=open(self.log, 'w'),
                                      stderr=subprocess.STDOUT, start_new_session=True)
        RUNNING.append(self)

    def text(self):
        try:
            return open(self.log, errors='replace').read()
        except OSError:
            return ''

    def wait_for(self, pattern, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if re.search(pattern, self.text()):
                return True
            if self.p.poll() is not None:
                return bool(re.search(pattern, self.text()))
            time.sleep(0.2)
        return False

    def stop(self, timeout=15):
        if self.p.poll() is None:
            os.killpg(self.p.pid, signal.SIGINT)
            try:
                self.p.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, signal.SIGKILL)
                self.p.wait()
        return self.p.returncode


# --- forked Python processes -------------------------------------------------------------
# Under TCG a Python node's start-up is most of its cost: image_sink imports OpenCV
# (Debian's cv2 links ~360 shared libraries) and rospy, each taking the emulated guest
# tens of seconds, for every image_sink (four of them), the publisher and the master. So
# this process imports them once (``preload``) and runs each of those programs unchanged
# (the node file itself, as __main__, with its own argv, session and log) in a child forked
# from it: a separate process like the one rosrun would start, without the import cost.
# No thread runs here while a child is forked (the fast writer's thread is joined before).
def preload_ros():
    """What the publisher imports (it starts on the other CPU while OpenCV loads here)."""
    import rospy  # noqa: F401
    import sensor_msgs.msg  # noqa: F401
    import simvid.imageconv  # noqa: F401


def preload():
    """... and what image_sink imports on top."""
    preload_ros()
    import cv2  # noqa: F401
    import simvid.image_sink  # noqa: F401


class Forked(object):
    """The Popen methods Proc uses, for a forked child that runs ``script``."""

    def __init__(self, script, args, log):
        sys.stdout.flush()
        sys.stderr.flush()
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        pid = os.fork()
        if pid == 0:                                  # the child: never returns
            code = 1
            try:
                os.setsid()
                os.dup2(fd, 1)
                os.dup2(fd, 2)
                os.close(fd)
                signal.signal(signal.SIGINT, signal.default_int_handler)
                sys.argv[:] = [script] + args        # in place: rosmaster_main's default
                sys.path[0] = os.path.dirname(os.path.abspath(script))
                if 'rospy' in sys.modules:           # what a fresh import reads from argv
                    sys.modules['rospy'].names.reload_mappings(sys.argv)
                import runpy
                try:
                    runpy.run_path(script, run_name='__main__')
                    code = 0
                except SystemExit as e:
                    code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
                import atexit
                atexit._run_exitfuncs()
            except BaseException:
                import traceback
                traceback.print_exc()
            finally:
                try:
                    sys.stdout.flush()
                    sys.stderr.flush()
                finally:
                    os._exit(code)
        os.close(fd)
        self.pid, self.script, self.returncode = pid, script, None

    def poll(self):
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout=None):
        end = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if end is not None and time.monotonic() > end:
                raise subprocess.TimeoutExpired(self.script, timeout)
            time.sleep(0.05)
        return self.returncode


def module(which, device, **params):
    subprocess.call(['rmmod', 'v4l2loopback'], stderr=subprocess.DEVNULL)
    args = ['insmod', '/run/vmtest/v4l2loopback-%s.ko' % which]
    args += ['%s=%s' % kv for kv in sorted(params.items())]
    subprocess.check_call(args)
    for _ in range(50):
        if os.path.exists(device):
            return
        time.sleep(0.1)
    raise RuntimeError('%s did not appear after insmod' % device)


def sink(name, **params):
    """Start image_sink: its node file (what rosrun runs), forked from this process."""
    p = dict(device=DEV, width=W, height=H, fps=FPS)
    p.update(params)
    return Proc(name, script=os.path.join(ROOT, 'simvid', 'nodes', 'image_sink'),
                args=['__name:=%s' % name] + ['_%s:=%s' % kv for kv in sorted(p.items())])


def master_up(timeout):
    import xmlrpc.client
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            xmlrpc.client.ServerProxy(os.environ['ROS_MASTER_URI']).getPid('/vmtest')
            return True
        except OSError:
            time.sleep(1)
    return False


def set_rate(hz):
    with open(os.path.join(TMP, 'rate'), 'w') as f:
        f.write('%g\n' % hz)


def publications():
    """k -> list of monotonic publish times."""
    out = {}
    try:
        for line in open(os.path.join(TMP, 'pub.log')):
            k, t = line.split()
            out.setdefault(int(k) % frames.N, []).append(float(t))
    except (OSError, ValueError):
        pass
    return out


def start_reader(cap, timeout=30):
    """STREAMON fails (EIO) until a writer has delivered the first frame: retry."""
    end = time.monotonic() + timeout
    while True:
        try:
            return cap.start()
        except DeviceError:
            if time.monotonic() > end:
                raise
            cap.maps = []
            time.sleep(0.5)


def read_frames(exp, count, timeout, device=DEV, hold=0.0, nbuf=2):
    """mmap reader: returns a list of (class, k, read_time). ``hold``: seconds the reader
    keeps a dequeued buffer between reading its top half and the rest."""
    cap = CaptureDevice(device, buffers=nbuf)
    out = []
    try:
        start_reader(cap)
        end = time.monotonic() + timeout
        while len(out) < count and time.monotonic() < end:
            top = []

            def slow(m):
                top.append(bytes(m[:exp.half]))
                time.sleep(hold)
            try:
                data, _ = cap.read(timeout=min(2.0, max(0.1, end - time.monotonic())),
                                   hold=slow if hold else None)
            except DeviceError:
                continue
            cls, k = exp.classify(data, top[0] if top else None)
            out.append((cls, k, time.monotonic()))
    finally:
        cap.close()
    return out


def summary(reads):
    c = {}
    for cls, _, _ in reads:
        c[cls] = c.get(cls, 0) + 1
    return c


# --- helpers for the phases --------------------------------------------------------------
def take_over_with_reader_open(exp, first, second, device, keep_second=False):
    """``first`` (an image_sink) streams to ``device`` and a reader is open and reading. A
    second image_sink is started: it must report the busy device (capture-only while a
    writer streams, exclusive_caps=1) in ONE error line and keep retrying. ``first`` then
    stops; the second must take over while the reader stays open.
    -> (error_line_ok, took_over, detail)"""
    cap = CaptureDevice(device, buffers=2)
    try:
        start_reader(cap)
        got, end = 0, time.monotonic() + 30
        while got < 5 and time.monotonic() < end:
            try:
                data, _ = cap.read(timeout=2.0)
            except DeviceError:
                continue
            if exp.classify(data)[0] == 'frame':
                got += 1
        if got < 5:
            return False, False, 'reader got only %d frames from the first image_sink' % got
        note('reader open; waiting for the second image_sink (%s)' % second.name)
        busy = second.wait_for(r'not a video output device', 150)
        note('second image_sink reported the busy device: %s; stopping the first' % busy)
        first.stop()
        took = second.wait_for(r'image_sink: writing', 10)
        new, end = 0, time.monotonic() + (20 if took else 2)
        while new < 10 and time.monotonic() < end:
            try:
                data, _ = cap.read(timeout=1.0)
            except DeviceError:
                continue
            if exp.classify(data)[0] == 'frame':
                new += 1
        text = second.text()
        busy_lines = [l for l in text.splitlines() if 'not a video output device' in l]
        other_err = [l.strip() for l in text.splitlines()
                     if 'ERROR' in l and 'not a video output device' not in l]
        detail = ('second image_sink: %d busy-device error line(s)%s; after the first '
                  'stopped it %s, the open reader got %d new frames%s'
                  % (len(busy_lines), (' (%s)' % busy_lines[0].split('image_sink: ')[-1][:120])
                     if busy_lines else '', 'took over' if took else 'could NOT take over',
                     new, ('; then: ' + other_err[0][:200]) if other_err else ''))
        return busy and len(busy_lines) == 1, took and new >= 10, detail
    finally:
        cap.close()
        if not keep_second:
            second.stop()


def fast_writer_vs_slow_reader(device, nframes=100, hold=0.03):
    """A raw writer at full speed (distinct frames) against an mmap reader that reads the
    top half of a dequeued buffer, waits ``hold`` s, then the rest. -> read counts."""
    note('fast raw writer vs slow reader on %s' % device)
    exp = EXP_SMALL
    stop = threading.Event()
    dev = OutputDevice(device, TW, TH, 200)
    written = [0]

    def run():
        k = 0
        while not stop.is_set():
            dev.write(exp.frames[k % frames.N])
            k += 1
            written[0] = k
            time.sleep(0.001)
    t = threading.Thread(target=run, daemon=True)
    t.start()
    try:
        reads = read_frames(exp, nframes, 60, device=device, hold=hold)
    finally:
        stop.set()
        t.join(5)
        dev.close()
    return summary(reads), written[0]


def list_formats(device):
    out = subprocess.run(['v4l2-ctl', '-d', device, '--list-formats-ext'],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         timeout=60).stdout
    sizes = re.findall(r'Size: (\w+) (\d+)x(\d+)', out)
    ivals = re.findall(r'Interval: (\w+) [\d.]+s \(([\d.]+) fps\)', out)
    fmts = re.findall(r"'(\w{4})'", out)
    ok = (fmts == ['YUYV'] and sizes == [('Discrete', str(W), str(H))]
          and ivals == [('Discrete', '%.3f' % FPS)])
    return ok, out


def v4l2ctl_stream(exp, device, count=45):
    raw = os.path.join(TMP, 'stream.raw')
    p = subprocess.run(['v4l2-ctl', '-d', device, '--stream-mmap=3',
                        '--stream-count=%d' % count, '--stream-to=%s' % raw],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
    data = open(raw, 'rb').read() if os.path.exists(raw) else b''
    reads = [exp.classify(data[i:i + exp.size]) for i in range(0, len(data), exp.size)]
    c = {}
    for cls, _ in reads:
        c[cls] = c.get(cls, 0) + 1
    return p.returncode, len(reads), c


def opencv_read(exp, device, count=10):
    import cv2
    import numpy as np
    cap = cv2.VideoCapture(device, cv2.CAP_V4L2)
    if not cap.isOpened():
        return False, 'VideoCapture could not open %s' % device
    want = {}
    for k, d in enumerate(exp.frames):
        yuyv = np.frombuffer(d, np.uint8).reshape(H, W, 2)
        want[frames.digest(cv2.cvtColor(yuyv, cv2.COLOR_YUV2BGR_YUYV).tobytes())] = k
    matched, shape = 0, None
    for _ in range(count):
        ok, img = cap.read()
        if not ok:
            continue
        shape = img.shape
        if frames.digest(np.ascontiguousarray(img).tobytes()) in want:
            matched += 1
    fps = cap.get(cv2.CAP_PROP_FPS)
    cap.release()
    return (matched >= count - 2 and shape == (H, W, 3),
            'shape %s, %d/%d frames equal to a published picture as OpenCV decodes it, '
            'CAP_PROP_FPS %.1f' % (shape, matched, count, fps))


def latency_and_rate(exp, device, seconds=6.0):
    """mmap reader for ``seconds``: frames and new pictures per second, publish->read
    latency (median, p90) of each new picture."""
    reads = read_frames(exp, 10 ** 6, seconds, device=device)
    pubs = publications()
    lat, last_k, new = [], None, 0
    for cls, k, t in reads:
        if cls != 'frame' or k == last_k:
            continue
        last_k = k
        new += 1
        before = [tp for tp in pubs.get(k, []) if tp <= t]
        if before:
            lat.append(t - max(before))
    lat.sort()
    dur = (reads[-1][2] - reads[0][2]) if len(reads) > 1 else 0
    return (new / dur if dur else 0.0, len(reads) / dur if dur else 0.0,
            lat[len(lat) // 2] * 1000 if lat else -1,
            lat[int(len(lat) * .9)] * 1000 if lat else -1, summary(reads))


# --- phase 1: the pristine module ------------------------------------------------------
def phase_unpatched(sink_a):
    """sink_a writes with write(2) (io_method write) to the pristine module."""
    dev = DEV_UNPATCHED
    note('roscore up; waiting for image_sink (io_method write) on the unpatched module')
    if not sink_a.wait_for(r'image_sink: writing', 300):
        check('image_sink writes to the unpatched module', False, sink_a.text()[-1500:])
        return
    sink_b = sink('sink_b_unpatched', device=dev, io_method='mmap')
    busy_ok, took, detail = take_over_with_reader_open(EXP, sink_a, sink_b, dev)
    check('unpatched module: busy device (capture-only while another writer streams): '
          'one clear error line', busy_ok, detail)
    check('unpatched module: after a write() writer stops, a restarted image_sink cannot '
          'serve the open reader (bug reproduced)', not took, detail)
    # only a module reload brings the pristine device back
    module('unpatched', dev, exclusive_caps=1, video_nr=5, card_label='unpatched')
    counts, written = fast_writer_vs_slow_reader(dev)
    check('unpatched module, max_buffers=2: a fast writer tears frames (bug reproduced)',
          counts.get('torn', 0) > 0, '%s, %d frames written' % (counts, written))


# --- phase 2: the patched module --------------------------------------------------------
def phase_patched(sink_c):
    """sink_c (io_method write) was started before the module existed."""
    dev = DEV
    note('patched module loaded')
    took = sink_c.wait_for(r'image_sink: writing', 60)
    lines = [l for l in sink_c.text().splitlines() if 'no such device' in l]
    check('no such device: one clear error line, node keeps retrying and takes the device '
          'once the module is loaded', took and len(lines) == 1,
          '%d error lines: %s' % (len(lines), lines[0].strip()[:160] if lines else ''))
    if not took:
        return
    # the image_sink that will take over starts now (slow under emulation), is refused
    # while sink_c streams and takes over when sink_c stops, below
    sink_d = sink('sink_d_patched', device=dev, io_method='mmap')
    time.sleep(1)
    ok, out = list_formats(dev)
    check('v4l2-ctl --list-formats-ext shows exactly YUYV %dx%d at %d fps' % (W, H, FPS), ok,
          ' | '.join(l.strip() for l in out.splitlines() if l.strip())[:400])
    rc, n, c = v4l2ctl_stream(EXP, dev)
    check('io_method write: v4l2-ctl --stream-mmap frames are byte-exact published pictures',
          rc == 0 and n >= 45 and c.get('frame', 0) == n, 'rc %d, %d frames: %s' % (rc, n, c))
    ok, detail = opencv_read(EXP, dev)
    check('io_method write: OpenCV VideoCapture reads the published pictures', ok, detail)
    # restart: the write() image_sink stops, an mmap one takes over, the reader stays open
    busy_ok, took, detail = take_over_with_reader_open(EXP, sink_c, sink_d, dev,
                                                       keep_second=True)
    check('patched module: busy device (capture-only while another writer streams): '
          'one clear error line', busy_ok, detail)
    check('patched module: after a write() writer stops, a restarted image_sink (mmap) '
          'serves the open reader', took, detail)
    if not took:
        sink_d.stop()
        return
    rc, n, c = v4l2ctl_stream(EXP, dev)
    check('io_method mmap: v4l2-ctl --stream-mmap frames are byte-exact published pictures',
          rc == 0 and n >= 45 and c.get('frame', 0) == n, 'rc %d, %d frames: %s' % (rc, n, c))
    fps_new, fps_read, lat50, lat90, c = latency_and_rate(EXP, dev)
    metric('vm_640x480_30fps_frames_read_per_s', '%.1f' % fps_read)
    metric('vm_640x480_30fps_new_pictures_per_s', '%.1f' % fps_new)
    metric('vm_topic_to_reader_latency_ms_median', '%.1f' % lat50)
    metric('vm_topic_to_reader_latency_ms_p90', '%.1f' % lat90)
    # the rates are figures of the emulator, not asserted; what is asserted: exact frames
    # only, and readers never starve (a slow topic has its last picture repeated)
    check('mmap reader: frames exact, the last picture repeated when the topic is slower',
          c.get('frame', 0) > 0 and set(c) <= {'frame'} and fps_read >= fps_new > 0,
          '%s, %.1f frames/s read, %.1f new pictures/s' % (c, fps_read, fps_new))
    set_rate(2 * FPS)
    time.sleep(1)
    reads = read_frames(EXP, 300, 150, device=dev, hold=0.015)
    c = summary(reads)
    set_rate(FPS)
    changes = sum(1 for a, b in zip(reads, reads[1:]) if a[1] != b[1])
    check('300 frames through image_sink from a fast publisher, slow reader: none torn',
          len(reads) == 300 and c.get('torn', 0) == 0 and c.get('frame', 0) >= 290,
          '%s, %d picture changes' % (c, changes))
    sink_d.stop()
    counts, written = fast_writer_vs_slow_reader(dev)
    check('patched module, max_buffers=2: fast writer vs slow reader, no torn frames',
          counts.get('torn', 0) == 0 and counts.get('frame', 0) >= 95,
          '%s, %d frames written' % (counts, written))


def main():
    global EXP, EXP_SMALL
    os.makedirs(TMP, exist_ok=True)
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % PORT
    os.environ['ROS_HOSTNAME'] = 'localhost'
    os.environ['ROS_HOME'] = os.path.join(TMP, 'ros')
    set_rate(FPS)
    # the pristine module on /dev/video5; /dev/video0 does not exist yet
    module('unpatched', DEV_UNPATCHED, exclusive_caps=1, video_nr=5, card_label='unpatched')
    # the ROS core: rosmaster --core and rosout, what `roscore` launches (roscore itself
    # gives the master 10 s to come up, too little for Python under emulation). The master
    # is forked before the heavy imports, so it comes up while they run.
    core = Proc('rosmaster', script='/usr/bin/rosmaster', args=['--core', '-p', str(PORT)])
    rosout = Proc('rosout', ['/usr/lib/rosout/rosout', '__name:=rosout'])
    preload_ros()
    note('imported rospy; forking the publisher')
    pub = Proc('publisher', script=os.path.join(HERE, 'publisher.py'),
               args=['_width:=%d' % W, '_height:=%d' % H, '_rate:=%d' % FPS,
                     '_log:=%s' % os.path.join(TMP, 'pub.log'),
                     '_rate_file:=%s' % os.path.join(TMP, 'rate')])
    preload()
    note('imported OpenCV and image_sink; forking two image_sinks')
    sink_a = sink('sink_a_unpatched', device=DEV_UNPATCHED, io_method='write')
    sink_c = sink('sink_c_patched', device=DEV, io_method='write')
    note('started roscore, publisher, two image_sinks; computing expected frames')
    EXP = frames.Expected(W, H, cache=os.path.join(ROOT, 'build', 'vm', 'expected_%dx%d.npy'
                                                   % (W, H)))
    EXP_SMALL = frames.Expected(TW, TH, cache=os.path.join(ROOT, 'build', 'vm',
                                                           'expected_%dx%d.npy' % (TW, TH)))
    note('expected frames ready')
    try:
        if not master_up(200):
            check('ROS master starts', False, core.text()[-800:])
            return 1
        note('ROS master up')
        try:
            phase_unpatched(sink_a)
        except Exception as e:  # a crash in a phase is a failed check, not a hang
            import traceback
            traceback.print_exc()
            check('phase_unpatched', False, '%s: %s' % (type(e).__name__, e))
        sink_a.stop()
        for p in list(RUNNING):
            if p not in (core, rosout, pub, sink_c):
                p.stop()
        subprocess.call(['rmmod', 'v4l2loopback'])
        # sink_c must have met the missing device before the module appears
        if not sink_c.wait_for(r'no such device', 240):
            note('image_sink for /dev/video0 did not report the missing device in time')
        module('patched', DEV, exclusive_caps=1, video_nr=0, card_label='mobile_device_sim')
        try:
            phase_patched(sink_c)
        except Exception as e:
            import traceback
            traceback.print_exc()
            check('phase_patched', False, '%s: %s' % (type(e).__name__, e))
    finally:
        for p in reversed(RUNNING):
            p.stop()
        if os.environ.get('MDS_VM_VERBOSE') or any(not ok for _, ok in RESULTS):
            for log in sorted(glob.glob(os.path.join(TMP, 'sink*.log'))):
                print('---- %s\n%s' % (log, open(log, errors='replace').read()[-1500:]))
    failed = [n for n, ok in RESULTS if not ok]
    say('summary', '%d passed, %d failed' % (len(RESULTS) - len(failed), len(failed)))
    say('RESULT:', 'PASS' if RESULTS and not failed else 'FAIL')
    return 0 if RESULTS and not failed else 1


if __name__ == '__main__':
    sys.exit(main())
