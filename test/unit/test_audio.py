"""Sound sources, speaker and microphones (simsensors.audio) on the real World, no roscore:
1/r attenuation, propagation delay, Doppler from the delay line, several listeners, sound
files, bad input."""
import logging
import os

import numpy as np
import pytest

from simsensors.audio import AudioSource, Microphone, SPEED_OF_SOUND, scene_of
from sim_world.transforms import Pose
from sim_world.urdf import load_urdf_file, parse_urdf
from sim_world.world import World

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PHONE = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


def _body(name, plugin, params):
    return parse_urdf('''<robot name="%s"><link name="base">
      <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4"/></inertial>
      <visual><geometry><box size="0.05 0.05 0.05"/></geometry></visual></link>
      <gazebo reference="base"><turnGravityOff>true</turnGravityOff></gazebo>
      <gazebo><plugin name="p" filename="%s">%s</plugin></gazebo></robot>'''
                      % (name, plugin, ''.join('<%s>%s</%s>' % (k, v, k)
                                               for k, v in params.items())), name=name)


def _source(w, name, pos, **params):
    w.add_model(_body(name, 'libgazebo_ros_audio.so', params), pose=Pose(pos))
    return next(p for p in w.plugins[name] if isinstance(p, AudioSource))


def _mic(w, name, pos, **params):
    w.add_model(_body(name, 'libgazebo_ros_microphone.so', params), pose=Pose(pos))
    return next(p for p in w.plugins[name] if isinstance(p, Microphone))


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.fixture
def world():
    w = World(physics='ode', seed=1, gravity=(0, 0, 0))
    yield w
    w.shutdown()


def test_amplitude_halves_when_distance_doubles_two_mics(world):
    _source(world, 'src', (0, 0, 1), toneFrequency=440, toneAmplitude=0.5)
    near = _mic(world, 'mic2', (2, 0, 1))
    far = _mic(world, 'mic4', (0, 4, 1))
    world.step(1000)
    a, b = near.samples_since(0.1), far.samples_since(0.1)
    assert len(a) == len(b) == 14400                     # 0.9 s at 16 kHz mono
    ratio = _rms(a) / _rms(b)
    assert ratio == pytest.approx(2.0, rel=0.01)
    assert _rms(a) == pytest.approx(0.5 / 2 / np.sqrt(2), rel=0.01)    # 1/r, 1 m reference


def test_delay_is_distance_over_343(tmp_path, world):
    import soundfile
    click = np.zeros(1600)
    click[0:16] = 0.8
    f = tmp_path / 'click.wav'
    soundfile.write(str(f), click, 16000)
    _source(world, 'src', (0, 0, 1), soundFile=str(f), startTime=0.1)
    d = 68.6
    mic = _mic(world, 'mic', (d, 0, 1))
    world.step(600)
    x = mic.samples_since(0.0)
    t_first = np.argmax(np.abs(x) > 1e-4) / 16000.0 + 1 / 16000.0
    assert t_first - 0.1 == pytest.approx(d / SPEED_OF_SOUND, abs=2 / 16000.0)
    assert d / SPEED_OF_SOUND == pytest.approx(0.2)


def _peak_hz(x, sr=16000):
    n = 1 << 18
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    return np.argmax(spec) * sr / float(n)


def test_doppler_approaching_source(world):
    f0, v = 1000.0, 10.0
    src = _source(world, 'src', (40, 0, 1), toneFrequency=f0, toneAmplitude=0.5)
    mic = _mic(world, 'mic', (0, 0, 1))
    still = _mic(world, 'still', (40, 3, 1))            # rides nowhere: hears f0 (no motion)
    world.set_state('src', Pose((40, 0, 1)), lin=(-v, 0, 0))
    world.step(1500)
    assert world.link_pose('src', 'base').p[0] == pytest.approx(40 - v * 1.5, abs=0.05)
    x = mic.samples_since(0.5)
    expect = f0 * SPEED_OF_SOUND / (SPEED_OF_SOUND - v)
    assert _peak_hz(x) == pytest.approx(expect, rel=0.01)
    assert abs(_peak_hz(x) - f0) > 20                     # not the unshifted tone
    # a receding listener-side view: the mic beside the path hears it fall below f0 later
    assert src.gain == 1.0 and len(still.samples_since(0.5)) == len(x)


def test_phone_speaker_stream_to_other_phone(world):
    a = load_urdf_file(PHONE, name='mobile_device')
    b = load_urdf_file(PHONE, name='mobile_device_b', mappings={'ns': 'mobile_device_b'})
    world.add_model(a, pose=Pose((0, 0, 1)))
    world.add_model(b, pose=Pose((1, 0, 1)))
    spk = next(p for p in world.plugins['mobile_device'] if isinstance(p, AudioSource))
    mic_b = next(p for p in world.plugins['mobile_device_b'] if isinstance(p, Microphone))
    assert spk.body == 'mobile_speaker' and mic_b.body == 'mobile_microphone'
    t = np.arange(16000) / 16000.0
    assert spk.push_audio(0.5 * np.sin(2 * np.pi * 880 * t), 16000)
    world.step(1000)
    x = mic_b.samples_since(0.2)
    assert _peak_hz(x) == pytest.approx(880, abs=2)
    assert _rms(x) > 0.1


