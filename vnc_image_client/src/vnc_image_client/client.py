"""A VNC client built on the ctypes LibVNCClient binding, plus the receiving loop.

``VncClient`` is one connection: ``connect()`` performs the RFB handshake step by step
(so an unreachable host, a missing password and a wrong password give distinct errors),
``poll()`` handles server messages and ``snapshot()`` copies the framebuffer as RGBA8
under the same lock ``poll()`` holds while LibVNCClient writes into it (the thesis's
"global lock").

``VncReceiver`` is the receiving thread: it connects, polls, and when the server goes
away it reconnects with exponential back-off, logging once per outage. A wrong password
stops it with one error (no retry storm: VNC servers blacklist clients that keep trying).
Nothing here depends on ROS; the node adds the publisher thread.
"""
import ctypes
import logging
import socket
import threading
import time

import numpy as np

from . import libvncclient as L

LOG = logging.getLogger('vnc_image_client')


class VncError(Exception):
    """Base class of every error this module raises."""


class VncConnectError(VncError):
    """The server could not be reached or the handshake broke off."""


class VncConnectionLost(VncError):
    """An established connection ended."""


class VncAuthError(VncError):
    """The server rejected the password."""


class VncPasswordRequired(VncError):
    """The server wants a password and none could be obtained."""


def _describe(messages, default):
    """The most telling LibVNCClient message of a failure (without timestamps)."""
    for m in reversed(messages):
        low = m.lower()
        if any(k in low for k in ('fail', 'unable', 'error', 'refused', 'closed', 'too many',
                                   'authentication', 'timed out', 'timeout')):
            return m
    return messages[-1] if messages else default


def _os_reason(host, port, timeout):
    """The operating system's reason why host:port cannot be reached (LibVNCClient's own
    message does not say), or None when a plain TCP connect works now."""
    try:
        socket.create_connection((host, port), timeout=min(timeout, 2.0)).close()
    except socket.gaierror as e:
        return 'unknown host %r (%s)' % (host, e.strerror or e)
    except socket.timeout:
        return 'connection timed out'
    except OSError as e:
        return e.strerror or str(e)
    return None


def _cleanup(lib, c):
    """rfbClientCleanup, plus the framebuffer: LibVNCClient 0.9.14 frees everything of the
    client except the buffer its own MallocFrameBuffer allocated (one framebuffer leaked per
    reconnect otherwise; test_vnc_server checks the process size over reconnects)."""
    fb = c.contents.frameBuffer
    c.contents.frameBuffer = None
    lib.rfbClientCleanup(c)
    if fb:
        L.free(fb)


