"""Known test frames shared by the VM publisher and the checks: frame k of a cycle of
``N`` distinct RGB pictures (seeded noise shifted and xor'ed by k), and their expected
output bytes from the unit-tested converter (simvid.yuv), hashed whole and per half so a
frame whose top and bottom come from different pictures (a torn frame) is recognised."""
import hashlib
import os

import numpy as np

N = 24


def base(width, height):
    rng = np.random.RandomState(20111)
    return rng.randint(0, 256, (height, width, 3)).astype(np.uint8)


def picture(k, width, height, _cache={}):
    key = (width, height)
    if key not in _cache:
        _cache[key] = base(width, height)
    b = _cache[key]
    k %= N
    return np.ascontiguousarray(np.roll(b, 7 * k, axis=1) ^ np.uint8((37 * k) & 255))


def digest(data):
    return hashlib.sha1(data).hexdigest()


class Expected(object):
    """Hashes of the expected output frames: whole, top half, bottom half -> k.

    ``cache``: an .npy file with the frames, written by the host (vm_test) so the emulated
    guest does not spend half a minute converting; computed here when it is missing."""

    def __init__(self, width, height, cache=None):
        self.size = width * height * 2          # YUYV
        self.half = self.size // 2
        self.whole, self.top, self.bottom = {}, {}, {}
        stack = None
        if cache and os.path.exists(cache):
            stack = np.load(cache)
            if stack.shape != (N, self.size):
                stack = None
        if stack is None:
            from simvid.yuv import Converter   # imports OpenCV: slow under emulation
            conv = Converter(width, height, 'yuyv')
            stack = np.stack([np.frombuffer(conv.rgb_to_bytes(picture(k, width, height)),
                                            np.uint8) for k in range(N)])
        self.frames = [stack[k].tobytes() for k in range(N)]
        for k, data in enumerate(self.frames):
            self.whole[digest(data)] = k
            self.top[digest(data[:self.half])] = k
            self.bottom[digest(data[self.half:])] = k
        # black in the thesis's YUYV: y 16, u and v 128
        self.black = digest(bytes((16, 128, 16, 128)) * (width * height // 2))
        self.stack = stack

    def classify(self, data, top=None):
        """-> ('black'|'frame'|'torn'|'garbage', k). ``top``: bytes of the top half read
        earlier than ``data`` (a slow reader), else taken from ``data``."""
        if len(data) < self.size:
            return 'garbage', None
        data = data[:self.size]
        if top is None:
            d = digest(data)
            if d == self.black:
                return 'black', None
            if d in self.whole:
                return 'frame', self.whole[d]
            top = data[:self.half]
        kt = self.top.get(digest(top[:self.half]))
        kb = self.bottom.get(digest(data[self.half:]))
        if kt is not None and kt == kb:
            return 'frame', kt
        if kt is not None and kb is not None:
            return 'torn', (kt, kb)
        return 'garbage', None


def write_cache(path, width, height):
    """Host side: convert the pictures once and store them for the guest."""
    e = Expected(width, height)
    np.save(path, e.stack)


if __name__ == '__main__':
    import sys
    # frames.py PATH WIDTH HEIGHT [PATH WIDTH HEIGHT ...]: one process (one OpenCV import)
    a = sys.argv[1:]
    for i in range(0, len(a) - 2, 3):
        write_cache(a[i], int(a[i + 1]), int(a[i + 2]))
