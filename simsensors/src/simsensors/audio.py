"""Speaker, sound sources and microphones of thesis sections 3.3.14 and 3.4.2.

Gazebo classic's audio (OpenAL) had one listener bound to the spectator and no ROS
interface (thesis 3.3.14). Here every world has one :class:`AudioScene` (kept in this
module, keyed by the world) holding its sound sources and their position histories; any
number of microphones render their own PCM from all sources, in sim time:

* distance attenuation: amplitude ``gain * referenceDistance / r`` (1/r, 1 m reference;
  r is clamped at ``minDistance``),
* propagation delay: the source is sampled at the emission time ``t - r(t)/c``
  (c = 343 m/s) -- a time-varying delay line, which gives the Doppler shift of relative
  motion without a formula (approaching at v: ``f * c / (c - v)``),
* source ``gain`` and ``pitch`` (playback-rate factor, thesis code snippet 3.3.5).

Plugins:

``libgazebo_ros_audio.so`` (also ``libaudio.so``, ``libgazebo_ros_speaker.so``): a sound
source on ``bodyName``. Plays a sound file (``soundFile``, aliases ``mp3``/``wav``/``ogg``/
``flac``/``file``: read with libsndfile through ``soundfile``, mixed to mono), a tone
(``toneFrequency`` Hz, ``toneAmplitude``), and whatever arrives on ``speaker/audio``
(mobile_device_sim/AudioData: queued gap-free from the sim time it is taken) and
``speaker/play`` (std_msgs/String: a file name to play now). Parameters ``pitch`` (1),
``gain`` (1), ``loop`` (false), ``startTime`` (sim s of the file's start, 0).

``libgazebo_ros_microphone.so``: a listener on ``bodyName``, publishing ``microphone/audio``
(AudioData) chunks of ``1/updateRate`` s (default 10 Hz: 0.1 s) at ``sampleRate``
(16000 Hz) mono; header.stamp is the sim time of the first sample. ``gain`` scales it,
``noiseStddev`` adds white noise from the world's seeded generator.

Bad input (unreadable/undecodable file, negative gain, a bad AudioData): one error line
naming it; the source keeps what it played before; the world keeps running.
"""
import bisect
import math
import threading

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.device import Actuator
from sim_world.plugins.sensor import Sensor

__all__ = ['AudioScene', 'scene_of', 'mono_chunk', 'Signal', 'FileSignal', 'ToneSignal',
           'StreamSignal', 'AudioSource', 'Microphone', 'read_sound', 'SPEED_OF_SOUND']

SPEED_OF_SOUND = 343.0


def mono_chunk(samples, sample_rate, channels=1):
    """An AudioData chunk's interleaved samples as one mono float array (channels
    averaged), or None when the chunk is not valid (rate <= 0, no channel, a sample count
    that is not a multiple of the channels, a non-finite sample)."""
    x = np.asarray(samples, float)
    if not (sample_rate > 0 and channels >= 1 and len(x) % channels == 0
            and np.all(np.isfinite(x))):
        return None
    return x.reshape(-1, channels).mean(axis=1) if channels > 1 else x


def scene_of(world):
    """The world's audio scene (made on first use)."""
    return world.shared('audio_scene', lambda w: AudioScene())


def read_sound(path):
    """(mono float64 samples, sample rate) of a sound file; ValueError naming the file."""
    try:
        import soundfile
    except ImportError as e:      # pragma: no cover - pinned in tools/requirements.txt
        raise ValueError('cannot read %r: soundfile is not installed (%s)' % (path, e))
    try:
        data, sr = soundfile.read(path, dtype='float64', always_2d=True)
    except Exception as e:  # noqa: BLE001 - libsndfile raises RuntimeError/LibsndfileError
        raise ValueError('cannot read sound file %r: %s' % (path, e))
    if data.shape[0] == 0:
        raise ValueError('sound file %r has no samples' % path)
    return data.mean(axis=1), int(sr)


# -- signals: value of the source's emitted pressure at source-time t ------------------------
class Signal(object):
    def sample(self, t):
        return np.zeros_like(t)


class ToneSignal(Signal):
    def __init__(self, freq, amplitude=1.0, t0=0.0):
        self.freq, self.amplitude, self.t0 = float(freq), float(amplitude), float(t0)

    def sample(self, t):
        out = self.amplitude * np.sin(2 * math.pi * self.freq * (t - self.t0))
        return np.where(t >= self.t0, out, 0.0)


