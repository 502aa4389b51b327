"""image_sink without a roscore: pacing, the device writer's error handling and retries,
bad input, and the V4L2 ioctl layout against the kernel's own header."""
import ctypes
import os
import shutil
import subprocess

import numpy as np
import pytest

from simvid import v4l2
from simvid.image_sink import DeviceWriter, FramePacer, ImageSink, OnceLogger
from simvid.imageconv import array_to_image
from simvid.yuv import Converter


class Clock(object):
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


class FakeDevice(object):
    """Stands in for OutputDevice; counts frames, can be told to fail."""
    instances = []

    def __init__(self, device, width, height, fps, pixel_format, io_method):
        self.frames = []
        self.fail_write = False
        self.closed = False
        self.driver = 'fake'
        FakeDevice.instances.append(self)

    def write(self, frame):
        if self.fail_write:
            raise v4l2.DeviceError('fake: VIDIOC_DQBUF failed: No such device')
        self.frames.append(bytes(frame))

    def close(self):
        self.closed = True


def test_pacer_rate_and_no_bursts():
    clock = Clock()
    p = FramePacer(10, clock)
    assert p.wait_time() == 0
    p.done()
    assert p.wait_time() == pytest.approx(0.1)
    clock.t += 0.1
    assert p.wait_time() == 0
    p.done()
    clock.t += 5.0   # the writer stalled for 5 s: one frame is due, not 50
    assert p.wait_time() == 0
    p.done()
    assert p.wait_time() > 0
    with pytest.raises(ValueError):
        FramePacer(0)


def test_once_logger():
    lines = []
    log = OnceLogger(lines.append)
    for _ in range(5):
        log('a')
    log('b')
    log('b')
    log.reset()
    log('b')
    assert lines == ['a', 'b', 'b']


def test_missing_device_one_error_line_and_retry():
    clock, errors, infos = Clock(), [], []
    w = DeviceWriter('/dev/mds_no_such_video', 64, 48, 15, retry_period=1.0,
                     log_error=errors.append, log_info=infos.append, clock=clock)
    frame = bytes(64 * 48 * 2)
    for _ in range(20):
        assert not w.write(frame)
        clock.t += 0.25
    assert len(errors) == 1
    assert '/dev/mds_no_such_video: no such device' in errors[0]
    assert w.failures == 5   # retried once per second, not on every frame


def test_not_a_v4l2_device():
    with pytest.raises(v4l2.DeviceError, match='/dev/null: not a V4L2 device'):
        v4l2.OutputDevice('/dev/null', 64, 48, 15)


def test_not_an_output_device_message(monkeypatch):
    """QUERYCAP of a capture-only device (v4l2loopback with exclusive_caps=1 while another
    writer streams) -> OutputDevice refuses it with one message and closes the fd."""
    cap = v4l2.v4l2_capability()
    cap.driver = b'v4l2 loopback'
    caps = v4l2.CAP_VIDEO_CAPTURE | v4l2.CAP_STREAMING
    monkeypatch.setattr(v4l2, 'querycap', lambda fd, device: (cap, caps))
    closed = []
    real_close = os.close
    monkeypatch.setattr(v4l2.os, 'close', lambda fd: (closed.append(fd), real_close(fd)))
    with pytest.raises(v4l2.DeviceError) as e:
        v4l2.OutputDevice('/dev/null', 64, 48, 15)
    assert str(e.value).startswith('/dev/null: not a video output device')
    assert "'v4l2 loopback'" in str(e.value) and len(closed) == 1


def test_writer_reopens_after_a_device_error():
    clock, errors = Clock(), []
    FakeDevice.instances = []
    w = DeviceWriter('/dev/videoF', 8, 4, 15, log_error=errors.append, log_info=lambda m: 0,
                     clock=clock, opener=FakeDevice)
    assert w.write(b'x' * 64)
    FakeDevice.instances[0].fail_write = True
    assert not w.write(b'x' * 64)
    assert FakeDevice.instances[0].closed and not w.is_open
    assert not w.write(b'x' * 64)        # still within retry_period
    clock.t += 1.0
    assert w.write(b'x' * 64)            # reopened: a second device object
    assert len(FakeDevice.instances) == 2 and w.opens == 2
    assert len(errors) == 1 and 'VIDIOC_DQBUF failed' in errors[0]


def make_sink(**params):
    clock, errors, infos = Clock(), [], []
    FakeDevice.instances = []
    p = dict(width=8, height=4, fps=10, device='/dev/videoF')
    p.update(params)
    s = ImageSink(p, log_error=errors.append, log_info=infos.append, clock=clock,
                  opener=FakeDevice)
    return s, clock, errors


def test_black_until_first_image_then_repeat_last():
    s, clock, errors = make_sink()
    conv = Converter(8, 4)
    assert s.step()
    dev = FakeDevice.instances[0]
    assert dev.frames[0] == conv.rgb_to_bytes(np.zeros((4, 8, 3), np.uint8))
    img = np.full((4, 8, 3), 99, np.uint8)
    assert s.on_image(array_to_image(img, 'rgb8'))
    s.step()
    s.step()
    s.step()
    assert dev.frames[1] == dev.frames[2] == dev.frames[3] == conv.rgb_to_bytes(img)
    assert s.stats['written'] == 4 and s.stats['repeated'] == 2
    assert errors == []


def test_newest_image_wins_when_topic_is_faster():
    s, clock, _ = make_sink()
    for v in (10, 20, 30):
        s.on_image(array_to_image(np.full((4, 8, 3), v, np.uint8), 'rgb8'))
    s.step()
    frame = np.frombuffer(FakeDevice.instances[0].frames[-1], np.uint8)
    assert frame[0] == ((879 * 30) >> 10) + 16


