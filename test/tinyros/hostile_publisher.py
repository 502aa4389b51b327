"""A hostile sensor_msgs/Image publisher for the tinyros tests.

It plays a ROS node by hand: a raw HTTP/XML-RPC slave API (so it can also answer
requestTopic with garbage) and a TCPROS server, registered at a real master with
registerPublisher. Each requestTopic call and each TCPROS connection gets the next
scenario of its list; the last one repeats."""
import os
import socket
import struct
import threading
import time
import xmlrpc.client
import zlib

IMAGE_MD5 = '060021388200f6f0f447d0fcd9c64743'


def tcpros_header(fields):
    body = b''.join(struct.pack('<I', len(f)) + f for f in
                    (('%s=%s' % kv).encode() for kv in fields))
    return struct.pack('<I', len(body)) + body


def _str(b):
    return struct.pack('<I', len(b)) + b


def image_message(seq, width, height, data, encoding=b'rgb8', frame_id=b'hostile'):
    step = len(data) // height if height else 0
    return (struct.pack('<III', seq, int(time.time()), 0) + _str(frame_id) +
            struct.pack('<II', height, width) + _str(encoding) + b'\x00' + struct.pack('<I', step) + _str(data))


def xmlrpc_http(body):
    if isinstance(body, str):
        body = body.encode()
    return b'HTTP/1.0 200 OK\r\nContent-Type: text/xml\r\nContent-Length: %d\r\n\r\n' % len(body) + body


def xmlrpc_result(value):
    return xmlrpc_http(xmlrpc.client.dumps((value,), methodresponse=True))


# --- requestTopic scenarios: (name, callable(tcp_port) -> raw HTTP answer) ---------------
RPC_GARBAGE = ('garbage XML', lambda port: xmlrpc_http('<methodResponse><params><oops>'))
RPC_FAULT = ('fault', lambda port: xmlrpc_http(xmlrpc.client.dumps(xmlrpc.client.Fault(1, 'hostile fault'),
                                                                   methodresponse=True)))
RPC_WRONG_PROTO = ('wrong protocol', lambda port: xmlrpc_result([1, 'ok', ['UDPROS', '127.0.0.1', port]]))
RPC_OK = ('ok', lambda port: xmlrpc_result([1, 'ready', ['TCPROS', '127.0.0.1', port]]))