class VncClient(object):
    """One RFB connection through LibVNCClient.

    password: bytes/str, or a callable returning one (or None when no password can be
    had); it is only consulted when the server asks for VNC authentication.
    """

    def __init__(self, host='localhost', port=5901, password=None, connect_timeout=5.0,
                 read_timeout=0, encodings=None):
        self.host = host
        self.port = int(port)
        self._password = password
        self.connect_timeout = connect_timeout
        self.read_timeout = read_timeout
        self.encodings = encodings
        self.lock = threading.Lock()
        self.updated = threading.Condition(threading.Lock())
        self._lib = L.lib()
        self._c = None
        self.seq = 0                 # completed updates that changed pixels (never reset)
        self.rects = 0               # updated rectangles since connect
        self._pending = 0            # rectangles of the update message being handled
        self.valid = False           # the framebuffer holds server pixels (this connection)
        self._cov_size = None        # framebuffer size the coverage mask belongs to
        self._cov = None             # pixels filled so far, until the first full frame
        self.password_asked = False
        self.password_given = False
        self._encodings_buf = None
        # keep the C callbacks alive as long as this object
        self._cb_rect = L.GotFrameBufferUpdateProc(self._on_rect)
        self._cb_finished = L.FinishedFrameBufferUpdateProc(self._on_finished)
        self._cb_password = L.GetPasswordProc(self._on_password)

    # -- callbacks (called from C on the thread running poll()/connect()) --------------
    def _on_rect(self, client, x, y, w, h):
        # Called inside HandleRFBServerMessage, i.e. with self.lock held.
        if w <= 0 or h <= 0:      # pseudo-encodings (cursor, desktop size) report 0x0
            return
        self.rects += 1
        self._pending += 1
        cl = client.contents
        size = (cl.width, cl.height)
        if size != self._cov_size:
            # a new (uninitialised) framebuffer: no image until the server filled all of it
            self._cov_size = size
            self._cov = np.zeros((cl.height, cl.width), bool)
            self.valid = False
        if self._cov is not None:
            self._cov[max(y, 0):y + h, max(x, 0):x + w] = True
            if self._cov.all():
                self._cov = None

    def _on_finished(self, client):
        # one call per FramebufferUpdate message; a message that changed no pixel, or a
        # framebuffer the server has not completely filled yet, is not a new frame
        if not self._pending or self._cov is not None:
            return
        self._pending = 0
        with self.updated:
            self.valid = True
            self.seq += 1
            self.updated.notify_all()

    def _on_password(self, client):
        self.password_asked = True
        try:
            pw = self._password() if callable(self._password) else self._password
        except Exception as e:  # an exception must not cross into C
            LOG.error('reading the VNC password failed: %s', e)
            pw = None
        if pw is None or pw == '' or pw == b'':
            return None
        if isinstance(pw, str):
            pw = pw.encode('utf-8')
        self.password_given = True
        return L.strdup(pw)

    # -- connection ------------------------------------------------------------------
    @property
    def connected(self):
        return self._c is not None

    @property
    def size(self):
        """(width, height) of the server's framebuffer, or None when not connected."""
        c = self._c
        if c is None:
            return None
        return c.contents.width, c.contents.height

    @property
    def desktop_name(self):
        c = self._c
        if c is None or not c.contents.desktopName:
            return ''
        return ctypes.string_at(c.contents.desktopName).decode('utf-8', 'replace')

    def connect(self):
        """Connect and request the first full update; raises a VncError subclass."""
        if self._c is not None:
            return
        lib = self._lib
        L.start_recording()
        self.password_asked = self.password_given = False
        self.rects = self._pending = 0
        self.valid = False
        self._cov_size = None
        self._cov = None
        c = lib.rfbGetClient(8, 3, 4)   # 32 bpp, bytes R,G,B,x in memory on little endian
        if not c:
            raise VncConnectError('rfbGetClient failed (out of memory?)')
        cl = c.contents
        cl.canHandleNewFBSize = 1
        cl.appData.enableJPEG = L.FALSE        # lossless: pixels must equal the server's
        cl.appData.shareDesktop = L.TRUE
        cl.appData.viewOnly = L.TRUE
        if self.encodings:
            self._encodings_buf = ctypes.create_string_buffer(self.encodings.encode())
            cl.appData.encodingsString = ctypes.cast(self._encodings_buf, ctypes.c_char_p)
        cl.connectTimeout = max(1, int(round(self.connect_timeout)))
        cl.readTimeout = int(self.read_timeout)
        cl.GotFrameBufferUpdate = ctypes.cast(self._cb_rect, ctypes.c_void_p).value
        cl.FinishedFrameBufferUpdate = ctypes.cast(self._cb_finished, ctypes.c_void_p).value
        cl.GetPassword = ctypes.cast(self._cb_password, ctypes.c_void_p).value
        where = '%s:%d' % (self.host, self.port)
        try:
            if not lib.ConnectToRFBServer(c, self.host.encode(), self.port):
                raise VncConnectError('cannot connect to VNC server %s: %s' % (
                    where, _os_reason(self.host, self.port, self.connect_timeout) or
                    _describe(L.recorded(), 'connection failed')))
            if not lib.InitialiseRFBConnection(c):
                why = _describe(L.recorded(), 'handshake failed')
                if self.password_asked and not self.password_given:
                    raise VncPasswordRequired(
                        'VNC server %s requires a password and none was given '
                        '(set ~password or start the node on a terminal to be asked)' % where)
                if self.password_asked and any('authentication fail' in m.lower()
                                               for m in L.recorded()):
                    raise VncAuthError('VNC server %s rejected the password (%s)' % (where, why))
                # (a server that goes away in the middle of the handshake, even after the
                # password was sent, is an outage, not a wrong password)
                raise VncConnectError('VNC handshake with %s failed: %s' % (where, why))
            cl.width = cl.si.framebufferWidth
            cl.height = cl.si.framebufferHeight
            malloc_fb = L.MallocFrameBufferProc(cl.MallocFrameBuffer)
            if not malloc_fb(c):
                raise VncConnectError('cannot allocate a %dx%d framebuffer' % (cl.width, cl.height))
            if not lib.SetFormatAndEncodings(c):
                raise VncConnectError('VNC server %s closed the connection during set-up: %s' % (
                    where, _describe(L.recorded(), 'write failed')))
            cl.updateRect.x = cl.updateRect.y = 0
            cl.updateRect.w, cl.updateRect.h = cl.width, cl.height
            if not lib.SendFramebufferUpdateRequest(c, 0, 0, cl.width, cl.height, L.FALSE):
                raise VncConnectError('VNC server %s closed the connection during set-up' % where)
        except VncError:
            _cleanup(lib, c)
            raise
        self._c = c

    def close(self):
        with self.lock:
            c, self._c = self._c, None
            if c is not None:
                _cleanup(self._lib, c)
        with self.updated:
            self.updated.notify_all()

    def poll(self, timeout=0.1):
        """Wait up to ``timeout`` s for server data and handle one message.

        Returns True when a message was handled. Raises VncConnectionLost when the server
        went away (the connection is closed then)."""
        c = self._c
        if c is None:
            raise VncConnectionLost('not connected')
        L.start_recording()
        n = self._lib.WaitForMessage(c, int(timeout * 1e6))
        if n < 0:
            self.close()
            raise VncConnectionLost('VNC server %s:%d went away (%s)' % (
                self.host, self.port, _describe(L.recorded(), 'connection lost')))
        if n == 0:
            return False
        with self.lock:
            ok = self._lib.HandleRFBServerMessage(c)
        if not ok:
            self.close()
            raise VncConnectionLost('VNC server %s:%d went away (%s)' % (
                self.host, self.port, _describe(L.recorded(), 'connection closed')))
        return True

    def wait_update(self, after_seq, timeout):
        """Block until more than ``after_seq`` updates completed; returns the new seq."""
        deadline = time.monotonic() + timeout
        with self.updated:
            while self.seq <= after_seq:
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self.updated.wait(left)
            return self.seq

    def snapshot(self, out=None):
        """Copy the framebuffer as an HxWx4 uint8 RGBA array (alpha 255).

        Returns (image, seq) or (None, seq) before the first update. ``out`` is reused
        when its shape fits."""
        with self.lock:
            c = self._c
            if c is None or not c.contents.frameBuffer or not self.valid:
                return None, self.seq
            cl = c.contents
            w, h = cl.width, cl.height
            seq = self.seq
            src = np.ctypeslib.as_array(
                (ctypes.c_uint8 * (w * h * 4)).from_address(cl.frameBuffer)).reshape(h, w, 4)
            if out is None or out.shape != (h, w, 4):
                out = np.empty((h, w, 4), np.uint8)
            np.copyto(out, src)
        out[:, :, 3] = 255
        return out, seq

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


