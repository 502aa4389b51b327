"""Bluetooth external sensors (thesis 3.3.15, "Linking of external sensors"): a device in the
world reaches the phone's topics only within its range and while the phone's Bluetooth is on.

``libgazebo_ros_bluetooth_device.so`` on any model (e.g. a heart-rate belt): ``deviceName``
(default the model name), ``range`` (m, out-of-reach distance, default 10), ``quantity``
(the reading's name, default ``heart_rate``), ``heartRate``/``value`` (its mean, default 72
bpm) with ``gaussianNoise`` (default 1.0), sampled at ``updateRate`` (1 Hz of sim time) from
the device's seeded generator. It registers in ``world.environment.transmitters`` (kind
``bluetooth``).

``libgazebo_ros_bluetooth.so`` on the phone: ``bluetooth/enable`` (std_msgs/Bool, switches
the adapter; flag ``bluetooth`` and ``power`` W on the power bus); for every device, at
``updateRate`` (1 Hz): ``bluetooth/<device>/<quantity>`` (std_msgs/Float64) while connected,
and ``bluetooth/<device>/state`` (std_msgs/String, latched, on change: ``connected``,
``out_of_range`` or ``disabled``).
"""
import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

from . import radio_budget as rb
from .wifi import RadioSwitch, TransmitterPlugin

__all__ = ['BluetoothDevice', 'BluetoothAdapter', 'bt_state']


def bt_state(enabled, distance, rng):
    """'disabled' | 'connected' | 'out_of_range' for the phone's adapter and a device."""
    if not enabled:
        return 'disabled'
    return 'connected' if distance <= rng else 'out_of_range'


@register('libgazebo_ros_bluetooth_device.so', 'libbluetooth_device.so')
class BluetoothDevice(TransmitterPlugin):
    KIND = 'bluetooth'
    ALWAYS_MEASURE = True
    ERRORS = {'': dict(dims=1, gaussian_noise=1.0)}
    PARAMS = [
        Param('deviceName', str, None, aliases=('device_name', 'name'),
              doc='default: the model name'),
        Param('range', float, 10.0, aliases=('maxRange',), unit='m', check='>=0',
              doc='out-of-reach distance'),
        Param('quantity', str, 'heart_rate', doc='name of the reading (topic leaf)'),
        Param('heartRate', float, 72.0, aliases=('value',), unit='bpm (quantity unit)'),
    ]

    def make_transmitter(self):
        name = (self.p.deviceName or self.model.name).strip('/').replace('/', '_')
        self.value = None
        return rb.Transmitter('bluetooth', name, name, 2441.0, 4.0, 0.0, 0.0, self.position,
                              model=self.model.name, owner=self, range=self.p.range,
                              quantity=self.p.quantity)

    def measure(self, state, dt):
        self.value = float(self.errors[''].apply(np.array([self.p.heartRate]))[0])
        return self.value


@register('libgazebo_ros_bluetooth.so', 'libbluetooth.so')
class BluetoothAdapter(RadioSwitch, Sensor):
    DEFAULT_TOPIC = None
    DEFAULT_RATE = 1.0
    ALWAYS_MEASURE = True
    ENABLE_TOPIC = 'bluetooth/enable'
    FLAG = 'bluetooth'
    PARAMS = RadioSwitch.switch_params(0.05)

    def setup(self):
        from std_msgs.msg import Float64, String
        self.Float64, self.String = Float64, String
        self.devices = {}         # name -> dict(state, data_pub, state_pub, value)
        self.setup_switch()

    def _entry(self, tx):
        """The outputs of one device (declared when the adapter first sees it): its reading
        and its state (latched, on change)."""
        e = self.devices.get(tx.id)
        if e is None:
            base = 'bluetooth/%s/' % tx.id
            e = dict(state=None, value=None,
                     data_pub=self.output(base + tx.extra.get('quantity', 'data'),
                                          self.Float64),
                     state_pub=self.output(base + 'state', self.String, latch=True,
                                           noisy=False, on_change=True))
            self.devices[tx.id] = e
        return e

    def measure(self, state, dt):
        pos = state.body_pose.p
        out = {}
        for tx in self.world.transmitters('bluetooth'):
            d = float(np.linalg.norm(np.asarray(tx.position(), float) - pos))
            st = bt_state(self.enabled, d, tx.extra.get('range', 10.0))
            e = self._entry(tx)
            e['state'] = st
            value = tx.owner.value
            if st == 'connected' and value is not None:
                e['value'] = value
            out[tx.id] = (st, value if st == 'connected' else None)
        return out

    def messages(self, value, stamp):
        msgs = []
        for tx_id, (st, v) in value.items():
            e = self.devices[tx_id]
            msgs.append((e['state_pub'].key, self.String(data=st)))
            if v is not None:
                msgs.append((e['data_pub'].key, self.Float64(data=v)))
        return msgs
