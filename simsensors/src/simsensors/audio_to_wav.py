"""Write a microphone's audio (mobile_device_sim/AudioData) to a WAV file.

    rosrun mobile_device_sim audio_to_wav _topic:=/mobile_device/microphone/audio _file:=out.wav
        [_duration:=5.0]   (s of audio, then exit; 0: until Ctrl-C)

The file is written as chunks arrive (16-bit PCM at the message's sample rate and channel
count) and closed on exit. This machine has no sound card: play the file elsewhere.
"""


def main():
    """``rosrun mobile_device_sim audio_to_wav`` (the whole node; the script in
    simsensors/nodes/ only calls it)."""
    import threading
    import numpy as np
    import rospy
    import soundfile
    from mobile_device_sim.msg import AudioData
    rospy.init_node('audio_to_wav', anonymous=True)
    topic = rospy.get_param('~topic', '/mobile_device/microphone/audio')
    path = rospy.get_param('~file', 'out.wav')
    duration = float(rospy.get_param('~duration', 0.0))
    lock = threading.Lock()
    state = {'f': None, 'rate': None, 'ch': None, 'n': 0}

    def on_chunk(m):
        with lock:
            if state['f'] is None:
                if m.sample_rate <= 0 or m.channels < 1:
                    rospy.logerr('audio_to_wav: %s: chunk with sample_rate %d, channels %d '
                                 'ignored', topic, m.sample_rate, m.channels)
                    return
                state['f'] = soundfile.SoundFile(path, 'w', samplerate=m.sample_rate,
                                                 channels=m.channels, subtype='PCM_16')
                state['rate'], state['ch'] = m.sample_rate, m.channels
                rospy.loginfo('audio_to_wav: %s -> %s (%d Hz, %d ch)', topic, path,
                              m.sample_rate, m.channels)
            if (m.sample_rate, m.channels) != (state['rate'], state['ch']):
                rospy.logerr('audio_to_wav: %s: chunk at %d Hz/%d ch differs from the file\'s '
                             '%d Hz/%d ch; ignored', topic, m.sample_rate, m.channels,
                             state['rate'], state['ch'])
                return
            x = np.clip(np.asarray(m.samples, np.float32), -1, 1).reshape(-1, state['ch'])
            state['f'].write(x)
            state['n'] += len(x)
            if duration > 0 and state['n'] >= duration * state['rate']:
                rospy.signal_shutdown('%g s written' % duration)

    rospy.Subscriber(topic, AudioData, on_chunk, queue_size=1000)
    try:
        rospy.spin()
    finally:
        with lock:
            if state['f'] is not None:
                state['f'].close()
                rospy.loginfo('audio_to_wav: %s: %.2f s written', path,
                              state['n'] / float(state['rate']))
