"""Just enough of the V4L2 user API (linux/videodev2.h) for a loopback writer and reader.

ctypes structures with the x86_64 layout of the kernel's uapi header, the ioctl numbers
computed from their sizes the way _IOWR does, and two small classes:

* ``OutputDevice``: the writer side of thesis figures 4.5/4.6 (QUERYCAP, S_FMT, S_PARM,
  REQBUFS, QUERYBUF + mmap, QBUF, STREAMON, then DQBUF / fill / QBUF per frame), or the
  ``write()`` fallback.
* ``CaptureDevice``: a plain mmap reader (used by the VM test and benchmarks).

Errors are raised as ``DeviceError`` with one message that names the device and what was
wrong with it (missing, not a V4L2 device, not an output device, format refused ...).
"""
import ctypes
import errno
import fcntl
import mmap
import os
import select

__all__ = ['DeviceError', 'OutputDevice', 'CaptureDevice', 'fourcc', 'fourcc_str',
           'PIX_FMT', 'querycap', 'choose_io', 'rate_fraction']

# --- constants -------------------------------------------------------------------------
BUF_TYPE_VIDEO_CAPTURE = 1
BUF_TYPE_VIDEO_OUTPUT = 2
MEMORY_MMAP = 1
FIELD_NONE = 1
COLORSPACE_SRGB = 8
CAP_VIDEO_CAPTURE = 0x00000001
CAP_VIDEO_OUTPUT = 0x00000002
CAP_READWRITE = 0x01000000
CAP_STREAMING = 0x04000000
CAP_DEVICE_CAPS = 0x80000000
CAP_TIMEPERFRAME = 0x1000
FRMSIZE_TYPE_DISCRETE = 1
FRMIVAL_TYPE_DISCRETE = 1


def fourcc(code):
    """'YUYV' -> the little-endian 32 bit code V4L2 uses."""
    a, b, c, d = (ord(ch) for ch in code)
    return a | (b << 8) | (c << 16) | (d << 24)


def fourcc_str(value):
    return ''.join(chr((value >> s) & 0xff) for s in (0, 8, 16, 24))


# pixel_format parameter -> (fourcc, bytes per pixel)
PIX_FMT = {
    'yuyv': (fourcc('YUYV'), 2),
    'uyvy': (fourcc('UYVY'), 2),
    'rgb24': (fourcc('RGB3'), 3),
}


# --- structures (uapi/linux/videodev2.h, LP64) ---------------------------------------
class v4l2_capability(ctypes.Structure):
    _fields_ = [('driver', ctypes.c_char * 16), ('card', ctypes.c_char * 32),
                ('bus_info', ctypes.c_char * 32), ('version', ctypes.c_uint32),
                ('capabilities', ctypes.c_uint32), ('device_caps', ctypes.c_uint32),
                ('reserved', ctypes.c_uint32 * 3)]


class v4l2_pix_format(ctypes.Structure):
    _fields_ = [('width', ctypes.c_uint32), ('height', ctypes.c_uint32),
                ('pixelformat', ctypes.c_uint32), ('field', ctypes.c_uint32),
                ('bytesperline', ctypes.c_uint32), ('sizeimage', ctypes.c_uint32),
                ('colorspace', ctypes.c_uint32), ('priv', ctypes.c_uint32),
                ('flags', ctypes.c_uint32), ('ycbcr_enc', ctypes.c_uint32),
                ('quantization', ctypes.c_uint32), ('xfer_func', ctypes.c_uint32)]


class _fmt_union(ctypes.Union):
    # the kernel union holds v4l2_window (pointers): 8 byte aligned, 200 bytes
    _fields_ = [('pix', v4l2_pix_format), ('raw_data', ctypes.c_uint8 * 200),
                ('_align', ctypes.c_uint64)]


class v4l2_format(ctypes.Structure):
    _fields_ = [('type', ctypes.c_uint32), ('fmt', _fmt_union)]


class v4l2_fract(ctypes.Structure):
    _fields_ = [('numerator', ctypes.c_uint32), ('denominator', ctypes.c_uint32)]


