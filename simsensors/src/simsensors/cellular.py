"""Cellular signal (thesis 3.3.2): cell towers in the world and the phone's receiver.

``libgazebo_ros_cell_tower.so`` on any model: a base station at the model's (``bodyName``)
origin: ``cellId`` (default the model name), ``operator``, ``frequency`` (MHz, default
947.4: GSM 900 downlink), ``txPower`` P_TX (dBm, 43), ``txGain`` G_TX (dBi, 15), ``txLoss``
L_TX (dB, 3).

``libgazebo_ros_cellular.so`` on the phone: every ``updateRate`` (1 Hz of sim time) the same
budget as WiFi (``simsensors.radio_budget``, obstacles by ray casts) to every tower;
``cellular/signal`` (mobile_device_sim/CellSignal) names the serving cell (the strongest,
kept until another is ``roamHysteresis`` dB stronger) with its power in dBm and as 3GPP ASU
0..31 (dBm = -113 + 2 ASU; 99 and dbm NaN when no tower is heard above ``sensitivity``).
``cellular/enable`` (std_msgs/Bool) switches the radio (flag ``cellular`` on the power bus).
"""
from sim_world.plugins import register
from sim_world.plugins.params import Param

from . import radio_budget as rb
from .wifi import RadioReceiver, TransmitterPlugin

__all__ = ['CellTower', 'CellularReceiver']


@register('libgazebo_ros_cell_tower.so', 'libcell_tower.so')
class CellTower(TransmitterPlugin):
    KIND = 'cell'
    PARAMS = [
        Param('cellId', str, None, aliases=('cell_id', 'cid'), doc='default: the model name'),
        Param('operator', str, 'sim', doc='network operator name'),
        Param('frequency', float, 947.4, unit='MHz', check='>0'),
        Param('txPower', float, 43.0, aliases=('P_TX', 'p_tx', 'tx_power'), unit='dBm'),
        Param('txGain', float, 15.0, aliases=('G_TX', 'g_tx', 'tx_gain'), unit='dBi'),
        Param('txLoss', float, 3.0, aliases=('L_TX', 'l_tx', 'tx_loss'), unit='dB'),
    ]

    def make_transmitter(self):
        p = self.p
        return rb.Transmitter('cell', p.cellId or self.model.name, p.operator, p.frequency,
                              p.txPower, p.txGain, p.txLoss, self.position,
                              model=self.model.name, owner=self)


@register('libgazebo_ros_cellular.so', 'libcellular.so')
class CellularReceiver(RadioReceiver):
    KIND = 'cell'
    FLAG = 'cellular'
    ENABLE_TOPIC = 'cellular/enable'
    DEFAULT_TOPIC = 'cellular/signal'
    DEFAULT_RATE = 1.0
    PARAMS = RadioReceiver.COMMON[:-1] + [
        Param('power', float, 0.0, unit='W', check='>=0', doc='draw while on'),
        Param('sensitivity', float, -110.0, unit='dBm', doc='receiver sensitivity'),
        Param('roamHysteresis', float, 3.0, unit='dB', check='>=0'),
    ]

    def setup(self):
        from mobile_device_sim.msg import CellSignal
        self.CellSignal = CellSignal
        self.output('main', CellSignal)
        self.serving = None
        RadioReceiver.setup(self)

    def on_scan(self, heard):
        cur = None
        if self.serving is not None:
            cur = next((h for h in heard if h[0] is self.serving[0]), None)
        best = heard[0] if heard else None
        if cur is None or (best is not None and best[1] > cur[1] + self.p.roamHysteresis):
            cur = best
        self.serving = None if cur is None else (cur[0], cur[1])
        return (self.serving,)        # a value even when no cell is heard (asu 99)

    def to_msg(self, value, stamp):
        m = self.CellSignal()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.enabled = self.enabled
        serving = value[0]
        if self.enabled and serving is not None:
            m.cell_id = serving[0].id
            m.dbm = float(serving[1])
            m.asu = rb.asu_from_dbm(serving[1])
        else:
            m.asu, m.dbm = 99, float('nan')
        return m

    def reset(self):
        RadioReceiver.reset(self)
        self.serving = None