class VncReceiver(threading.Thread):
    """Receiving thread: keeps a VncClient connected and handles its messages.

    log: an object with info/warn/error methods (rospy-style) or a logging.Logger.
    backoff: (first, maximum) seconds between reconnect attempts.
    on_fatal: called with the exception when the receiver gives up (wrong password,
    missing password).
    """

    def __init__(self, client, log=None, backoff=(0.5, 5.0), on_fatal=None,
                 retry_auth=None):
        threading.Thread.__init__(self, name='vnc-receiver')
        self.daemon = True
        self.client = client
        self.log = log or LOG
        self.backoff = backoff
        self.on_fatal = on_fatal
        self.retry_auth = retry_auth   # callable -> bool: may a failed password be retried?
        self._stop_ev = threading.Event()
        self.fatal = None
        self.outages = 0
        self.connects = 0

    def _warn(self, msg):
        (getattr(self.log, 'warn', None) or self.log.warning)(msg)

    def stop(self):
        self._stop_ev.set()

    def run(self):
        delay = self.backoff[0]
        down_since = None          # set while in an outage (after the first failure)
        first = True
        while not self._stop_ev.is_set():
            if not self.client.connected:
                try:
                    self.client.connect()
                except (VncAuthError, VncPasswordRequired) as e:
                    if isinstance(e, VncAuthError) and self.retry_auth and self.retry_auth():
                        self.log.error(str(e) + '; asking again')
                        continue
                    if isinstance(e, VncAuthError):
                        self.log.error(str(e) + '; giving up (no retries: VNC servers block '
                                       'clients that keep sending wrong passwords)')
                    else:
                        self.log.error(str(e) + '; giving up')
                    self.fatal = e
                    if self.on_fatal:
                        self.on_fatal(e)
                    return
                except VncError as e:
                    if down_since is None:
                        down_since = time.monotonic()
                        self.outages += 1
                        self._warn('%s; retrying with back-off up to %.0f s (logged once '
                                   'until it is back)' % (e, self.backoff[1]))
                    self._stop_ev.wait(delay)
                    delay = min(delay * 2, self.backoff[1])
                    continue
                self.connects += 1
                w, h = self.client.size
                if down_since is not None and not first:
                    self.log.info('reconnected to VNC server %s:%d after %.1f s (%dx%d)' % (
                        self.client.host, self.client.port,
                        time.monotonic() - down_since, w, h))
                else:
                    self.log.info('connected to VNC server %s:%d "%s" (%dx%d)' % (
                        self.client.host, self.client.port, self.client.desktop_name, w, h))
                down_since = None
                first = False
                delay = self.backoff[0]
            try:
                self.client.poll(0.1)
            except VncConnectionLost as e:
                down_since = time.monotonic()
                self.outages += 1
                self._warn('%s; reconnecting with back-off up to %.0f s (logged once '
                           'until it is back)' % (e, self.backoff[1]))
                first = False
        self.client.close()