class v4l2_outputparm(ctypes.Structure):
    _fields_ = [('capability', ctypes.c_uint32), ('outputmode', ctypes.c_uint32),
                ('timeperframe', v4l2_fract), ('extendedmode', ctypes.c_uint32),
                ('writebuffers', ctypes.c_uint32), ('reserved', ctypes.c_uint32 * 4)]


class v4l2_captureparm(ctypes.Structure):
    _fields_ = [('capability', ctypes.c_uint32), ('capturemode', ctypes.c_uint32),
                ('timeperframe', v4l2_fract), ('extendedmode', ctypes.c_uint32),
                ('readbuffers', ctypes.c_uint32), ('reserved', ctypes.c_uint32 * 4)]


class _parm_union(ctypes.Union):
    _fields_ = [('capture', v4l2_captureparm), ('output', v4l2_outputparm),
                ('raw_data', ctypes.c_uint8 * 200)]


class v4l2_streamparm(ctypes.Structure):
    _fields_ = [('type', ctypes.c_uint32), ('parm', _parm_union)]


class v4l2_requestbuffers(ctypes.Structure):
    _fields_ = [('count', ctypes.c_uint32), ('type', ctypes.c_uint32),
                ('memory', ctypes.c_uint32), ('capabilities', ctypes.c_uint32),
                ('flags', ctypes.c_uint8), ('reserved', ctypes.c_uint8 * 3)]


class timeval(ctypes.Structure):
    _fields_ = [('tv_sec', ctypes.c_long), ('tv_usec', ctypes.c_long)]


class v4l2_timecode(ctypes.Structure):
    _fields_ = [('type', ctypes.c_uint32), ('flags', ctypes.c_uint32),
                ('frames', ctypes.c_uint8), ('seconds', ctypes.c_uint8),
                ('minutes', ctypes.c_uint8), ('hours', ctypes.c_uint8),
                ('userbits', ctypes.c_uint8 * 4)]


class _buf_m(ctypes.Union):
    _fields_ = [('offset', ctypes.c_uint32), ('userptr', ctypes.c_ulong),
                ('planes', ctypes.c_void_p), ('fd', ctypes.c_int32)]


class v4l2_buffer(ctypes.Structure):
    _fields_ = [('index', ctypes.c_uint32), ('type', ctypes.c_uint32),
                ('bytesused', ctypes.c_uint32), ('flags', ctypes.c_uint32),
                ('field', ctypes.c_uint32), ('timestamp', timeval),
                ('timecode', v4l2_timecode), ('sequence', ctypes.c_uint32),
                ('memory', ctypes.c_uint32), ('m', _buf_m), ('length', ctypes.c_uint32),
                ('reserved2', ctypes.c_uint32), ('request_fd', ctypes.c_int32)]


class v4l2_fmtdesc(ctypes.Structure):
    _fields_ = [('index', ctypes.c_uint32), ('type', ctypes.c_uint32),
                ('flags', ctypes.c_uint32), ('description', ctypes.c_char * 32),
                ('pixelformat', ctypes.c_uint32), ('mbus_code', ctypes.c_uint32),
                ('reserved', ctypes.c_uint32 * 3)]


class v4l2_frmsize_discrete(ctypes.Structure):
    _fields_ = [('width', ctypes.c_uint32), ('height', ctypes.c_uint32)]


class _frmsize_union(ctypes.Union):
    _fields_ = [('discrete', v4l2_frmsize_discrete), ('stepwise', ctypes.c_uint32 * 6)]


class v4l2_frmsizeenum(ctypes.Structure):
    _fields_ = [('index', ctypes.c_uint32), ('pixel_format', ctypes.c_uint32),
                ('type', ctypes.c_uint32), ('u', _frmsize_union),
                ('reserved', ctypes.c_uint32 * 2)]


class _frmival_union(ctypes.Union):
    _fields_ = [('discrete', v4l2_fract), ('stepwise', v4l2_fract * 3)]


class v4l2_frmivalenum(ctypes.Structure):
    _fields_ = [('index', ctypes.c_uint32), ('pixel_format', ctypes.c_uint32),
                ('width', ctypes.c_uint32), ('height', ctypes.c_uint32),
                ('type', ctypes.c_uint32), ('u', _frmival_union),
                ('reserved', ctypes.c_uint32 * 2)]


