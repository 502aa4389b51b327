"""The one offscreen OpenGL context of the process (OSMesa, Mesa llvmpipe).

No X server and no GPU: ``PYOPENGL_PLATFORM=osmesa`` must be set before PyOpenGL is first
imported (``build/env.sh`` does it; this module sets it when it is missing). Every component
that renders (the world's cameras, pcl2image ...) shares this context and draws into
framebuffer objects, one per image size::

    ctx = get_context()
    with ctx:                       # lock + make current in this thread
        ctx.target(w, h)            # bind the FBO of that size, viewport = whole image
        ... draw ...
        rgb = ctx.read_rgb(w, h)    # HxWx3 uint8, row 0 = top
        depth = ctx.read_depth(w, h, near, far)   # HxW float32 metres, inf = background

The context is not thread safe by itself; ``with ctx:`` serialises its use between threads
(rospy callbacks run in their own threads).
"""
import os
import threading

os.environ.setdefault('PYOPENGL_PLATFORM', 'osmesa')

import numpy as np  # noqa: E402

__all__ = ['RenderError', 'Context', 'get_context']


class RenderError(RuntimeError):
    """OpenGL/OSMesa could not do what was asked; the message says what."""


_CTX = None
_CTX_LOCK = threading.Lock()


def get_context():
    """The process's one OSMesa context (created on first call)."""
    global _CTX
    with _CTX_LOCK:
        if _CTX is None:
            _CTX = Context()
        return _CTX


class _Target(object):
    __slots__ = ('fbo', 'color', 'depth', 'width', 'height')

    def __init__(self, fbo, color, depth, width, height):
        self.fbo, self.color, self.depth = fbo, color, depth
        self.width, self.height = width, height