def test_unsupported_encoding_one_line_keeps_serving():
    s, clock, errors = make_sink()
    good = array_to_image(np.full((4, 8, 3), 50, np.uint8), 'rgb8')
    s.on_image(good)
    from sensor_msgs.msg import Image
    bad = Image(height=4, width=8, encoding='weird42', step=8, data=bytes(32))
    for _ in range(10):
        assert not s.on_image(bad)
        s.step()
    assert len(errors) == 1 and 'weird42' in errors[0] and '/camera/image_raw' in errors[0]
    frames = FakeDevice.instances[0].frames
    assert len(frames) == 10 and len(set(frames)) == 1   # last good picture kept
    assert s.stats['bad_images'] == 10


def test_odd_width_parameter_is_padded_with_one_line():
    s, clock, errors = make_sink(width=641, height=480)
    assert s.converter.width == 642 and len(errors) == 1 and 'odd' in errors[0]


def test_spin_paces_and_closes():
    s, clock, _ = make_sink(fps=20)
    ticks = []

    def sleep(dt):
        clock.t += dt

    def stop():
        ticks.append(clock.t)
        return clock.t >= 101.0
    s.spin(stop, sleep=sleep)
    assert 19 <= s.stats['written'] <= 21     # one second at 20 fps
    assert FakeDevice.instances[0].closed


def test_bad_parameters():
    with pytest.raises(ValueError):
        ImageSink({'pixel_format': 'nv12'}, opener=FakeDevice)
    with pytest.raises(ValueError):
        ImageSink({'fps': 0}, opener=FakeDevice)
    with pytest.raises(v4l2.DeviceError, match='io_method'):
        v4l2.OutputDevice('/dev/null', 8, 4, 15, io_method='userptr')


def test_io_method_choice_and_fallback():
    S, RW = v4l2.CAP_STREAMING, v4l2.CAP_READWRITE
    assert v4l2.choose_io(S | RW, 'mmap') == 'mmap'
    assert v4l2.choose_io(S | RW, 'write') == 'write'
    assert v4l2.choose_io(RW, 'mmap') == 'write'          # write(2) is mmap's fallback
    with pytest.raises(v4l2.DeviceError, match='no read/write I/O'):
        v4l2.choose_io(S, 'write', '/dev/videoX')
    with pytest.raises(v4l2.DeviceError, match='neither streaming nor read/write'):
        v4l2.choose_io(0, 'mmap', '/dev/videoX')


def test_fallback_is_named_in_the_info_line():
    class WriteOnly(FakeDevice):
        def __init__(self, *a, **k):
            FakeDevice.__init__(self, *a, **k)
            self.io_method, self.fallback = 'write', 'VIDIOC_REQBUFS failed: Invalid argument'
    infos = []
    w = DeviceWriter('/dev/videoF', 8, 4, 15, log_error=lambda m: 0, log_info=infos.append,
                     clock=Clock(), opener=WriteOnly)
    assert w.write(b'x' * 64)
    assert 'write I/O instead of mmap: VIDIOC_REQBUFS failed' in infos[0]


def test_rate_fraction():
    assert v4l2.rate_fraction(15) == (1, 15)
    assert v4l2.rate_fraction(29.97) == (1000, 29970)
    with pytest.raises(ValueError):
        v4l2.rate_fraction(-1)


C_SIZES = r'''
#include <stdio.h>
#include <stddef.h>
#include <linux/videodev2.h>
int main(void) {
  printf("%zu %zu %zu %zu %zu %zu %zu %zu %zu %zu\n",
    sizeof(struct v4l2_capability), sizeof(struct v4l2_format),
    sizeof(struct v4l2_requestbuffers), sizeof(struct v4l2_buffer),
    sizeof(struct v4l2_streamparm), sizeof(struct v4l2_fmtdesc),
    sizeof(struct v4l2_frmsizeenum), sizeof(struct v4l2_frmivalenum),
    offsetof(struct v4l2_buffer, m), offsetof(struct v4l2_buffer, length));
  printf("%lu %lu %lu %lu %lu\n", (unsigned long)VIDIOC_QUERYCAP, (unsigned long)VIDIOC_S_FMT,
    (unsigned long)VIDIOC_QBUF, (unsigned long)VIDIOC_S_PARM,
    (unsigned long)VIDIOC_ENUM_FRAMEINTERVALS);
  return 0;
}
'''


@pytest.mark.skipif(not shutil.which('cc') or not os.path.exists('/usr/include/linux/videodev2.h'),
                    reason='needs a C compiler and linux/videodev2.h')
def test_struct_layout_matches_kernel_header(tmp_path):
    src = tmp_path / 'sizes.c'
    src.write_text(C_SIZES)
    exe = tmp_path / 'sizes'
    subprocess.check_call(['cc', '-o', str(exe), str(src)])
    sizes, ioctls = subprocess.check_output([str(exe)], text=True).splitlines()
    want = [int(x) for x in sizes.split()]
    got = [ctypes.sizeof(t) for t in (v4l2.v4l2_capability, v4l2.v4l2_format,
                                      v4l2.v4l2_requestbuffers, v4l2.v4l2_buffer,
                                      v4l2.v4l2_streamparm, v4l2.v4l2_fmtdesc,
                                      v4l2.v4l2_frmsizeenum, v4l2.v4l2_frmivalenum)]
    got += [v4l2.v4l2_buffer.m.offset, v4l2.v4l2_buffer.length.offset]
    assert got == want
    assert [int(x) for x in ioctls.split()] == [
        v4l2.VIDIOC_QUERYCAP, v4l2.VIDIOC_S_FMT, v4l2.VIDIOC_QBUF, v4l2.VIDIOC_S_PARM,
        v4l2.VIDIOC_ENUM_FRAMEINTERVALS]