# --- ioctl numbers (asm-generic/ioctl.h) ---------------------------------------------
_IOC_WRITE, _IOC_READ = 1, 2


def _ioc(direction, nr, size):
    return (direction << 30) | (size << 16) | (ord('V') << 8) | nr


def _IOR(nr, st):
    return _ioc(_IOC_READ, nr, ctypes.sizeof(st))


def _IOW(nr, st):
    return _ioc(_IOC_WRITE, nr, ctypes.sizeof(st))


def _IOWR(nr, st):
    return _ioc(_IOC_READ | _IOC_WRITE, nr, ctypes.sizeof(st))


VIDIOC_QUERYCAP = _IOR(0, v4l2_capability)
VIDIOC_ENUM_FMT = _IOWR(2, v4l2_fmtdesc)
VIDIOC_G_FMT = _IOWR(4, v4l2_format)
VIDIOC_S_FMT = _IOWR(5, v4l2_format)
VIDIOC_REQBUFS = _IOWR(8, v4l2_requestbuffers)
VIDIOC_QUERYBUF = _IOWR(9, v4l2_buffer)
VIDIOC_QBUF = _IOWR(15, v4l2_buffer)
VIDIOC_DQBUF = _IOWR(17, v4l2_buffer)
VIDIOC_STREAMON = _IOW(18, ctypes.c_int)
VIDIOC_STREAMOFF = _IOW(19, ctypes.c_int)
VIDIOC_G_PARM = _IOWR(21, v4l2_streamparm)
VIDIOC_S_PARM = _IOWR(22, v4l2_streamparm)
VIDIOC_ENUM_FRAMESIZES = _IOWR(74, v4l2_frmsizeenum)
VIDIOC_ENUM_FRAMEINTERVALS = _IOWR(75, v4l2_frmivalenum)


class DeviceError(RuntimeError):
    """A device that cannot be used as asked; the message names device and reason."""


def _ioctl(fd, request, arg, what, device):
    try:
        fcntl.ioctl(fd, request, arg)
    except OSError as e:
        raise DeviceError('%s: %s failed: %s' % (device, what, os.strerror(e.errno)))


def _open(device, flags):
    try:
        return os.open(device, flags)
    except FileNotFoundError:
        raise DeviceError('%s: no such device (is the v4l2loopback module loaded?)' % device)
    except OSError as e:
        raise DeviceError('%s: cannot open: %s' % (device, os.strerror(e.errno)))


def _map_buffers(fd, device, buf_type, count):
    """REQBUFS(count, MMAP) then QUERYBUF + mmap of every granted buffer -> [mmap]."""
    req = v4l2_requestbuffers()
    req.count, req.type, req.memory = count, buf_type, MEMORY_MMAP
    _ioctl(fd, VIDIOC_REQBUFS, req, 'VIDIOC_REQBUFS', device)
    if req.count < 1:
        raise DeviceError('%s: driver granted no mmap buffers' % device)
    maps = []
    for i in range(req.count):
        buf = v4l2_buffer()
        buf.index, buf.type, buf.memory = i, buf_type, MEMORY_MMAP
        _ioctl(fd, VIDIOC_QUERYBUF, buf, 'VIDIOC_QUERYBUF', device)
        maps.append((mmap.mmap(fd, buf.length, mmap.MAP_SHARED,
                               mmap.PROT_READ | mmap.PROT_WRITE, offset=buf.m.offset),
                     buf.length))
    return maps


def _release(fd, maps, buf_type, streaming):
    """STREAMOFF (if streaming), unmap, close."""
    if streaming:
        try:
            fcntl.ioctl(fd, VIDIOC_STREAMOFF, ctypes.c_int(buf_type))
        except OSError:
            pass
    for m in maps:
        try:
            m.close()
        except (BufferError, ValueError):
            pass
    os.close(fd)