class FileSignal(Signal):
    """Samples played from t0 at ``pitch`` times their rate; ``loop`` repeats them."""

    def __init__(self, samples, rate, t0=0.0, pitch=1.0, loop=False):
        self.x = np.asarray(samples, float)
        self.rate, self.t0, self.pitch, self.loop = float(rate), float(t0), float(pitch), loop

    def sample(self, t):
        idx = (t - self.t0) * self.rate * self.pitch
        n = len(self.x)
        if self.loop:
            idx = np.where(idx >= 0, np.mod(idx, n), -1.0)
        valid = (idx >= 0) & (idx <= n - 1)
        out = np.interp(idx, np.arange(n), self.x)
        return np.where(valid, out, 0.0)


class StreamSignal(Signal):
    """PCM chunks placed gap-free on the sim-time axis (a speaker fed by a topic)."""

    KEEP = 10.0       # s of history kept (longest delay: 3.4 km)

    def __init__(self, pitch=1.0):
        self.segments = []          # (t_start, rate, samples)
        self.pitch = float(pitch)

    def push(self, samples, rate, now):
        end = self.end()
        t0 = max(now, end) if end is not None and end > now - 1e-9 else now
        self.segments.append((t0, float(rate), np.asarray(samples, float)))
        self.segments = [s for s in self.segments
                         if s[0] + len(s[2]) / (s[1] * self.pitch) > now - self.KEEP]
        return t0

    def end(self):
        if not self.segments:
            return None
        t0, rate, x = self.segments[-1]
        return t0 + len(x) / (rate * self.pitch)

    def sample(self, t):
        out = np.zeros_like(t)
        for t0, rate, x in self.segments:
            idx = (t - t0) * rate * self.pitch
            valid = (idx >= 0) & (idx <= len(x) - 1)
            if valid.any():
                out[valid] += np.interp(idx[valid], np.arange(len(x)), x)
        return out


class _Track(object):
    """Positions of one emitter over sim time (linear in between)."""

    KEEP = 12.0

    def __init__(self):
        self.t = []
        self.p = []

    def add(self, t, p):
        if self.t and t < self.t[-1] - 1e-12:        # time went back (world reset)
            self.t, self.p = [], []
        if self.t and abs(t - self.t[-1]) < 1e-12:
            self.p[-1] = np.asarray(p, float)
            return
        self.t.append(float(t))
        self.p.append(np.asarray(p, float))
        while len(self.t) > 2 and self.t[1] < t - self.KEEP:
            self.t.pop(0)
            self.p.pop(0)

    def at(self, t):
        if not self.t:
            return np.zeros((len(t), 3))
        if len(self.t) == 1:
            return np.tile(self.p[0], (len(t), 1))
        # only the samples around the asked times (a chunk spans one tick, the track 12 s:
        # converting all of it to arrays at every call was 5 % of a sensors world's step);
        # the same segments, so the same values, as with the whole track
        n = len(self.t)
        t = np.asarray(t, float)
        i0 = max(0, bisect.bisect_right(self.t, float(t.min())) - 1)
        i1 = min(n, bisect.bisect_left(self.t, float(t.max())) + 1)
        if i0 == 0 or i1 - i0 < 2:
            i1 = max(i1, min(n, 2))           # the first segment (extrapolating below)
        if i1 == n or i1 - i0 < 2:
            i0 = min(i0, n - 2)               # the last segment (extrapolating above)
        ts = np.asarray(self.t[i0:i1])
        ps = np.asarray(self.p[i0:i1])
        # linear, extrapolated at the ends with the last segment's velocity
        out = np.empty((len(t), 3))
        for k in range(3):
            out[:, k] = np.interp(t, ts, ps[:, k])
            lo, hi = t < ts[0], t > ts[-1]
            if lo.any():
                v = (ps[1, k] - ps[0, k]) / (ts[1] - ts[0])
                out[lo, k] = ps[0, k] + v * (t[lo] - ts[0])
            if hi.any():
                v = (ps[-1, k] - ps[-2, k]) / (ts[-1] - ts[-2])
                out[hi, k] = ps[-1, k] + v * (t[hi] - ts[-1])
        return out


