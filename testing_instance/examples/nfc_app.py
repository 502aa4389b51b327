#!/usr/bin/env python3
"""The app under test of the NFC scenario (thesis 3.3.8): a contact-sharing app. When an
active NFC partner connects, the sender sends the thesis's vCard; the receiver answers 'OK'
when a vCard arrives. Both report what they received.

Parameters: ~ns (the phone's namespace, default mobile_device), ~send_vcard (bool).
Subscribes <ns>/nfc/notification, <ns>/nfc/incoming; publishes <ns>/nfc/outgoing and
~received (std_msgs/String, latched: the last data received) and ~partner (std_msgs/String,
latched: the connected partner, '' when none).
"""
import rospy
from std_msgs.msg import String

from mobile_device_sim.msg import NfcIncoming, NfcNotification, NfcOutgoing

VCARD = ('BEGIN:VCARD\nVERSION:2.1\nN:Mustermann;Max\nFN:Max Mustermann\n'
         'TEL;CELL:+49 89 289 00000\nEMAIL:max@example.org\nEND:VCARD')


def main():
    rospy.init_node('nfc_app')
    ns = '/' + rospy.get_param('~ns', 'mobile_device').strip('/')
    send = rospy.get_param('~send_vcard', False)
    out = rospy.Publisher(ns + '/nfc/outgoing', NfcOutgoing, queue_size=10)
    received = rospy.Publisher('~received', String, queue_size=10, latch=True)
    partner = rospy.Publisher('~partner', String, queue_size=10, latch=True)
    partner.publish(String(''))

    def on_note(m):
        if m.type != 'active':
            return
        if m.status == 'connected':
            partner.publish(String(m.name))
            if send:
                out.publish(NfcOutgoing(receiver=m.name, data=VCARD))
        else:
            partner.publish(String(''))

    def on_incoming(m):
        received.publish(String(m.data))
        if m.data.startswith('BEGIN:VCARD'):
            out.publish(NfcOutgoing(receiver=m.sender, data='OK'))

    rospy.Subscriber(ns + '/nfc/notification', NfcNotification, on_note, queue_size=10)
    rospy.Subscriber(ns + '/nfc/incoming', NfcIncoming, on_incoming, queue_size=10)
    rospy.spin()


if __name__ == '__main__':
    main()
