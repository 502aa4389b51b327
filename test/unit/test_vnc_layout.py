"""The ctypes mirror of struct _rfbClient must match Debian's LibVNCClient header.

A tiny C program is compiled against <rfb/rfbclient.h> (Debian package libvncserver-dev)
and prints offsetof() of every field the binding declares; any mismatch (a field added,
a wrong type, a different build configuration of the library) fails here instead of
corrupting memory at run time."""
import os
import shutil
import subprocess

import pytest

from vnc_image_client import libvncclient as L

HEADER = '/usr/include/rfb/rfbclient.h'


@pytest.fixture(scope='module')
def c_layout(tmp_path_factory):
    if not os.path.exists(HEADER):
        pytest.fail('%s missing: tools/setup installs libvncserver-dev' % HEADER)
    cc = shutil.which('cc') or shutil.which('gcc') or shutil.which('clang')
    assert cc, 'no C compiler'
    d = tmp_path_factory.mktemp('vnclayout')
    names = [n for n, _ in L.RfbClient._fields_]
    lines = ['#include <stddef.h>', '#include <stdio.h>', '#include <rfb/rfbclient.h>',
             'int main(void) {']
    for n in names:
        lines.append('  printf("%s %%zu\\n", offsetof(rfbClient, %s));' % (n, n))
    lines.append('  printf("sizeof %zu\\n", sizeof(rfbClient));')
    for sub, fields in (('AppData', L.AppData), ('rfbPixelFormat', L.RfbPixelFormat),
                        ('rfbServerInitMsg', L.RfbServerInitMsg)):
        for n, _ in fields._fields_:
            lines.append('  printf("%s.%s %%zu\\n", offsetof(%s, %s));' % (sub, n, sub, n))
        lines.append('  printf("%s.sizeof %%zu\\n", sizeof(%s));' % (sub, sub))
    lines.append('  printf("rfbBool %zu\\n", sizeof(rfbBool));')
    lines.append('  return 0; }')
    src = d / 'layout.c'
    src.write_text('\n'.join(lines) + '\n')
    exe = d / 'layout'
    subprocess.run([cc, '-o', str(exe), str(src)], check=True, capture_output=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return {k: int(v) for k, v in (line.split() for line in out.splitlines())}


def test_rfbclient_offsets_match_header(c_layout):
    py = L.layout()
    wrong = {k: (py[k], c_layout[k]) for k in py if py[k] != c_layout[k]}
    assert not wrong, 'ctypes offset != C offset (python, C): %r' % wrong


@pytest.mark.parametrize('cname,pyst', [('AppData', L.AppData),
                                        ('rfbPixelFormat', L.RfbPixelFormat),
                                        ('rfbServerInitMsg', L.RfbServerInitMsg)])
def test_substructs_match_header(c_layout, cname, pyst):
    import ctypes
    for n, _ in pyst._fields_:
        assert getattr(pyst, n).offset == c_layout['%s.%s' % (cname, n)], n
    assert ctypes.sizeof(pyst) == c_layout[cname + '.sizeof']


def test_rfbbool_is_one_byte(c_layout):
    import ctypes
    assert c_layout['rfbBool'] == ctypes.sizeof(L.rfbBool) == 1


def test_library_defaults_read_through_binding():
    """Values rfbGetClient(8, 3, 4) writes, read back through the ctypes mirror: a
    shifted offset would read neighbouring bytes instead."""
    lib = L.lib()
    c = lib.rfbGetClient(8, 3, 4)
    try:
        cl = c.contents
        f = cl.format
        assert (f.bitsPerPixel, f.depth, f.trueColour, f.redMax) == (32, 24, 1, 255)
        assert (f.redShift, f.greenShift, f.blueShift) == (0, 8, 16)
        assert cl.serverPort == 5900
        assert cl.endianTest == 1
        assert cl.sock == -1 and cl.listenSock == -1
        assert cl.appData.encodingsString.split()[-1] == b'raw'
        assert cl.MallocFrameBuffer  # the library's default allocator is installed
    finally:
        lib.rfbClientCleanup(c)


def test_log_hook_formats_printf_arguments():
    """LibVNCClient's printf-style log lines are rebuilt from the raw varargs registers."""
    import ctypes
    buf = ctypes.create_string_buffer(b'Authentication failure')
    addr = ctypes.addressof(buf)
    assert L._format(b'VNC connection failed: %s\n', [addr]) == \
        'VNC connection failed: Authentication failure\n'
    assert L._format(b'%d bits, %u%%, 0x%x', [32, 0xffffffff, 255]) == '32 bits, 4294967295%, 0xff'
    assert L._format(b'neg %d', [0xfffffffe]) == 'neg -2'
    # more conversions than arguments: the bare format, nothing invented
    assert L._format(b'%d %d %d', [1]) == '%d %d %d'


def test_library_messages_reach_python_logging(caplog):
    import logging
    caplog.set_level(logging.DEBUG, logger='vnc_image_client.libvncclient')
    lib = L.lib()
    L.start_recording()
    c = lib.rfbGetClient(8, 3, 4)
    try:
        # port 1 on localhost: nothing listens there (privileged, unused)
        assert not lib.ConnectToRFBServer(c, b'127.0.0.1', 1)
    finally:
        lib.rfbClientCleanup(c)
    assert any('Unable to connect' in m for m in L.recorded()), L.recorded()
    assert 'libvncclient: Unable to connect' in caplog.text