def querycap(fd, device='device'):
    cap = v4l2_capability()
    try:
        fcntl.ioctl(fd, VIDIOC_QUERYCAP, cap)
    except OSError as e:
        if e.errno in (errno.ENOTTY, errno.EINVAL):
            raise DeviceError('%s: not a V4L2 device (VIDIOC_QUERYCAP: %s)'
                              % (device, os.strerror(e.errno)))
        raise DeviceError('%s: VIDIOC_QUERYCAP failed: %s' % (device, os.strerror(e.errno)))
    caps = cap.device_caps if cap.capabilities & CAP_DEVICE_CAPS else cap.capabilities
    return cap, caps


class OutputDevice(object):
    """A V4L2 video output device (the writer end of a loopback device).

    ``io_method`` 'mmap' (the thesis's choice) streams through mmap'd driver buffers,
    'write' uses write(2). Frames are bytes-like objects of exactly ``frame_size`` bytes.
    """

    def __init__(self, device, width, height, fps, pixel_format='yuyv', io_method='mmap',
                 buffers=4):
        if pixel_format not in PIX_FMT:
            raise DeviceError('%s: unsupported pixel_format %r (use one of %s)'
                              % (device, pixel_format, ', '.join(sorted(PIX_FMT))))
        if io_method not in ('mmap', 'write'):
            raise DeviceError('%s: unsupported io_method %r (use mmap or write)'
                              % (device, io_method))
        self.device = device
        self.width, self.height = int(width), int(height)
        self.fps = float(fps)
        self.pixel_format = pixel_format
        self.io_method = self.requested_io = io_method
        self.fallback = None     # why io_method differs from the requested one
        self.fourcc, bpp = PIX_FMT[pixel_format]
        self.bytesperline = self.width * bpp
        self.frame_size = self.bytesperline * self.height
        self.fd = None
        self.maps = []
        self.streaming = False
        self._fresh = []
        self.frames_written = 0
        self._open(buffers)

    # -- set-up, in the order of thesis figure 4.5 (a) --------------------------------
    def _open(self, nbuffers):
        self.fd = _open(self.device, os.O_RDWR)
        try:
            cap, caps = querycap(self.fd, self.device)
            self.driver = cap.driver.decode(errors='replace')
            if not caps & CAP_VIDEO_OUTPUT:
                raise DeviceError('%s: not a video output device (driver %r, capabilities '
                                  '0x%08x have no VIDEO_OUTPUT)' % (self.device, self.driver,
                                                                   caps))
            self.io_method = choose_io(caps, self.io_method, self.device)
            if self.io_method != self.requested_io:
                self.fallback = 'the device has no streaming I/O'
            self._set_format()
            self._set_rate()
            if self.io_method == 'mmap':
                try:
                    self._setup_mmap(nbuffers)
                except DeviceError as e:
                    if not caps & CAP_READWRITE:
                        raise
                    # write(2) as the fallback of the thesis's mmap I/O
                    for m in self.maps:
                        m.close()
                    self.maps, self.io_method, self.fallback = [], 'write', str(e)
        except Exception:
            self.close()
            raise

    def _set_format(self):
        fmt = v4l2_format()
        fmt.type = BUF_TYPE_VIDEO_OUTPUT
        _ioctl(self.fd, VIDIOC_G_FMT, fmt, 'VIDIOC_G_FMT', self.device)
        fmt.type = BUF_TYPE_VIDEO_OUTPUT
        pix = fmt.fmt.pix
        pix.width, pix.height = self.width, self.height
        pix.pixelformat = self.fourcc
        pix.field = FIELD_NONE
        pix.bytesperline = self.bytesperline
        pix.sizeimage = self.frame_size
        pix.colorspace = COLORSPACE_SRGB
        _ioctl(self.fd, VIDIOC_S_FMT, fmt, 'VIDIOC_S_FMT', self.device)
        got = fmt.fmt.pix
        if (got.width, got.height, got.pixelformat) != (self.width, self.height,
                                                         self.fourcc):
            raise DeviceError('%s: device keeps format %dx%d %s, writer wants %dx%d %s '
                              '(another writer or a reader holds the old format)'
                              % (self.device, got.width, got.height,
                                 fourcc_str(got.pixelformat), self.width, self.height,
                                 fourcc_str(self.fourcc)))
        if got.bytesperline and got.bytesperline != self.bytesperline:
            raise DeviceError('%s: driver wants %d bytes per line, not %d'
                              % (self.device, got.bytesperline, self.bytesperline))

    def _set_rate(self):
        """VIDIOC_S_PARM: announce the frame rate (readers see it in ENUM_FRAMEINTERVALS)."""
        parm = v4l2_streamparm()
        parm.type = BUF_TYPE_VIDEO_OUTPUT
        num, den = rate_fraction(self.fps)
        parm.parm.output.timeperframe.numerator = num
        parm.parm.output.timeperframe.denominator = den
        parm.parm.output.capability = CAP_TIMEPERFRAME
        _ioctl(self.fd, VIDIOC_S_PARM, parm, 'VIDIOC_S_PARM', self.device)
        tpf = parm.parm.output.timeperframe
        self.announced_fps = (tpf.denominator / float(tpf.numerator)) if tpf.numerator else 0.0

    def _setup_mmap(self, nbuffers):
        maps = _map_buffers(self.fd, self.device, BUF_TYPE_VIDEO_OUTPUT, nbuffers)
        self.maps = [m for m, _ in maps]
        for i, (_, length) in enumerate(maps):
            if length < self.frame_size:
                raise DeviceError('%s: buffer %d has %d bytes, a frame needs %d'
                                  % (self.device, i, length, self.frame_size))
        # Start streaming; every buffer is first filled with a real frame and queued
        # (figure 4.5 a), after that a buffer is reclaimed with DQBUF (figure 4.6). An empty
        # buffer is never queued: a loopback driver would hand it to the readers as a frame.
        self._fresh = list(range(len(self.maps)))
        t = ctypes.c_int(BUF_TYPE_VIDEO_OUTPUT)
        _ioctl(self.fd, VIDIOC_STREAMON, t, 'VIDIOC_STREAMON', self.device)
        self.streaming = True

    # -- per frame (figure 4.6) ---------------------------------------------------------
    def write(self, frame):
        mv = memoryview(frame).cast('B')
        if mv.nbytes != self.frame_size:
            raise ValueError('frame has %d bytes, %dx%d %s needs %d'
                             % (mv.nbytes, self.width, self.height, self.pixel_format,
                                self.frame_size))
        if self.io_method == 'write':
            try:
                n = os.write(self.fd, mv)
            except OSError as e:
                raise DeviceError('%s: write failed: %s' % (self.device, os.strerror(e.errno)))
            if n != self.frame_size:
                raise DeviceError('%s: short write (%d of %d bytes)'
                                  % (self.device, n, self.frame_size))
        else:
            buf = v4l2_buffer()
            buf.type, buf.memory = BUF_TYPE_VIDEO_OUTPUT, MEMORY_MMAP
            if self._fresh:
                buf.index = self._fresh.pop(0)
            else:
                _ioctl(self.fd, VIDIOC_DQBUF, buf, 'VIDIOC_DQBUF', self.device)
            m = self.maps[buf.index % len(self.maps)]
            m[:self.frame_size] = mv
            buf.bytesused = self.frame_size
            buf.field = FIELD_NONE
            _ioctl(self.fd, VIDIOC_QBUF, buf, 'VIDIOC_QBUF', self.device)
        self.frames_written += 1

    def close(self):
        if self.fd is None:
            return
        _release(self.fd, self.maps, BUF_TYPE_VIDEO_OUTPUT, self.streaming)
        self.maps, self.streaming, self.fd = [], False, None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def choose_io(caps, requested, device='device'):
    """The I/O method to use: mmap (the thesis's choice) when the device streams, write(2)
    as its fallback; a clear error when the device offers neither."""
    if requested == 'mmap' and caps & CAP_STREAMING:
        return 'mmap'
    if caps & CAP_READWRITE:
        return 'write'
    if requested == 'write' and caps & CAP_STREAMING:
        raise DeviceError('%s: no read/write I/O, use io_method mmap' % device)
    raise DeviceError('%s: offers neither streaming nor read/write I/O' % device)


