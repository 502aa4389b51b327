"""A real VNC server for tests, benchmarks and demos: Debian's Xtigervnc on 127.0.0.1.

``XVncServer`` starts ``Xtigervnc :N -localhost -rfbport P`` (no authentication, or VNC
password authentication with a file written by ``tigervncpasswd -f``), draws known content
on its screen with python-xlib (the root window's background pixmap, so it stays put),
resizes the screen with ``xrandr --fb`` and can be killed and restarted on the same port.
"""
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

import numpy as np


def free_display_and_port():
    """An X display number with no socket/lock and a free TCP port on 127.0.0.1."""
    for n in range(40 + os.getpid() % 200, 400):
        if not (os.path.exists('/tmp/.X11-unix/X%d' % n) or os.path.exists('/tmp/.X%d-lock' % n)):
            break
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()
    return n, port


def make_passwd_file(password, path):
    """Write a VNC password file (obfuscated DES, as vncpasswd does) with tigervncpasswd."""
    exe = shutil.which('tigervncpasswd') or shutil.which('vncpasswd')
    if not exe:
        raise RuntimeError('tigervncpasswd missing: tools/setup installs tigervnc-tools')
    out = subprocess.run([exe, '-f'], input=(password + '\n').encode(), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, check=True).stdout
    with open(path, 'wb') as f:
        f.write(out)
    os.chmod(path, 0o600)
    return path


def pattern(width, height, seed=0, block=16):
    """A known RGB test picture: random colour blocks with a diagonal gradient, so that
    a shifted, mirrored, channel-swapped or partly stale copy never matches."""
    rng = np.random.RandomState(seed)
    by, bx = (height + block - 1) // block, (width + block - 1) // block
    blocks = rng.randint(0, 256, size=(by, bx, 3)).astype(np.uint8)
    img = np.repeat(np.repeat(blocks, block, 0), block, 1)[:height, :width].copy()
    yy, xx = np.mgrid[0:height, 0:width]
    img[:, :, 1] ^= ((xx + yy) & 0xff).astype(np.uint8)
    return img


class XVncServer(object):
    def __init__(self, width=320, height=240, password=None, display=None, port=None,
                 extra_args=()):
        d, p = free_display_and_port()
        self.display = d if display is None else display
        self.port = p if port is None else port
        self.width, self.height = width, height
        self.password = password
        self.extra_args = list(extra_args)
        self.tmp = tempfile.mkdtemp(prefix='xvnc%d-' % self.display)
        self.passwd_file = None
        if password is not None:
            self.passwd_file = make_passwd_file(password, os.path.join(self.tmp, 'passwd'))
        self.proc = None
        self.log_path = os.path.join(self.tmp, 'Xtigervnc.log')
        self._x = None

    @property
    def env(self):
        e = dict(os.environ)
        e['DISPLAY'] = ':%d' % self.display
        return e

    def start(self, timeout=10.0):
        exe = shutil.which('Xtigervnc')
        if not exe:
            raise RuntimeError('Xtigervnc missing: tools/setup installs tigervnc-standalone-server')
        args = [exe, ':%d' % self.display, '-localhost', '-rfbport', str(self.port),
                '-geometry', '%dx%d' % (self.width, self.height), '-depth', '24',
                '-AlwaysShared', '-nolisten', 'tcp']
        if self.passwd_file:
            args += ['-SecurityTypes', 'VncAuth', '-rfbauth', self.passwd_file]
        else:
            args += ['-SecurityTypes', 'None']
        args += self.extra_args
        self._log = open(self.log_path, 'ab')
        self.proc = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError('Xtigervnc exited with %s:\n%s' % (
                    self.proc.returncode, self.log_tail()))
            try:
                socket.create_connection(('127.0.0.1', self.port), 0.2).close()
                if os.path.exists('/tmp/.X11-unix/X%d' % self.display):
                    return self
            except OSError:
                pass
            time.sleep(0.05)
        self.stop()
        raise RuntimeError('Xtigervnc did not come up on port %d:\n%s' % (self.port, self.log_tail()))

    def log_tail(self, n=2000):
        try:
            with open(self.log_path, 'rb') as f:
                return f.read()[-n:].decode('utf-8', 'replace')
        except OSError:
            return ''

    def stop(self):
        if self._x is not None:
            try:
                self._x.close()
            except Exception:
                pass
            self._x = None
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.proc = None
        # a killed server may leave its lock and socket behind
        for p in ('/tmp/.X%d-lock' % self.display, '/tmp/.X11-unix/X%d' % self.display):
            try:
                os.unlink(p)
            except OSError:
                pass

    def kill(self):
        """Hard kill (SIGKILL), as if the machine went away."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)
        self.stop()

    def cleanup(self):
        self.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.cleanup()

    # -- drawing ---------------------------------------------------------------------
    def _xdisplay(self):
        if self._x is None:
            from Xlib import display as xdisplay
            self._x = xdisplay.Display(':%d' % self.display)
        return self._x

    def upload(self, rgb):
        """A server-side pixmap holding ``rgb`` (HxWx3 uint8)."""
        from Xlib import X
        d = self._xdisplay()
        scr = d.screen()
        h, w = rgb.shape[:2]
        pix = scr.root.create_pixmap(w, h, scr.root_depth)
        gc = pix.create_gc()
        # ZPixmap, depth 24, 32 bits per pixel, little endian: bytes B, G, R, x
        bgrx = np.zeros((h, w, 4), np.uint8)
        bgrx[:, :, 0] = rgb[:, :, 2]
        bgrx[:, :, 1] = rgb[:, :, 1]
        bgrx[:, :, 2] = rgb[:, :, 0]
        rows = max(1, 60000 // (w * 4))
        for y in range(0, h, rows):
            band = bgrx[y:y + rows]
            pix.put_image(gc, 0, y, w, band.shape[0], X.ZPixmap, scr.root_depth, 0,
                          band.tobytes())
        gc.free()
        return pix

    def show(self, rgb):
        """Make the whole screen show ``rgb`` (HxWx3 uint8, the screen's size)."""
        d = self._xdisplay()
        root = d.screen().root
        pix = self.upload(rgb)
        root.change_attributes(background_pixmap=pix)
        root.clear_area(0, 0, 0, 0)
        pix.free()
        d.sync()

    def fill(self, rgb_tuple):
        w, h = self.screen_size()
        img = np.empty((h, w, 3), np.uint8)
        img[:, :] = rgb_tuple
        self.show(img)
        return img

    def screen_size(self):
        # the Xlib connection caches the size from connect time; ask again after resize
        from Xlib import display as xdisplay
        d = xdisplay.Display(':%d' % self.display)
        try:
            s = d.screen()
            return s.width_in_pixels, s.height_in_pixels
        finally:
            d.close()

    def resize(self, width, height):
        """Resize the X screen (RandR) - the server then sends a new framebuffer size."""
        subprocess.run(['xrandr', '--fb', '%dx%d' % (width, height)], env=self.env, check=True,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        if self._x is not None:
            self._x.close()
            self._x = None
        self.width, self.height = width, height
