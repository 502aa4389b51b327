#!/usr/bin/env python3
"""rostest: a tone on phone A's speaker heard by phone B's microphone (audio.test)."""
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import Pose, Twist

from mobile_device_sim.msg import AudioData, ModelState
from common import sim_sleep as wait_sim, start, wait_connected  # noqa: E402

A, B = 'mobile_device', 'mobile_device_b'
FREQ = 1000.0
SR = 16000


class Audio(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.get, cls.set = start('audio_test', [B])
        cls.chunks = []
        cls.sub = rospy.Subscriber('/%s/microphone/audio' % B, AudioData, cls.chunks.append,
                                   queue_size=1000)
        cls.spk = rospy.Publisher('/%s/speaker/audio' % A, AudioData, queue_size=10)
        wait_connected(cls.spk, cls.sub)

    def link_point(self, model, offset):
        """World position of a point fixed in the model's base link."""
        s = self.get(model, 'world')
        self.assertTrue(s.success, s.status_message)
        q, p = s.pose.orientation, s.pose.position
        u, w, v = np.array([q.x, q.y, q.z]), q.w, np.asarray(offset, float)
        rotated = v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))
        return np.array([p.x, p.y, p.z]) + rotated

    def distance(self):
        # speaker: 0.058 m toward the top, under the front face; microphone: bottom end
        a = self.link_point(A, (0.058, 0, 0.00444))
        b = self.link_point(B, (-0.06095, 0, 0))
        return float(np.linalg.norm(a - b))

    def play_and_hear(self):
        """Play 0.5 s of tone; return (samples heard during it, peak Hz)."""
        del self.chunks[:]
        t = np.arange(SR // 2) / float(SR)
        m = AudioData(sample_rate=SR, channels=1,
                      samples=(0.5 * np.sin(2 * np.pi * FREQ * t)).astype(np.float32).tolist())
        t0 = rospy.get_time()
        self.spk.publish(m)
        wait_sim(1.5)
        chunks = [c for c in list(self.chunks) if c.header.stamp.to_sec() >= t0 - 1e-6]
        self.assertTrue(chunks, 'no microphone chunks from %s' % B)
        self.assertTrue(all(c.sample_rate == SR and c.channels == 1 for c in chunks))
        x = np.concatenate([np.asarray(c.samples, float) for c in chunks])
        # the tone's 0.5 s: the windows of 0.05 s whose level is above half the loudest
        win = SR // 20
        rms = np.array([np.sqrt(np.mean(x[i:i + win] ** 2))
                        for i in range(0, len(x) - win + 1, win)])
        self.assertGreater(rms.max(), 1e-4, 'phone B heard nothing')
        on = rms > 0.5 * rms.max()
        self.assertTrue(7 <= on.sum() <= 11, 'tone length in windows: %d' % on.sum())
        tone = np.concatenate([x[i * win:(i + 1) * win] for i in np.nonzero(on)[0]])
        n = 1 << 17
        spec = np.abs(np.fft.rfft(tone * np.hanning(len(tone)), n))
        return float(np.median(rms[on])), np.argmax(spec) * SR / float(n)

    def move_b(self, dy):
        s = self.get(B, 'world')
        p = s.pose
        p.position.y += dy
        r = self.set(ModelState(model_name=B, pose=p, twist=Twist(), reference_frame='world'))
        self.assertTrue(r.success, r.status_message)
        wait_sim(1.0)

    def test_tone_arrives_with_frequency_and_level_falling_with_distance(self):
        wait_sim(1.0)                     # both phones at rest
        d1 = self.distance()
        level1, f1 = self.play_and_hear()
        self.move_b(1.0)
        d2 = self.distance()
        level2, f2 = self.play_and_hear()
        rospy.loginfo('d %.3f m: level %.4f, %.1f Hz; d %.3f m: level %.4f, %.1f Hz',
                      d1, level1, f1, d2, level2, f2)
        self.assertGreater(d2, d1 + 0.5)
        self.assertAlmostEqual(f1, FREQ, delta=3.0)
        self.assertAlmostEqual(f2, FREQ, delta=3.0)
        self.assertLess(level2, level1)
        # 1/r: the level ratio is the inverse distance ratio
        self.assertAlmostEqual(level1 / level2, d2 / d1, delta=0.1 * d2 / d1)

    def test_audio_to_wav_writes_the_microphone(self):
        import os
        import subprocess
        import tempfile
        import soundfile
        path = os.path.join(tempfile.mkdtemp(), 'mic_b.wav')
        proc = subprocess.Popen(['rosrun', 'mobile_device_sim', 'audio_to_wav',
                                 '_topic:=/%s/microphone/audio' % B, '_file:=' + path,
                                 '_duration:=1.0', '__name:=audio_to_wav_test'])
        try:
            self.assertEqual(proc.wait(timeout=120), 0)
        finally:
            if proc.poll() is None:
                proc.kill()
        info = soundfile.info(path)
        self.assertEqual((info.samplerate, info.channels), (SR, 1))
        self.assertGreaterEqual(info.frames, SR)
        self.assertLess(info.frames, SR + SR // 5)


if __name__ == '__main__':
    rostest.rosrun('mobile_device_sim', 'audio', Audio)
