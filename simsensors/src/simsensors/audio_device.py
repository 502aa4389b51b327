"""The phone's microphone and speaker as real PulseAudio devices (thesis 3.3.14, 3.4.2).

The camera reaches unmodified programs through v4l2loopback; this module does the same for
sound. ``rosrun mobile_device_sim audio_device`` makes

* an **input device** (``module-pipe-source``, default name ``mds_microphone``): what a
  microphone in the world hears (``microphone/audio``, mobile_device_sim/AudioData) is
  written into the source's pipe as 16-bit PCM, so ``parecord -d mds_microphone``, a
  browser, a VoIP client or an Android emulator (``-audio pa``) records the simulated
  microphone;
* an **output device** (``module-pipe-sink``, default name ``mds_speaker``): whatever a
  program plays into it (``paplay -d mds_speaker``) is read from the sink's pipe and
  published on a phone's ``speaker/audio``, so it becomes a sound source in the world that
  every microphone there hears (with distance, delay and Doppler). Silence is not sent.

Parameters (private): ``microphone_topic`` (/mobile_device/microphone/audio; '' for no
source), ``speaker_topic`` (/mobile_device/speaker/audio; '' for no sink),
``source_name`` (mds_microphone), ``sink_name`` (mds_speaker), ``rate`` (16000 Hz, both
devices, mono; microphone chunks at another rate are resampled), ``start_daemon`` (false:
use the user's PulseAudio as ``pactl`` finds it; true: when none answers, start a private
user-level daemon with no sound card, as on a headless CI machine). The server address
in use is set as the parameter ``~server`` (give it to clients as ``PULSE_SERVER``).
The modules are unloaded and the pipes removed when the node ends.

Bad input (a chunk with a bad rate or channel count, non-finite samples) is one error
line; the devices keep working. No PulseAudio and none can be started: one line, exit 2.
"""
import os
import shutil
import subprocess
import tempfile
import threading
import time

import numpy as np

__all__ = ['PulseAudio', 'PulseError', 'to_s16le', 'from_s16le', 'resample',
           'MicrophoneSource', 'SpeakerSink', 'main']


class PulseError(RuntimeError):
    pass


def resample(x, rate_in, rate_out):
    """Linear-interpolation resampling of a mono float signal."""
    x = np.asarray(x, float)
    if rate_in == rate_out or len(x) == 0:
        return x
    n = int(round(len(x) * float(rate_out) / float(rate_in)))
    t = np.arange(n) * (float(rate_in) / float(rate_out))
    return np.interp(t, np.arange(len(x)), x)


def to_s16le(x):
    """Full-scale floats (-1..1, clipped) -> little-endian 16-bit PCM bytes."""
    return (np.clip(np.asarray(x, float), -1.0, 1.0) * 32767.0).round().astype('<i2').tobytes()


def from_s16le(data):
    return np.frombuffer(data, '<i2').astype(np.float32) / 32768.0