class AudioScene(object):
    """Sources of one world and the rendering of what a listener hears."""

    def __init__(self, c=SPEED_OF_SOUND):
        self.c = float(c)
        self.sources = []          # AudioSource plugins (or anything with .track/.signals)
        self.lock = threading.RLock()

    def add(self, src):
        with self.lock:
            if src not in self.sources:
                self.sources.append(src)

    def remove(self, src):
        with self.lock:
            if src in self.sources:
                self.sources.remove(src)

    def render(self, times, mic_pos, ref=1.0, min_dist=0.1, exclude=()):
        """Pressure at the listener at sim ``times`` (array) with the listener at
        ``mic_pos`` (len(times) x 3): the sum over sources of
        gain * ref / r * signal(t - r/c), r at the emission time (fixed point)."""
        times = np.asarray(times, float)
        out = np.zeros_like(times)
        with self.lock:
            sources = [s for s in self.sources if s not in exclude]
        for s in sources:
            if s.gain <= 0:
                continue
            te = times.copy()
            for _ in range(3):                       # r(te): converges in 2-3 rounds
                r = np.linalg.norm(mic_pos - s.track.at(te), axis=1)
                te = times - r / self.c
            amp = s.gain * ref / np.maximum(r, min_dist)
            sig = np.zeros_like(times)
            for g in s.signals():
                sig += g.sample(te)
            out += amp * sig
        return out


# -- plugins --------------------------------------------------------------------------------
@register('libgazebo_ros_audio.so', 'libaudio.so', 'libgazebo_ros_speaker.so')
class AudioSource(Actuator):
    DEFAULT_TOPIC = 'speaker/audio'
    DEFAULT_RATE = 100.0
    PARAMS = [
        Param('pitch', float, 1.0, unit='x', check='>0', doc='playback-rate factor'),
        Param('gain', float, 1.0, check='>=0', doc='amplitude at referenceDistance'),
        Param('loop', bool, False, doc='repeat the sound file'),
        Param('soundFile', str, '', aliases=('mp3', 'wav', 'ogg', 'flac', 'file'),
              doc='sound file played from startTime'),
        Param('startTime', float, 0.0, unit='s', check='>=0', doc='sim time the file starts'),
        Param('toneFrequency', float, 0.0, unit='Hz', check='>=0', doc='a sine tone; 0: none'),
        Param('toneAmplitude', float, 0.5, check='>=0'),
        Param('playTopicName', str, 'speaker/play', doc='std_msgs/String: a file to play now'),
    ]

    def setup(self):
        p = self.p
        self.scene = scene_of(self.world)
        self.track = _Track()
        self.gain = p.gain
        self.file_signal = None
        self.tone = ToneSignal(p.toneFrequency, p.toneAmplitude) if p.toneFrequency > 0 \
            else None
        self.stream = StreamSignal(p.pitch)
        if p.soundFile:
            self.play_file(p.soundFile, p.startTime)
        self.scene.add(self)
        self._record(self.world.sim_time)
        if self.ros:
            from mobile_device_sim.msg import AudioData
            from std_msgs.msg import String
            self.subscribe(self.topic, AudioData, self._on_audio)
            self.subscribe(p.playTopicName, String, lambda m: self.play_file(m.data))

    def signals(self):
        return [s for s in (self.file_signal, self.tone, self.stream) if s is not None]

    # -- commands (any thread) ---------------------------------------------------------------
    def play_file(self, path, t0=None):
        """Play a sound file from sim time t0 (default now). False (one error line) when it
        cannot be read: what played before keeps playing."""
        try:
            x, sr = read_sound(path)
        except ValueError as e:
            self.log_error('%s: %s; the source keeps its last sound' % (self.label, e))
            return False
        t0 = self.world.sim_time if t0 is None else t0
        self.file_signal = FileSignal(x, sr, t0, self.p.pitch, self.p.loop)
        return True

    def play_tone(self, freq, amplitude=0.5, t0=None):
        if not (freq > 0 and amplitude >= 0):
            self.log_error('%s: tone frequency must be > 0 Hz and amplitude >= 0, got %r, %r'
                           % (self.label, freq, amplitude))
            return False
        t0 = self.world.sim_time if t0 is None else t0
        self.tone = ToneSignal(freq, amplitude, t0)
        return True

    def set_gain(self, gain):
        if not (isinstance(gain, (int, float)) and math.isfinite(gain) and gain >= 0):
            self.log_error('%s: gain must be >= 0, got %r; keeps %g' % (self.label, gain,
                                                                         self.gain))
            return False
        self.gain = float(gain)
        return True

    def push_audio(self, samples, sample_rate, channels=1):
        """Queue PCM for the speaker (taken at the next tick)."""
        x = mono_chunk(samples, sample_rate, channels)
        if x is None:
            self.log_error('%s: audio chunk with sample_rate %r, channels %r, %d samples is '
                           'not valid; ignored' % (self.label, sample_rate, channels,
                                                   len(samples)))
            return False
        self.queue((x, float(sample_rate)))
        return True

    def _on_audio(self, m):
        self.push_audio(m.samples, m.sample_rate, m.channels)

    # -- schedule ----------------------------------------------------------------------------
    def _record(self, t):
        try:
            self.track.add(t, self.state(t).body_pose.p)
        except Exception:   # noqa: BLE001 - a model being deleted
            pass

    def act(self, sim_time, commands):
        for x, sr in commands:
            self.stream.push(x, sr, sim_time)
        self._record(sim_time)
        self.last_value = self.gain

    def shutdown(self):
        self.scene.remove(self)
        Actuator.shutdown(self)


