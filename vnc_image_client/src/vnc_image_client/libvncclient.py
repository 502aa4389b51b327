"""ctypes binding of Debian's LibVNCClient 0.9.14 (package libvncclient1).

The thesis generated its wrapper with RPythonic and had to patch the library for a
frame-update callback and for handing over the password. LibVNCClient 0.9.14 has both
hooks (``GotFrameBufferUpdate``, ``FinishedFrameBufferUpdate``, ``GetPassword``), so this
module binds the unmodified Debian library.

``RfbClient`` mirrors ``struct _rfbClient`` of 0.9.14's ``<rfb/rfbclient.h>`` for Debian's
build configuration (LIBZ, LIBJPEG, SASL, pthreads). Fields this project never touches
(zlib streams, the mutex) are opaque byte blocks of the right size and alignment.
``test/unit/test_vnc_layout.py`` compiles a tiny C program against the real header
(libvncserver-dev) and checks every offset below against ``offsetof``.
"""
import ctypes
import ctypes.util
import logging
import platform
import re
import threading

rfbBool = ctypes.c_int8          # typedef int8_t rfbBool; TRUE is -1
TRUE = -1
FALSE = 0

LOG = logging.getLogger('vnc_image_client.libvncclient')


def _opaque(name, size):
    return type(name, (ctypes.Structure,), {'_fields_': [('_q', ctypes.c_uint64 * (size // 8))]})


# Sizes on LP64 Linux (x86_64, aarch64): z_stream is 112 bytes, pthread_mutex_t 40.
ZStream = _opaque('ZStream', 112)
PthreadMutex = _opaque('PthreadMutex', 40)


class AppData(ctypes.Structure):
    _fields_ = [
        ('shareDesktop', rfbBool),
        ('viewOnly', rfbBool),
        ('encodingsString', ctypes.c_char_p),
        ('useBGR233', rfbBool),
        ('nColours', ctypes.c_int),
        ('forceOwnCmap', rfbBool),
        ('forceTrueColour', rfbBool),
        ('requestedDepth', ctypes.c_int),
        ('compressLevel', ctypes.c_int),
        ('qualityLevel', ctypes.c_int),
        ('enableJPEG', rfbBool),
        ('useRemoteCursor', rfbBool),
        ('palmVNC', rfbBool),
        ('scaleSetting', ctypes.c_int),
    ]


class RfbPixelFormat(ctypes.Structure):
    _fields_ = [
        ('bitsPerPixel', ctypes.c_uint8),
        ('depth', ctypes.c_uint8),
        ('bigEndian', ctypes.c_uint8),
        ('trueColour', ctypes.c_uint8),
        ('redMax', ctypes.c_uint16),
        ('greenMax', ctypes.c_uint16),
        ('blueMax', ctypes.c_uint16),
        ('redShift', ctypes.c_uint8),
        ('greenShift', ctypes.c_uint8),
        ('blueShift', ctypes.c_uint8),
        ('pad1', ctypes.c_uint8),
        ('pad2', ctypes.c_uint16),
    ]


class RfbServerInitMsg(ctypes.Structure):
    _fields_ = [
        ('framebufferWidth', ctypes.c_uint16),
        ('framebufferHeight', ctypes.c_uint16),
        ('format', RfbPixelFormat),
        ('nameLength', ctypes.c_uint32),
    ]


class UpdateRect(ctypes.Structure):
    _fields_ = [('x', ctypes.c_int), ('y', ctypes.c_int), ('w', ctypes.c_int), ('h', ctypes.c_int)]


class RfbExtDesktopScreen(ctypes.Structure):
    _fields_ = [
        ('id', ctypes.c_uint32),
        ('x', ctypes.c_uint16),
        ('y', ctypes.c_uint16),
        ('width', ctypes.c_uint16),
        ('height', ctypes.c_uint16),
        ('flags', ctypes.c_uint32),
    ]


_fp = ctypes.c_void_p  # function pointers are stored as plain addresses

RFB_BUFFER_SIZE = 640 * 480
RFB_BUF_SIZE = 8192
ZLIB_BUFFER_SIZE = 30000
TIGHT_GRADIENT_MAX_WIDTH = 2048


class RfbClient(ctypes.Structure):
    _fields_ = [
        ('frameBuffer', ctypes.c_void_p),
        ('width', ctypes.c_int),
        ('height', ctypes.c_int),
        ('endianTest', ctypes.c_int),
        ('appData', AppData),
        ('programName', ctypes.c_char_p),
        ('serverHost', ctypes.c_void_p),      # malloc'd: libvncclient frees it
        ('serverPort', ctypes.c_int),
        ('listenSpecified', rfbBool),
        ('listenPort', ctypes.c_int),
        ('flashPort', ctypes.c_int),
        ('updateRect', UpdateRect),
        ('buffer', ctypes.c_char * RFB_BUFFER_SIZE),
        ('sock', ctypes.c_int),
        ('canUseCoRRE', rfbBool),
        ('canUseHextile', rfbBool),
        ('desktopName', ctypes.c_void_p),
        ('format', RfbPixelFormat),
        ('si', RfbServerInitMsg),
        ('buf', ctypes.c_char * RFB_BUF_SIZE),
        ('bufoutptr', ctypes.c_void_p),
        ('buffered', ctypes.c_uint),
        ('ultra_buffer_size', ctypes.c_int),
        ('ultra_buffer', ctypes.c_void_p),
        ('raw_buffer_size', ctypes.c_int),
        ('raw_buffer', ctypes.c_void_p),
        ('decompStream', ZStream),
        ('decompStreamInited', rfbBool),
        ('zlib_buffer', ctypes.c_char * ZLIB_BUFFER_SIZE),
        ('zlibStream', ZStream * 4),
        ('zlibStreamActive', rfbBool * 4),
        ('cutZeros', rfbBool),
        ('rectWidth', ctypes.c_int),
        ('rectColors', ctypes.c_int),
        ('tightPalette', ctypes.c_char * (256 * 4)),
        ('tightPrevRow', ctypes.c_uint8 * (TIGHT_GRADIENT_MAX_WIDTH * 3 * 2)),
        ('jpegError', rfbBool),
        ('jpegSrcManager', ctypes.c_void_p),
        ('jpegBufferPtr', ctypes.c_void_p),
        ('jpegBufferLen', ctypes.c_size_t),
        ('rcSource', ctypes.c_void_p),
        ('rcMask', ctypes.c_void_p),
        ('clientData', ctypes.c_void_p),
        ('vncRec', ctypes.c_void_p),
        ('KeyboardLedStateEnabled', ctypes.c_int),
        ('CurrentKeyboardLedState', ctypes.c_int),
        ('canHandleNewFBSize', ctypes.c_int),
        ('HandleTextChat', _fp),
        ('HandleKeyboardLedState', _fp),
        ('HandleCursorPos', _fp),
        ('SoftCursorLockArea', _fp),
        ('SoftCursorUnlockScreen', _fp),
        ('GotFrameBufferUpdate', _fp),
        ('GetPassword', _fp),
        ('MallocFrameBuffer', _fp),
        ('GotXCutText', _fp),
        ('Bell', _fp),
        ('GotCursorShape', _fp),
        ('GotCopyRect', _fp),
        ('supportedMessages', ctypes.c_uint8 * 64),
        ('major', ctypes.c_int),
        ('minor', ctypes.c_int),
        ('authScheme', ctypes.c_uint32),
        ('subAuthScheme', ctypes.c_uint32),
        ('tlsSession', ctypes.c_void_p),
        ('GetCredential', _fp),
        ('clientAuthSchemes', ctypes.c_void_p),
        ('destHost', ctypes.c_void_p),
        ('destPort', ctypes.c_int),
        ('QoS_DSCP', ctypes.c_int),
        ('HandleXvpMsg', _fp),
        ('listenSock', ctypes.c_int),
        ('FinishedFrameBufferUpdate', _fp),
        ('listenAddress', ctypes.c_void_p),
        ('listen6Sock', ctypes.c_int),
        ('listen6Address', ctypes.c_void_p),
        ('listen6Port', ctypes.c_int),
        ('outputWindow', ctypes.c_ulong),
        ('LockWriteToTLS', _fp),
        ('UnlockWriteToTLS', _fp),
        ('GotFillRect', _fp),
        ('GotBitmap', _fp),
        ('GotJpeg', _fp),
        ('saslconn', ctypes.c_void_p),
        ('saslDecoded', ctypes.c_void_p),
        ('saslDecodedLength', ctypes.c_uint),
        ('saslDecodedOffset', ctypes.c_uint),
        ('saslSecret', ctypes.c_void_p),
        ('GetSASLMechanism', _fp),
        ('GetUser', _fp),
        ('tjhnd', ctypes.c_void_p),
        ('connectTimeout', ctypes.c_uint),
        ('readTimeout', ctypes.c_uint),
        ('tlsRwMutex', PthreadMutex),
        ('requestedResize', rfbBool),
        ('screen', RfbExtDesktopScreen),
    ]


ClientP = ctypes.POINTER(RfbClient)

# Callback types (rfbclient.h typedefs)
GotFrameBufferUpdateProc = ctypes.CFUNCTYPE(None, ClientP, ctypes.c_int, ctypes.c_int,
                                            ctypes.c_int, ctypes.c_int)
FinishedFrameBufferUpdateProc = ctypes.CFUNCTYPE(None, ClientP)
# char* (*GetPasswordProc)(rfbClient*): the result must be malloc'd (the library frees it),
# so it is declared as an address and produced with libc's strdup.
GetPasswordProc = ctypes.CFUNCTYPE(ctypes.c_void_p, ClientP)
MallocFrameBufferProc = ctypes.CFUNCTYPE(rfbBool, ClientP)


class LibVncClientMissing(ImportError):
    pass


_lib = None
_libc = None
_lock = threading.Lock()


def lib():
    """The loaded libvncclient.so.1 with prototypes set (loaded once per process)."""
    global _lib, _libc
    with _lock:
        if _lib is not None:
            return _lib
        name = ctypes.util.find_library('vncclient') or 'libvncclient.so.1'
        try:
            L = ctypes.CDLL(name)
        except OSError as e:
            raise LibVncClientMissing(
                'cannot load LibVNCClient (%s): install Debian package libvncclient1' % e)
        L.rfbGetClient.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int]
        L.rfbGetClient.restype = ClientP
        L.rfbClientCleanup.argtypes = [ClientP]
        L.rfbClientCleanup.restype = None
        L.ConnectToRFBServer.argtypes = [ClientP, ctypes.c_char_p, ctypes.c_int]
        L.ConnectToRFBServer.restype = rfbBool
        L.InitialiseRFBConnection.argtypes = [ClientP]
        L.InitialiseRFBConnection.restype = rfbBool
        L.SetFormatAndEncodings.argtypes = [ClientP]
        L.SetFormatAndEncodings.restype = rfbBool
        L.SendFramebufferUpdateRequest.argtypes = [ClientP, ctypes.c_int, ctypes.c_int,
                                                   ctypes.c_int, ctypes.c_int, rfbBool]
        L.SendFramebufferUpdateRequest.restype = rfbBool
        L.SendIncrementalFramebufferUpdateRequest.argtypes = [ClientP]
        L.SendIncrementalFramebufferUpdateRequest.restype = rfbBool
        L.WaitForMessage.argtypes = [ClientP, ctypes.c_uint]
        L.WaitForMessage.restype = ctypes.c_int
        L.HandleRFBServerMessage.argtypes = [ClientP]
        L.HandleRFBServerMessage.restype = rfbBool
        L.SendPointerEvent.argtypes = [ClientP, ctypes.c_int, ctypes.c_int, ctypes.c_int]
        L.SendPointerEvent.restype = rfbBool
        L.SendKeyEvent.argtypes = [ClientP, ctypes.c_uint32, rfbBool]
        L.SendKeyEvent.restype = rfbBool
        _libc = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6')
        _libc.strdup.argtypes = [ctypes.c_char_p]
        _libc.strdup.restype = ctypes.c_void_p
        _libc.free.argtypes = [ctypes.c_void_p]
        _libc.free.restype = None
        _install_log_hooks(L)
        _lib = L
        return L


def strdup(data):
    """A malloc'd copy of ``data`` (bytes) that LibVNCClient may free()."""
    lib()
    return _libc.strdup(data)


def free(addr):
    """libc free() of memory LibVNCClient allocated and left to its user."""
    lib()
    _libc.free(addr)


# --- LibVNCClient's log output -----------------------------------------------------
# rfbClientLog/rfbClientErr are global printf-like function pointers. They are replaced
# with a callback so the library's messages go to Python logging (DEBUG) and to a
# per-thread record the client uses to explain a failure in ONE line, instead of the
# library printing a line on stderr for every reconnect attempt.
# Variadic arguments arrive in integer registers on x86_64/aarch64 Linux, so up to five
# of them can be read; other conversions fall back to the bare format string.

_NARGS = 5 if platform.machine() in ('x86_64', 'aarch64', 'arm64') else 0
_LogProc = ctypes.CFUNCTYPE(None, ctypes.c_char_p, *([ctypes.c_void_p] * _NARGS))
_CONV = re.compile(rb'%([-+ #0]*\d*(?:\.\d+)?)(hh|h|ll|l|z)?([diouxXscp%])')
_records = threading.local()


def _format(fmt, args):
    out = []
    pos = 0
    argi = 0
    for m in _CONV.finditer(fmt):
        out.append(fmt[pos:m.start()])
        pos = m.end()
        conv = m.group(3)
        if conv == b'%':
            out.append(b'%')
            continue
        if argi >= len(args):
            return fmt.decode('utf-8', 'replace')
        a = args[argi] or 0
        argi += 1
        if conv == b's':
            out.append(ctypes.string_at(a) if a else b'(null)')
        elif conv == b'c':
            out.append(bytes([a & 0xff]))
        elif conv == b'p':
            out.append(b'0x%x' % a)
        else:
            size = m.group(2) or b''
            if size not in (b'l', b'll', b'z'):
                a &= 0xffffffff
                if conv in (b'd', b'i') and a & 0x80000000:
                    a -= 1 << 32
            elif conv in (b'd', b'i') and a & (1 << 63):
                a -= 1 << 64
            spec = '%' + m.group(1).decode() + {b'i': 'd', b'u': 'd'}.get(conv, conv.decode())
            out.append((spec % a).encode())
    out.append(fmt[pos:])
    if not _NARGS and _CONV.search(fmt):
        return fmt.decode('utf-8', 'replace')
    return b''.join(out).decode('utf-8', 'replace')


def _make_log_cb(level):
    def cb(fmt, *args):
        try:
            text = _format(fmt or b'', args).strip()
        except Exception:  # never let an exception cross into C
            text = (fmt or b'').decode('utf-8', 'replace').strip()
        msgs = getattr(_records, 'msgs', None)
        if msgs is not None:
            msgs.append(text)
            del msgs[:-20]
        LOG.log(level, 'libvncclient: %s', text)
    return _LogProc(cb)


_log_cbs = []


def _install_log_hooks(L):
    for name, level in (('rfbClientLog', logging.DEBUG), ('rfbClientErr', logging.DEBUG)):
        cb = _make_log_cb(level)
        _log_cbs.append(cb)
        ctypes.c_void_p.in_dll(L, name).value = ctypes.cast(cb, ctypes.c_void_p).value


def start_recording():
    """Collect the library's log lines emitted by the calling thread from now on."""
    _records.msgs = []


def recorded():
    return list(getattr(_records, 'msgs', None) or [])


def layout():
    """{field: offset} of RfbClient plus 'sizeof', for the layout test."""
    d = {name: getattr(RfbClient, name).offset for name, _ in RfbClient._fields_}
    d['sizeof'] = ctypes.sizeof(RfbClient)
    return d
