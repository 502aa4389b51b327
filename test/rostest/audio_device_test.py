#!/usr/bin/env python3
"""rostest: the phone's microphone and speaker as PulseAudio devices (audio_device.test).
Unmodified parecord / paplay against a private daemon started by the node."""
import os
import subprocess
import tempfile
import time
import unittest

import numpy as np
import rospy
import rostest
import soundfile

from mobile_device_sim.msg import AudioData
from common import sim_sleep as wait_sim, start, wait_connected  # noqa: E402

A, B = 'mobile_device', 'mobile_device_b'
SR = 16000


def peak_hz(x, rate):
    x = np.asarray(x, float)
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    return float(np.fft.rfftfreq(len(x), 1.0 / rate)[np.argmax(spec)])


def tone(freq, seconds, amp=0.5):
    t = np.arange(int(SR * seconds)) / float(SR)
    return amp * np.sin(2 * np.pi * freq * t)


class AudioDevice(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        start('audio_device_test', [B])
        deadline = time.time() + 60
        while time.time() < deadline and not rospy.has_param('/audio_device/server'):
            time.sleep(0.1)
        cls.env = dict(os.environ, PULSE_SERVER=rospy.get_param('/audio_device/server'))
        cls.chunks = []
        cls.sub = rospy.Subscriber('/%s/microphone/audio' % B, AudioData, cls.chunks.append,
                                   queue_size=1000)
        cls.spk = rospy.Publisher('/%s/speaker/audio' % A, AudioData, queue_size=10)
        # the world listens to A's speaker (audio_device publishes into it: the sink)
        wait_connected(cls.spk, cls.sub, 1)
        cls.tmp = tempfile.mkdtemp(prefix='audio_device_test_')

    def test_parecord_hears_phone_a_through_phone_b(self):
        out = os.path.join(self.tmp, 'rec.wav')
        rec = subprocess.Popen(['parecord', '-d', 'mds_microphone', '--rate=%d' % SR,
                                '--channels=1', '--format=s16le', '--file-format=wav', out],
                               env=self.env)
        try:
            time.sleep(0.5)
            self.spk.publish(AudioData(sample_rate=SR, channels=1,
                                       samples=tone(1000.0, 1.0).astype(np.float32).tolist()))
            wait_sim(2.0)
            time.sleep(0.5)
        finally:
            rec.terminate()
            rec.wait(10)
        x, rate = soundfile.read(out)
        self.assertEqual(rate, SR)
        self.assertGreater(len(x), SR // 2, 'parecord recorded %d samples' % len(x))
        self.assertGreater(np.abs(x).max(), 1e-3, 'parecord heard silence')
        self.assertAlmostEqual(peak_hz(x, rate), 1000.0, delta=5.0)

    def test_paplay_into_the_sink_is_heard_in_the_world(self):
        wav = os.path.join(self.tmp, 'tone.wav')
        soundfile.write(wav, tone(440.0, 1.0), SR)
        t0 = rospy.get_time()
        del self.chunks[:]
        subprocess.run(['paplay', '-d', 'mds_speaker', wav], env=self.env, timeout=60,
                       check=True)
        wait_sim(2.0)
        chunks = [c for c in list(self.chunks) if c.header.stamp.to_sec() >= t0 - 1e-6]
        self.assertTrue(chunks, 'no microphone chunks from %s' % B)
        x = np.concatenate([np.asarray(c.samples, float) for c in chunks])
        self.assertGreater(np.abs(x).max(), 1e-4, 'phone B heard nothing')
        self.assertAlmostEqual(peak_hz(x, SR), 440.0, delta=3.0)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'audio_device_pulse', AudioDevice)