@register('libgazebo_ros_microphone.so', 'libmicrophone.so')
class Microphone(Sensor):
    DEFAULT_TOPIC = 'microphone/audio'
    DEFAULT_RATE = 10.0
    PARAMS = [
        Param('sampleRate', int, 16000, aliases=('sample_rate',), unit='Hz', check='>0'),
        Param('gain', float, 1.0, check='>=0'),
        Param('noiseStddev', float, 0.0, check='>=0', doc='white noise, full scale'),
        Param('referenceDistance', float, 1.0, unit='m', check='>0'),
        Param('minDistance', float, 0.05, unit='m', check='>0'),
        Param('hearOwnModel', bool, True, doc='hear the sources of its own model'),
    ]

    def setup(self):
        self.scene = scene_of(self.world)
        self.track = _Track()
        self.t_last = self.world.sim_time
        self._t_from = self.t_last
        self.chunks = []            # (t_first_sample, samples) kept for tests (last 50)
        from mobile_device_sim.msg import AudioData
        self.AudioData = AudioData
        self.output('main', AudioData)
        self._record(self.t_last)

    def _record(self, t):
        try:
            self.track.add(t, self.state(t).body_pose.p)
        except Exception:   # noqa: BLE001
            pass

    def render(self, t_from, t_to):
        """Samples for sim times (t_from, t_to] at sampleRate (first at the next sample
        instant after t_from): (t_first, samples)."""
        sr = self.p.sampleRate
        k0 = int(math.floor(t_from * sr + 1e-6)) + 1
        k1 = int(math.floor(t_to * sr + 1e-6))
        if k1 < k0:
            return t_to, np.zeros(0)
        times = np.arange(k0, k1 + 1) / float(sr)
        mic = self.track.at(times)
        for s in list(self.scene.sources):          # sources' positions up to now
            s._record(t_to)
        excl = () if self.p.hearOwnModel else tuple(
            s for s in self.scene.sources if s.model is self.model)
        x = self.scene.render(times, mic, self.p.referenceDistance, self.p.minDistance, excl)
        x = x * self.p.gain
        if self.p.noiseStddev > 0:
            x = x + self.rng.normal(0.0, self.p.noiseStddev * self.noise_scale, len(x))
        return times[0], x

    def has_noise(self):
        return self.p.noiseStddev > 0

    def tick(self, sim_time, dt):
        if sim_time < self.t_last:               # world reset
            self.t_last = sim_time
            self.track = _Track()
        self._record(sim_time)
        self._t_from, self.t_last = self.t_last, sim_time

    def measure(self, state, dt):
        """The chunk heard since the last tick: (time of its first sample, samples)."""
        t0, x = self.render(self._t_from, state.t)
        if not len(x):
            return None
        self.chunks.append((t0, x))
        del self.chunks[:-50]
        return t0, x

    def to_msg(self, value, stamp):
        import rospy
        t0, x = value
        m = self.AudioData()
        m.header.stamp = rospy.Time.from_sec(t0)     # the sim time of the first sample
        m.header.frame_id = self.body
        m.sample_rate = self.p.sampleRate
        m.channels = 1
        m.samples = x.astype(np.float32).tolist()
        return m

    def samples_since(self, t):
        """Concatenated samples of the kept chunks whose first sample is at or after t."""
        xs = [x for t0, x in self.chunks if t0 >= t - 1e-9]
        return np.concatenate(xs) if xs else np.zeros(0)
