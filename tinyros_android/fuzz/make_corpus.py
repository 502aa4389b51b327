#!/usr/bin/env python3
"""Writes the seed corpus of the tinyros fuzz targets into fuzz/corpus/<target>/.
Run it again after changing it; the files are committed."""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def field(s):
    b = s.encode()
    return struct.pack('<I', len(b)) + b


def header(kv):
    return b''.join(field('%s=%s' % (k, v)) for k, v in kv)


def sstr(s):
    b = s.encode() if isinstance(s, str) else s
    return struct.pack('<I', len(b)) + b


def image(w, h, enc, bpp, seq=1, frame_id='camera', be=0, pad=0):
    step = w * bpp + pad
    data = bytes((i * 7) & 0xFF for i in range(step * h))
    return (struct.pack('<III', seq, 1300000000, 5) + sstr(frame_id) + struct.pack('<II', h, w) + sstr(enc)
            + bytes([be]) + struct.pack('<I', step) + sstr(data))


def write(target, name, data):
    d = os.path.join(HERE, 'corpus', target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), 'wb') as f:
        f.write(data)


SUB = [('message_definition', 'Header header\nuint32 height\n'), ('callerid', '/vmi_ros_android'),
       ('topic', '/mobile_device/image_raw'), ('md5sum', '060021388200f6f0f447d0fcd9c64743'),
       ('type', 'sensor_msgs/Image'), ('tcp_nodelay', '1')]
PUB = [('callerid', '/camera'), ('latching', '0'), ('md5sum', '060021388200f6f0f447d0fcd9c64743'),
       ('message_definition', 'a=b\n==='), ('topic', '/mobile_device/image_raw'), ('type', 'sensor_msgs/Image')]
write('header', 'subscriber', header(SUB))
write('header', 'publisher', header(PUB))
write('header', 'error', header([('error', 'topic md5sum mismatch')]))
write('header', 'empty_value', header([('latch', '')]))
write('header', 'truncated', header(PUB)[:-5])

RESP = ("<?xml version='1.0'?>\n<methodResponse>\n<params>\n<param>\n<value><array><data>\n"
        "<value><int>1</int></value>\n<value><string>Subscribed to [/mobile_device/image_raw]</string></value>\n"
        "<value><array><data>\n<value><string>http://10.152.4.58:52605/</string></value>\n</data></array></value>\n"
        "</data></array></value>\n</param>\n</params>\n</methodResponse>\n")
write('xmlrpc', 'register_response', RESP.encode())
write('xmlrpc', 'http_response', ('HTTP/1.0 200 OK\r\nContent-Type: text/xml\r\nContent-Length: %d\r\n\r\n'
                                  % len(RESP) + RESP).encode())
CALL = ('<?xml version="1.0"?><methodCall><methodName>publisherUpdate</methodName><params>'
        '<param><value><string>/master</string></value></param>'
        '<param><value><string>/mobile_device/image_raw</string></value></param>'
        '<param><value><array><data><value><string>http://localhost:4000/</string></value>'
        '<value>http://[::1]:4001/</value></data></array></value></param></params></methodCall>')
write('xmlrpc', 'publisher_update', CALL.encode())
write('xmlrpc', 'http_request', ('POST /RPC2 HTTP/1.1\r\nHost: x\r\nContent-Length: %d\r\n\r\n'
                                 % len(CALL) + CALL).encode())
write('xmlrpc', 'request_topic_answer', (
    "<methodResponse><params><param><value><array><data><value><i4>1</i4></value><value>ready</value>"
    "<value><array><data><value>TCPROS</value><value>127.0.0.1</value><value><int>52768</int></value>"
    "</data></array></value></data></array></value></param></params></methodResponse>").encode())
write('xmlrpc', 'fault', (
    "<methodResponse><fault><value><struct><member><name>faultCode</name><value><int>1</int></value></member>"
    "<member><name>faultString</name><value>&lt;boom&#x21;&amp;</value></member></struct></value></fault>"
    "</methodResponse>").encode())
write('xmlrpc', 'types', (
    "<!-- c --><methodResponse><params><param><value><array><data><value><boolean>1</boolean></value>"
    "<value><double>-1.5e3</double></value><value><i8>9000000000</i8></value><value><nil/></value>"
    "<value><string/></value><value/><value><base64>AAEC</base64></value>"
    "<value><dateTime.iso8601>20110101T00:00:00</dateTime.iso8601></value></data></array></value>"
    "</param></params></methodResponse>").encode())
write('xmlrpc', 'uri', b'http://localhost:11311/')

write('image', 'rgb8_4x3', image(4, 3, 'rgb8', 3))
write('image', 'bgr8_padded', image(3, 2, 'bgr8', 3, pad=3))
write('image', 'mono8', image(8, 6, 'mono8', 1))
write('image', 'mono16_be', image(4, 2, 'mono16', 2, be=1))
write('image', 'rgba8', image(2, 2, 'rgba8', 4))
write('image', 'yuv422', image(4, 2, 'yuv422', 2))
write('image', 'yuyv', image(6, 2, 'yuv422_yuy2', 2))
write('image', 'empty', image(0, 0, 'rgb8', 3))
write('image', 'unsupported', image(2, 2, '32FC1', 4))
write('image', 'truncated', image(4, 3, 'rgb8', 3)[:-3])