class PulseAudio(object):
    """``pactl`` against one server (``server``: a PULSE_SERVER string; None: the
    default lookup), and optionally a private daemon started here."""

    def __init__(self, server=None):
        self.server = server
        self.daemon = None
        self.runtime = None
        self.modules = []

    def env(self):
        env = dict(os.environ)
        if self.server:
            env['PULSE_SERVER'] = self.server
        return env

    def pactl(self, *args, timeout=10):
        try:
            r = subprocess.run(['pactl'] + list(args), capture_output=True, text=True,
                               env=self.env(), timeout=timeout)
        except FileNotFoundError:
            raise PulseError('pactl not found (Debian: apt-get install pulseaudio-utils)')
        except subprocess.TimeoutExpired:
            raise PulseError('pactl %s: no answer in %d s' % (args[0], timeout))
        if r.returncode != 0:
            raise PulseError('pactl %s: %s' % (' '.join(args),
                                               (r.stderr or r.stdout).strip()))
        return r.stdout

    def reachable(self):
        try:
            self.pactl('info', timeout=5)
            return True
        except PulseError:
            return False

    def start_daemon(self, timeout=15.0):
        """A user-level daemon of its own (no sound card, no D-Bus, anonymous socket)."""
        if shutil.which('pulseaudio') is None:
            raise PulseError('pulseaudio not found (Debian: apt-get install pulseaudio)')
        self.runtime = tempfile.mkdtemp(prefix='mds_pulse_')
        sock = os.path.join(self.runtime, 'native')
        env = dict(os.environ, XDG_RUNTIME_DIR=self.runtime, HOME=self.runtime)
        env.pop('PULSE_SERVER', None)
        log = open(os.path.join(self.runtime, 'pulseaudio.log'), 'w')
        self.daemon = subprocess.Popen(
            ['pulseaudio', '-n', '--daemonize=no', '--exit-idle-time=-1', '--disallow-exit',
             '--use-pid-file=no', '--system=no', '-F', '/dev/null',
             '--load=module-native-protocol-unix auth-anonymous=1 socket=%s' % sock,
             '--load=module-null-sink sink_name=mds_null'],
            env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        log.close()
        self.server = 'unix:' + sock
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.daemon.poll() is not None:
                break
            if os.path.exists(sock) and self.reachable():
                return self.server
            time.sleep(0.05)
        tail = ''
        try:
            with open(os.path.join(self.runtime, 'pulseaudio.log')) as f:
                tail = f.read().strip().splitlines()[-1:]
        except OSError:
            pass
        self.close()
        raise PulseError('could not start a private pulseaudio daemon%s'
                         % (': %s' % tail[0] if tail else ''))

    def load(self, module, **args):
        arg = ' '.join('%s=%s' % kv for kv in args.items())
        idx = int(self.pactl('load-module', module, *arg.split()).strip())
        self.modules.append(idx)
        return idx

    def close(self):
        for idx in reversed(self.modules):
            try:
                self.pactl('unload-module', str(idx), timeout=5)
            except PulseError:
                pass
        self.modules = []
        if self.daemon is not None:
            self.daemon.terminate()
            try:
                self.daemon.wait(5)
            except subprocess.TimeoutExpired:
                self.daemon.kill()
                self.daemon.wait()
            self.daemon = None
        if self.runtime:
            shutil.rmtree(self.runtime, ignore_errors=True)
            self.runtime = None


class MicrophoneSource(object):
    """A pipe source: ``write(samples, rate)`` queues mono audio for recorders. Writes do
    not block; audio that does not fit the pipe (nobody reading) is dropped and counted."""

    def __init__(self, pulse, name, rate, fifo):
        self.pulse, self.name, self.rate, self.fifo = pulse, name, int(rate), fifo
        self.module = pulse.load('module-pipe-source', source_name=name, file=fifo,
                                 format='s16le', rate=self.rate, channels=1)
        self.fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
        self.written = 0
        self.dropped = 0
        self._pending = b''
        self._lock = threading.Lock()

    def write(self, samples, rate):
        data = to_s16le(resample(samples, rate, self.rate))
        with self._lock:
            buf = self._pending + data
            try:
                n = os.write(self.fd, buf)
            except BlockingIOError:
                n = 0
            n -= n % 2
            self.written += n // 2
            rest = buf[n:]
            if len(rest) > self.rate * 2:      # more than 1 s behind: drop the oldest
                self.dropped += (len(rest) - self.rate * 2) // 2
                rest = rest[-self.rate * 2:]
            self._pending = rest

    def close(self):
        try:
            os.close(self.fd)
        except OSError:
            pass


class SpeakerSink(object):
    """A pipe sink: a thread reads what programs play and calls ``on_audio(samples,
    rate)`` with 0.1 s chunks that are not silent."""

    def __init__(self, pulse, name, rate, fifo, on_audio):
        self.pulse, self.name, self.rate, self.fifo = pulse, name, int(rate), fifo
        self.on_audio = on_audio
        self.module = pulse.load('module-pipe-sink', sink_name=name, file=fifo,
                                 format='s16le', rate=self.rate, channels=1)
        self.fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        self.chunks = 0
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name='audio_device_sink',
                                       daemon=True)
        self.thread.start()

    def _run(self):
        import select
        want = self.rate // 10 * 2
        buf = b''
        while not self._stop.is_set():
            r, _, _ = select.select([self.fd], [], [], 0.2)
            if not r:
                continue
            try:
                data = os.read(self.fd, 65536)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                break
            if not data:
                time.sleep(0.01)
                continue
            buf += data
            while len(buf) >= want:
                chunk, buf = buf[:want], buf[want:]
                x = from_s16le(chunk)
                if np.any(x != 0):
                    self.chunks += 1
                    self.on_audio(x, self.rate)

    def close(self):
        self._stop.set()
        self.thread.join(2)
        try:
            os.close(self.fd)
        except OSError:
            pass