class HostilePublisher:
    def __init__(self, master_uri, topic, rpc_scenarios, tcp_scenarios, caller_id='/hostile_pub'):
        self.master_uri, self.topic, self.caller_id = master_uri, topic, caller_id
        self.rpc_scenarios, self.tcp_scenarios = rpc_scenarios, tcp_scenarios
        self.rpc_calls, self.tcp_connections = [], []
        self.sent_crcs = []           # crc32 of the data of every valid frame sent
        self.stop = threading.Event()
        self.rpc = socket.socket()
        self.rpc.bind(('127.0.0.1', 0))
        self.rpc.listen(8)
        self.tcp = socket.socket()
        self.tcp.bind(('127.0.0.1', 0))
        self.tcp.listen(8)
        self.uri = 'http://127.0.0.1:%d/' % self.rpc.getsockname()[1]
        self.threads = [threading.Thread(target=self._serve, args=(self.rpc, self._rpc_conn), daemon=True),
                        threading.Thread(target=self._serve, args=(self.tcp, self._tcp_conn), daemon=True)]
        for t in self.threads:
            t.start()
        code, msg, _ = xmlrpc.client.ServerProxy(master_uri).registerPublisher(
            caller_id, topic, 'sensor_msgs/Image', self.uri)
        assert code == 1, msg

    def close(self):
        self.stop.set()
        try:
            xmlrpc.client.ServerProxy(self.master_uri).unregisterPublisher(self.caller_id, self.topic, self.uri)
        except Exception:
            pass
        self.rpc.close()
        self.tcp.close()

    def _serve(self, sock, handler):
        sock.settimeout(0.2)
        while not self.stop.is_set():
            try:
                c, _ = sock.accept()
            except (socket.timeout, OSError):
                continue
            threading.Thread(target=self._guard, args=(handler, c), daemon=True).start()

    def _guard(self, handler, c):
        try:
            c.settimeout(5)
            handler(c)
        except OSError:
            pass
        finally:
            c.close()

    def _rpc_conn(self, c):
        data = b''
        while b'\r\n\r\n' not in data:
            chunk = c.recv(4096)
            if not chunk:
                return
            data += chunk
        head, body = data.split(b'\r\n\r\n', 1)
        length = 0
        for line in head.split(b'\r\n'):
            if line.lower().startswith(b'content-length:'):
                length = int(line.split(b':')[1])
        while len(body) < length:
            chunk = c.recv(4096)
            if not chunk:
                return
            body += chunk
        params, method = xmlrpc.client.loads(body)
        if method != 'requestTopic':
            c.sendall(xmlrpc_result([1, '', os.getpid() if method == 'getPid' else 0]))
            return
        name, make = self.rpc_scenarios[min(len(self.rpc_calls), len(self.rpc_scenarios) - 1)]
        self.rpc_calls.append(name)
        c.sendall(make(self.tcp.getsockname()[1]))

    def _tcp_conn(self, c):
        # the subscriber's connection header first
        n = struct.unpack('<I', self._recv(c, 4))[0]
        hdr = self._recv(c, n)
        assert b'md5sum=' + IMAGE_MD5.encode() in hdr and b'topic=' + self.topic.encode() in hdr
        name, play = self.tcp_scenarios[min(len(self.tcp_connections), len(self.tcp_scenarios) - 1)]
        self.tcp_connections.append(name)
        play(self, c)

    @staticmethod
    def _recv(c, n):
        out = b''
        while len(out) < n:
            chunk = c.recv(n - len(out))
            if not chunk:
                raise OSError('closed')
            out += chunk
        return out

    def good_header(self):
        return tcpros_header([('callerid', self.caller_id), ('md5sum', IMAGE_MD5), ('topic', self.topic),
                              ('type', 'sensor_msgs/Image'), ('latching', '0')])

    def stream_valid(self, c, width=32, height=24, rate=50.0):
        seq = 0
        while not self.stop.is_set():
            data = os.urandom(width * height * 3)
            msg = image_message(seq, width, height, data, frame_id=b'valid_%d' % seq)
            c.sendall(struct.pack('<I', len(msg)) + msg)
            self.sent_crcs.append('%08x' % (zlib.crc32(data) & 0xFFFFFFFF))
            seq += 1
            time.sleep(1.0 / rate)


# --- TCPROS scenarios: (name, play(publisher, socket)) -----------------------------------
def _wrong_md5(p, c):
    c.sendall(tcpros_header([('callerid', p.caller_id), ('md5sum', '0123456789abcdef0123456789abcdef'),
                             ('type', 'sensor_msgs/Image')]))
    time.sleep(0.3)


def _error_field(p, c):
    c.sendall(tcpros_header([('error', 'hostile says no')]))
    time.sleep(0.3)


def _garbage_header(p, c):
    c.sendall(struct.pack('<I', 24) + b'\x07\x00\x00\x00no equal sign here!!')


def _huge_header(p, c):
    c.sendall(struct.pack('<I', 0x7FFFFFFF) + b'x' * 64)
    time.sleep(0.3)


def _huge_frame(p, c):
    c.sendall(p.good_header() + struct.pack('<I', 0xFFFFFFF0) + b'\x00' * 64)
    time.sleep(0.3)


def _truncated_frame(p, c):
    c.sendall(p.good_header() + struct.pack('<I', 1000) + b'\x01' * 10)


def _garbage_then_valid(p, c):
    c.sendall(p.good_header())
    junk = bytes(range(50))
    c.sendall(struct.pack('<I', len(junk)) + junk)
    p.stream_valid(c)


HOSTILE_TCP = [('wrong md5', _wrong_md5), ('error field', _error_field), ('garbage header', _garbage_header),
               ('huge header', _huge_header), ('huge frame', _huge_frame), ('truncated frame', _truncated_frame),
               ('garbage frame, then valid frames', _garbage_then_valid)]
HOSTILE_RPC = [RPC_GARBAGE, RPC_FAULT, RPC_WRONG_PROTO, RPC_OK]