class Context(object):
    """An OSMesa context with one offscreen framebuffer object per image size."""

    MAX_SIZE = 8192

    def __init__(self):
        if os.environ.get('PYOPENGL_PLATFORM') != 'osmesa':
            raise RenderError('PYOPENGL_PLATFORM is %r; the renderer needs "osmesa" set before '
                              'OpenGL is imported (source build/env.sh)'
                              % os.environ.get('PYOPENGL_PLATFORM'))
        try:
            from OpenGL import osmesa, arrays, GL
        except ImportError as e:  # pragma: no cover - python3-opengl is a dependency
            raise RenderError('PyOpenGL with OSMesa is not available: %s' % e)
        self._osmesa = osmesa
        self._GL = GL
        ctx = None
        if hasattr(osmesa, 'OSMesaCreateContextAttribs'):
            try:
                ctx = osmesa.OSMesaCreateContextAttribs(
                    [osmesa.OSMESA_FORMAT, osmesa.OSMESA_RGBA,
                     osmesa.OSMESA_DEPTH_BITS, 24,
                     osmesa.OSMESA_PROFILE, osmesa.OSMESA_COMPAT_PROFILE,
                     osmesa.OSMESA_CONTEXT_MAJOR_VERSION, 3,
                     osmesa.OSMESA_CONTEXT_MINOR_VERSION, 0, 0], None)
            except Exception:  # noqa: BLE001 - older Mesa: fall back below
                ctx = None
        if not ctx:
            ctx = osmesa.OSMesaCreateContextExt(osmesa.OSMESA_RGBA, 24, 0, 0, None)
        if not ctx:
            raise RenderError('OSMesaCreateContext failed (is libOSMesa installed? '
                              'Debian package libosmesa6)')
        self._ctx = ctx
        # The default framebuffer is a 1x1 dummy: all drawing goes to FBOs.
        self._buf = arrays.GLubyteArray.zeros((1, 1, 4))
        self.lock = threading.RLock()
        # which thread the context was last made current in: a token object of that
        # thread's own (thread-local), not threading.get_ident(), which the next thread
        # gets again once a thread has ended -- a renderer worker started after another
        # one ended would then skip OSMesaMakeCurrent and draw with no context at all
        self._tls = threading.local()
        self._current_thread = None
        self._depth_count = 0
        self._targets = {}
        self._bound = None
        self.make_current()
        self.version = GL.glGetString(GL.GL_VERSION).decode('ascii', 'replace')
        self.renderer_name = GL.glGetString(GL.GL_RENDERER).decode('ascii', 'replace')
        self.generation = 0   # bumped if GL objects have to be recreated (never so far)

    # -- current / locking ---------------------------------------------------------------
    def make_current(self):
        """Make the context current in the calling thread (hold ``ctx.lock`` around use)."""
        me = getattr(self._tls, 'token', None)
        if me is None:
            me = self._tls.token = object()
        if self._current_thread is not me:
            ok = self._osmesa.OSMesaMakeCurrent(self._ctx, self._buf,
                                                self._GL.GL_UNSIGNED_BYTE, 1, 1)
            if not ok:
                raise RenderError('OSMesaMakeCurrent failed')
            self._current_thread = me
            self._bound = None

    def __enter__(self):
        self.lock.acquire()
        try:
            self.make_current()
        except Exception:
            self.lock.release()
            raise
        return self

    def __exit__(self, *exc):
        self.lock.release()
        return False

    # -- offscreen targets ----------------------------------------------------------------
    def target(self, width, height):
        """Bind (creating on first use) the framebuffer object of ``width`` x ``height``
        with an RGBA8 colour and a 24-bit depth buffer; sets the viewport. Returns the FBO id."""
        GL = self._GL
        width, height = int(width), int(height)
        if not (0 < width <= self.MAX_SIZE and 0 < height <= self.MAX_SIZE):
            raise RenderError('render target size %dx%d outside 1..%d'
                              % (width, height, self.MAX_SIZE))
        key = (width, height)
        t = self._targets.get(key)
        if t is None:
            fbo = GL.glGenFramebuffers(1)
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
            color, depth = GL.glGenRenderbuffers(2)
            GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, color)
            GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_RGBA8, width, height)
            GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0,
                                         GL.GL_RENDERBUFFER, color)
            GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, depth)
            GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH_COMPONENT24, width, height)
            GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT,
                                         GL.GL_RENDERBUFFER, depth)
            status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
            if status != GL.GL_FRAMEBUFFER_COMPLETE:
                raise RenderError('framebuffer %dx%d incomplete (status 0x%x)'
                                  % (width, height, int(status)))
            t = _Target(fbo, color, depth, width, height)
            self._targets[key] = t
            self._bound = None
        if self._bound != key:
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, t.fbo)
            self._bound = key
        GL.glViewport(0, 0, width, height)
        return t.fbo

    def depth_target(self, key, width, height):
        """Bind (creating on first use) a depth-only framebuffer object named ``key`` whose
        depth buffer is a ``width`` x ``height`` depth texture set up for shadow look-ups
        (compare mode on, LEQUAL, luminance result, outside = 1: lit); sets the viewport.
        Returns the texture id. The next ``target()`` binds a colour target again."""
        GL = self._GL
        width, height = int(width), int(height)
        k = ('depth', key, width, height)
        t = self._targets.get(k)
        if t is None:
            fbo = GL.glGenFramebuffers(1)
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
            tex = GL.glGenTextures(1)
            GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
            GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_DEPTH_COMPONENT24, width, height, 0,
                            GL.GL_DEPTH_COMPONENT, GL.GL_UNSIGNED_INT, None)
            for pname, val in ((GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR),
                               (GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR),
                               (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_BORDER),
                               (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_BORDER),
                               (GL.GL_TEXTURE_COMPARE_MODE, GL.GL_COMPARE_REF_TO_TEXTURE),
                               (GL.GL_TEXTURE_COMPARE_FUNC, GL.GL_LEQUAL),
                               (GL.GL_DEPTH_TEXTURE_MODE, GL.GL_LUMINANCE)):
                GL.glTexParameteri(GL.GL_TEXTURE_2D, pname, val)
            GL.glTexParameterfv(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_BORDER_COLOR, (1.0, 1.0, 1.0, 1.0))
            GL.glFramebufferTexture2D(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT,
                                      GL.GL_TEXTURE_2D, tex, 0)
            GL.glDrawBuffer(GL.GL_NONE)
            GL.glReadBuffer(GL.GL_NONE)
            status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
            if status != GL.GL_FRAMEBUFFER_COMPLETE:
                raise RenderError('depth framebuffer %dx%d incomplete (status 0x%x)'
                                  % (width, height, int(status)))
            t = _Target(fbo, None, tex, width, height)
            self._targets[k] = t
            self._bound = None
        if self._bound != k:
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, t.fbo)
            self._bound = k
        GL.glViewport(0, 0, width, height)
        return t.depth

    def read_rgba_raw(self, width, height, out=None):
        """glReadPixels of the bound target as HxWx4 uint8, GL row order (row 0 = bottom)."""
        GL = self._GL
        if out is None:
            out = np.empty((height, width, 4), np.uint8)
        GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
        GL.glReadPixels(0, 0, width, height, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, out)
        return out

    def read_rgb(self, width, height):
        """The bound target's colour as HxWx3 uint8, row 0 = top of the image. (Reads RGBA:
        llvmpipe's RGB readback is several times slower than RGBA plus a conversion.)"""
        import cv2
        rgba = self.read_rgba_raw(width, height)
        return cv2.cvtColor(rgba[::-1], cv2.COLOR_RGBA2RGB)

    def read_depth_raw(self, width, height, out=None):
        """Depth buffer values 0..1 as HxW float32, GL row order."""
        GL = self._GL
        if out is None:
            out = np.empty((height, width), np.float32)
        GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
        GL.glReadPixels(0, 0, width, height, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, out)
        return out

    def read_depth(self, width, height, near=0.02, far=100.0):
        """The bound target's depth as HxW float32 metres along the view axis (row 0 = top),
        for a perspective projection with clip planes ``near``/``far``; inf = background."""
        d = self.read_depth_raw(width, height)[::-1]
        return linearize_depth(d, near, far)

    def delete_targets(self):
        GL = self._GL
        with self:
            for t in self._targets.values():
                GL.glDeleteFramebuffers(1, [t.fbo])
                if t.color is None:
                    GL.glDeleteTextures([t.depth])
                else:
                    GL.glDeleteRenderbuffers(2, [t.color, t.depth])
            self._targets.clear()
            self._bound = None


def linearize_depth(d, near, far):
    """Window depth 0..1 of a perspective projection -> metres along the view axis
    (float32); 1.0 (nothing drawn) -> inf."""
    d = np.asarray(d, np.float32)
    z_ndc = 2.0 * d - 1.0
    with np.errstate(divide='ignore', invalid='ignore'):
        z = (2.0 * near * far) / ((far + near) - z_ndc * (far - near))
    z = z.astype(np.float32)
    z[d >= 1.0] = np.inf
    return z