def main():
    import rospy
    from mobile_device_sim.msg import AudioData
    from .audio import mono_chunk
    rospy.init_node('audio_device')
    mic_topic = rospy.get_param('~microphone_topic', '/mobile_device/microphone/audio')
    spk_topic = rospy.get_param('~speaker_topic', '/mobile_device/speaker/audio')
    src_name = rospy.get_param('~source_name', 'mds_microphone')
    sink_name = rospy.get_param('~sink_name', 'mds_speaker')
    rate = rospy.get_param('~rate', 16000)
    start = bool(rospy.get_param('~start_daemon', False))
    if not (isinstance(rate, int) and 1000 <= rate <= 192000):
        rospy.logerr('audio_device: ~rate must be an integer 1000..192000 Hz, got %r' % rate)
        return 2
    pulse = PulseAudio()
    workdir = tempfile.mkdtemp(prefix='mds_audio_device_')
    devices = []
    try:
        try:
            if not pulse.reachable():
                if not start:
                    raise PulseError('no PulseAudio server answers (start one, or set '
                                     '~start_daemon:=true for a private one)')
                pulse.start_daemon()
            server = pulse.server or pulse.pactl('info').split('Server String:')[1].split()[0]
        except (PulseError, IndexError) as e:
            rospy.logerr('audio_device: %s' % e)
            return 2
        rospy.set_param('~server', server)
        if mic_topic:
            mic = MicrophoneSource(pulse, src_name, rate, os.path.join(workdir, 'source'))
            devices.append(mic)

            def on_chunk(m):
                x = mono_chunk(m.samples, m.sample_rate, m.channels)
                if x is None:
                    rospy.logerr('audio_device: chunk on %s with sample_rate %r, channels %r,'
                                 ' %d samples is not valid; ignored'
                                 % (mic_topic, m.sample_rate, m.channels, len(m.samples)))
                    return
                mic.write(x, m.sample_rate)
            rospy.Subscriber(mic_topic, AudioData, on_chunk, queue_size=100)
        if spk_topic:
            pub = rospy.Publisher(spk_topic, AudioData, queue_size=100)

            def on_play(x, r):
                m = AudioData(sample_rate=r, channels=1, samples=x.tolist())
                m.header.stamp = rospy.Time.now()
                pub.publish(m)
            devices.append(SpeakerSink(pulse, sink_name, rate, os.path.join(workdir, 'sink'),
                                       on_play))
        rospy.loginfo('audio_device: PulseAudio %s: %s' % (server, ', '.join(
            ['source %s <- %s' % (src_name, mic_topic)] * bool(mic_topic)
            + ['sink %s -> %s' % (sink_name, spk_topic)] * bool(spk_topic))))
        rospy.spin()
        return 0
    except PulseError as e:
        rospy.logerr('audio_device: %s' % e)
        return 2
    finally:
        for d in devices:
            d.close()
        pulse.close()
        shutil.rmtree(workdir, ignore_errors=True)