def test_bad_input_one_line_keeps_last_state(tmp_path, world, caplog):
    src = _source(world, 'src', (0, 0, 1), toneFrequency=300)
    mic = _mic(world, 'mic', (1, 0, 1))
    bad = tmp_path / 'noise.wav'
    bad.write_bytes(b'RIFF not really a wave file')
    with caplog.at_level(logging.ERROR):
        assert not src.play_file(str(bad))
        assert not src.play_file(str(tmp_path / 'missing.ogg'))
        assert not src.set_gain(-1.0)
        assert not src.push_audio([0.1, float('nan')], 16000)
    lines = [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(lines) == 4
    assert 'noise.wav' in lines[0] and 'missing.ogg' in lines[1] and 'gain' in lines[2]
    assert src.gain == 1.0 and src.file_signal is None
    world.step(500)
    assert _peak_hz(mic.samples_since(0.1)) == pytest.approx(300, abs=2)   # still playing
    assert src in scene_of(world).sources
    world.delete_model('src')
    assert src not in scene_of(world).sources


def test_sound_source_in_a_world_file_with_a_looped_ogg(tmp_path):
    import soundfile
    t = np.arange(8000) / 16000.0
    ogg = tmp_path / 'hum.ogg'
    soundfile.write(str(ogg), 0.5 * np.sin(2 * np.pi * 500 * t), 16000, format='OGG')
    world_file = tmp_path / 'w.world'
    world_file.write_text('''<?xml version="1.0"?><sdf version="1.6"><world name="w">
      <model name="radio"><static>true</static><pose>0 0 1 0 0 0</pose>
        <link name="body"><visual name="v"><geometry><box><size>0.1 0.1 0.1</size></box>
        </geometry></visual></link>
        <plugin name="radio" filename="libgazebo_ros_audio.so">
          <ogg>%s</ogg><loop>true</loop><pitch>2.0</pitch><gain>0.5</gain></plugin>
      </model></world></sdf>''' % ogg)
    w = World(physics='ode', seed=1, gravity=(0, 0, 0))
    try:
        w.load_world_file(str(world_file))
        mic = _mic(w, 'mic', (2, 0, 1))
        w.step(1500)                                    # 1.5 s: the 0.5 s file loops
        x = mic.samples_since(0.3)
        assert _peak_hz(x) == pytest.approx(1000, abs=3)          # pitch 2: 500 Hz -> 1 kHz
        assert _rms(x[-4000:]) == pytest.approx(0.5 * 0.5 / 2 / np.sqrt(2), rel=0.05)
    finally:
        w.shutdown()


def test_mp3_of_the_thesis_snippet(tmp_path, world):
    """Code snippet 3.3.5: <pitch>1.0</pitch> <gain>1.0</gain> <loop>false</loop>
    <mp3>test.mp3</mp3>: the file plays once."""
    import soundfile
    t = np.arange(8000) / 16000.0
    mp3 = tmp_path / 'test.mp3'
    soundfile.write(str(mp3), 0.4 * np.sin(2 * np.pi * 440 * t), 16000, format='MP3')
    _source(world, 'src', (0, 0, 1), mp3=str(mp3), pitch=1.0, gain=1.0, loop='false')
    mic = _mic(world, 'mic', (1, 0, 1))
    world.step(1000)
    x = mic.samples_since(0.0)
    assert _peak_hz(x[:8000]) == pytest.approx(440, abs=3)
    assert _rms(x[1000:7000]) == pytest.approx(0.4 / np.sqrt(2), rel=0.1)
    assert _rms(x[9000:]) < 1e-3                    # played once: silent after 0.5 s


def _track_at_whole(track, t):
    """_Track.at as it was: np.interp over the whole 12 s track (the reference)."""
    ts, ps = np.asarray(track.t), np.asarray(track.p)
    out = np.empty((len(t), 3))
    for k in range(3):
        out[:, k] = np.interp(t, ts, ps[:, k])
        lo, hi = t < ts[0], t > ts[-1]
        if lo.any():
            out[lo, k] = ps[0, k] + (ps[1, k] - ps[0, k]) / (ts[1] - ts[0]) * (t[lo] - ts[0])
        if hi.any():
            out[hi, k] = ps[-1, k] + (ps[-1, k] - ps[-2, k]) / (ts[-1] - ts[-2]) * (
                t[hi] - ts[-1])
    return out


def test_a_track_asked_for_a_chunk_gives_what_the_whole_track_gives_bit_for_bit():
    """_Track.at interpolates from the samples around the asked times only (a chunk spans
    a tick, the track 12 s): the same values, bit for bit, inside, on the samples, and
    extrapolated before the first and after the last."""
    from simsensors.audio import _Track
    rng = np.random.default_rng(3)
    tr = _Track()
    t = 0.0
    for _ in range(1500):                     # 15 s at 100 Hz: the track keeps 12 of them
        tr.add(t, rng.normal(size=3))
        t += 0.01
    assert len(tr.t) < 1500
    first, last = tr.t[0], tr.t[-1]
    chunks = [np.linspace(last - 0.01, last, 7),            # the tick just past
              np.linspace(last - 0.3, last - 0.29, 5),      # emitted 100 m away
              np.array(tr.t[500:503]),                       # on the samples
              np.linspace(last - 0.005, last + 0.02, 9),    # beyond the last sample
              np.linspace(first - 0.05, first + 0.015, 6),  # before the first
              np.linspace(first - 1, last + 1, 50)]         # all of it and more
    for c in chunks:
        assert np.array_equal(tr.at(c), _track_at_whole(tr, c)), c
    two = _Track()
    two.add(0.0, (0, 0, 0))
    two.add(1.0, (1, 2, 3))
    for c in (np.array([-0.5, 0.5, 1.5]), np.array([2.0]), np.array([-1.0])):
        assert np.array_equal(two.at(c), _track_at_whole(two, c)), c
