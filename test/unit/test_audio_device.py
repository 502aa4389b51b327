"""The microphone and speaker as PulseAudio devices (simsensors.audio_device), against a
private user-level PulseAudio daemon with no sound card: unmodified parecord records what
is written to the source; what paplay plays into the sink comes out as audio chunks."""
import os
import shutil
import subprocess
import time

import numpy as np
import pytest
import soundfile

from simsensors import audio_device as ad

pytestmark = pytest.mark.skipif(shutil.which('pulseaudio') is None,
                                reason='pulseaudio not installed (tools/setup installs it)')


def peak_hz(x, rate):
    x = np.asarray(x, float)
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    return float(np.fft.rfftfreq(len(x), 1.0 / rate)[np.argmax(spec)])


def test_pcm_helpers():
    x = np.array([0.0, 0.5, -0.5, 1.5, -2.0])
    y = ad.from_s16le(ad.to_s16le(x))
    assert np.allclose(y, np.clip(x, -1, 1), atol=1e-4)
    t = np.arange(8000) / 8000.0
    r = ad.resample(np.sin(2 * np.pi * 500 * t), 8000, 16000)
    assert len(r) == 16000 and peak_hz(r, 16000) == pytest.approx(500, abs=2)


@pytest.fixture
def pulse():
    p = ad.PulseAudio()
    p.start_daemon()
    yield p
    p.close()
    assert p.daemon is None and p.runtime is None


def test_private_daemon_and_clear_errors(pulse):
    assert pulse.server.startswith('unix:') and pulse.reachable()
    with pytest.raises(ad.PulseError, match='load-module'):
        pulse.load('module-does-not-exist')
    assert not ad.PulseAudio('unix:/nonexistent/socket').reachable()


def test_source_recorded_by_parecord(pulse, tmp_path):
    src = ad.MicrophoneSource(pulse, 'mds_microphone', 16000, str(tmp_path / 'src'))
    try:
        out = str(tmp_path / 'rec.wav')
        env = pulse.env()
        rec = subprocess.Popen(['parecord', '-d', 'mds_microphone', '--rate=16000',
                                '--channels=1', '--format=s16le', '--file-format=wav', out],
                               env=env)
        time.sleep(0.3)
        t = np.arange(8000) / 8000.0                 # 8 kHz input: resampled to 16 kHz
        for k in range(10):
            src.write(0.5 * np.sin(2 * np.pi * 1000 * (t[:800] + k * 0.1)), 8000)
            time.sleep(0.1)
        time.sleep(0.5)
        rec.terminate()
        rec.wait(10)
        x, rate = soundfile.read(out)
        assert rate == 16000
        loud = x[np.abs(x) > 0.1]
        assert len(loud) > 4000, 'parecord heard %d loud samples' % len(loud)
        assert peak_hz(x, rate) == pytest.approx(1000, abs=5)
        assert src.written >= 14000 and src.dropped == 0
    finally:
        src.close()


def test_sink_played_by_paplay(pulse, tmp_path):
    got = []
    sink = ad.SpeakerSink(pulse, 'mds_speaker', 16000, str(tmp_path / 'sink'),
                          lambda x, r: got.append((x, r)))
    try:
        wav = str(tmp_path / 'tone.wav')
        t = np.arange(16000) / 16000.0
        soundfile.write(wav, 0.5 * np.sin(2 * np.pi * 440 * t), 16000)
        subprocess.run(['paplay', '-d', 'mds_speaker', wav], env=pulse.env(), timeout=30,
                       check=True)
        deadline = time.time() + 10
        while time.time() < deadline and sum(len(x) for x, _ in got) < 15000:
            time.sleep(0.05)
        assert got and all(r == 16000 for _, r in got)
        x = np.concatenate([x for x, _ in got])
        assert len(x) >= 15000
        assert peak_hz(x, 16000) == pytest.approx(440, abs=3)
        n = len(got)
        time.sleep(0.5)                    # nothing playing: silence is not sent
        assert len(got) == n
    finally:
        sink.close()