def rate_fraction(fps):
    """fps -> (numerator, denominator) of the time per frame, e.g. 15 -> (1, 15),
    29.97 -> (100, 2997)."""
    fps = float(fps)
    if not fps > 0:
        raise ValueError('fps must be positive, got %r' % fps)
    if abs(fps - round(fps)) < 1e-9:
        return 1, int(round(fps))
    return 1000, int(round(fps * 1000))


class CaptureDevice(object):
    """Minimal mmap capture reader: format, sizes, intervals and raw frames."""

    def __init__(self, device, buffers=4, nonblock=False):
        self.device = device
        self.fd = _open(device, os.O_RDWR | (os.O_NONBLOCK if nonblock else 0))
        self.maps = []
        self.streaming = False
        self.nbuffers = buffers

    def caps(self):
        return querycap(self.fd, self.device)[1]

    def get_format(self):
        fmt = v4l2_format()
        fmt.type = BUF_TYPE_VIDEO_CAPTURE
        _ioctl(self.fd, VIDIOC_G_FMT, fmt, 'VIDIOC_G_FMT', self.device)
        p = fmt.fmt.pix
        return p.width, p.height, fourcc_str(p.pixelformat), p.bytesperline, p.sizeimage

    def frame_sizes(self, pixfmt):
        out = []
        i = 0
        while True:
            e = v4l2_frmsizeenum()
            e.index, e.pixel_format = i, fourcc(pixfmt) if isinstance(pixfmt, str) else pixfmt
            try:
                fcntl.ioctl(self.fd, VIDIOC_ENUM_FRAMESIZES, e)
            except OSError:
                return out
            if e.type == FRMSIZE_TYPE_DISCRETE:
                out.append((e.u.discrete.width, e.u.discrete.height))
            else:
                out.append(('stepwise', tuple(e.u.stepwise)))
            i += 1

    def frame_intervals(self, pixfmt, width, height):
        out = []
        i = 0
        while True:
            e = v4l2_frmivalenum()
            e.index = i
            e.pixel_format = fourcc(pixfmt) if isinstance(pixfmt, str) else pixfmt
            e.width, e.height = width, height
            try:
                fcntl.ioctl(self.fd, VIDIOC_ENUM_FRAMEINTERVALS, e)
            except OSError:
                return out
            if e.type == FRMIVAL_TYPE_DISCRETE:
                out.append((e.u.discrete.numerator, e.u.discrete.denominator))
            else:
                out.append(('stepwise',))
            i += 1

    def start(self):
        self.maps = [m for m, _ in _map_buffers(self.fd, self.device, BUF_TYPE_VIDEO_CAPTURE,
                                                 self.nbuffers)]
        for i in range(len(self.maps)):
            buf = v4l2_buffer()
            buf.index, buf.type, buf.memory = i, BUF_TYPE_VIDEO_CAPTURE, MEMORY_MMAP
            _ioctl(self.fd, VIDIOC_QBUF, buf, 'VIDIOC_QBUF', self.device)
        _ioctl(self.fd, VIDIOC_STREAMON, ctypes.c_int(BUF_TYPE_VIDEO_CAPTURE),
               'VIDIOC_STREAMON', self.device)
        self.streaming = True

    def read(self, timeout=5.0, hold=None):
        """Dequeue one frame; returns (bytes, v4l2_buffer). ``hold`` (callable) is called
        with the mapped buffer before it is copied and requeued, to model a slow reader."""
        r, _, _ = select.select([self.fd], [], [], timeout)
        if not r:
            raise DeviceError('%s: no frame within %.1f s' % (self.device, timeout))
        buf = v4l2_buffer()
        buf.type, buf.memory = BUF_TYPE_VIDEO_CAPTURE, MEMORY_MMAP
        _ioctl(self.fd, VIDIOC_DQBUF, buf, 'VIDIOC_DQBUF', self.device)
        m = self.maps[buf.index % len(self.maps)]
        if hold is not None:
            hold(m)
        data = bytes(m[:buf.bytesused or len(m)])
        _ioctl(self.fd, VIDIOC_QBUF, buf, 'VIDIOC_QBUF', self.device)
        return data, buf

    def close(self):
        if self.fd is None:
            return
        _release(self.fd, self.maps, BUF_TYPE_VIDEO_CAPTURE, self.streaming)
        self.maps, self.streaming, self.fd = [], False, None
