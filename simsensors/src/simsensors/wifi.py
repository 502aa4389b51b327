"""WiFi (thesis 3.3.2): access points in the world and the phone's WiFi receiver.

``libgazebo_ros_wifi_ap.so`` on any model: an access point at the model's (or ``bodyName``
link's) origin, registered as a transmitter in ``world.environment.transmitters``:
``bssid`` (aa:bb:cc:dd:ee:ff; default derived from the model name), ``ssid``, ``channel``
(1..14, 32..177) or ``frequency`` (MHz), ``txPower`` P_TX (dBm), ``txGain`` G_TX (dBi),
``txLoss`` L_TX (dB).

``libgazebo_ros_wifi.so`` on the phone: every scan (``updateRate``, default 1 Hz of sim
time) the received power of every access point by equation 3.3 (``simsensors.radio_budget``):
Friis free-space loss, obstacle loss from the ray caster (length inside solids x
``attenuation`` dB/m, per material by ``materialAttenuation``), a random miscellaneous loss
(``fading``: none | lognormal with ``fadingSigma`` dB | rayleigh) from the plugin's seeded
generator, receiver gain/loss; access points at or above ``sensitivity`` (dBm) are listed on
``wifi/scan`` (mobile_device_sim/WifiScan, strongest first, like Android's ScanResult) and the
phone keeps a link (``wifi/link``, mobile_device_sim/WifiLink) to the strongest one of
``ssid`` (any when empty), roaming when another is ``roamHysteresis`` dB stronger or the
current one falls below the sensitivity; link speed from the 802.11 rate table.
``wifi/enable`` (std_msgs/Bool) switches the radio; the battery sees it through the power bus
(flag ``wifi`` and a draw of ``power`` W while on).
"""
import hashlib
import logging


from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

from . import radio_budget as rb

__all__ = ['AccessPoint', 'WifiReceiver', 'RadioReceiver', 'RadioSwitch', 'TransmitterPlugin']

log = logging.getLogger('simsensors.wifi')


def _derived_bssid(name):
    h = hashlib.sha256(name.encode()).digest()
    return ':'.join('%02x' % b for b in (bytes([0x02]) + h[:5]))   # locally administered


def _channel_ok(c):
    try:
        rb.wifi_frequency(c)
        return True
    except ValueError:
        return False


class TransmitterPlugin(Sensor):
    """A transmitter on a model (no topics): registers in world.environment.transmitters
    while loaded."""
    KIND = None
    DEFAULT_TOPIC = None
    DEFAULT_RATE = 1.0
    tx = None

    def setup(self):
        self.tx = self.make_transmitter()
        if self.tx is not None:
            self.world.add_transmitter(self.tx)

    def make_transmitter(self):
        raise NotImplementedError

    def position(self):
        return self.world.link_pose(self.model.name, self.body).p

    def measure(self, state, dt):
        return None

    def shutdown(self):
        Sensor.shutdown(self)
        if self.tx is not None:
            self.world.remove_transmitter(self.tx)


@register('libgazebo_ros_wifi_ap.so', 'libwifi_ap.so')
class AccessPoint(TransmitterPlugin):
    KIND = 'wifi'
    PARAMS = [
        Param('bssid', str, None, aliases=('BSSID', 'mac', 'hardwareAddress'),
              check=rb.valid_bssid, check_text='of six hex pairs aa:bb:cc:dd:ee:ff',
              doc='hardware address aa:bb:cc:dd:ee:ff (default: '
              'derived from the model name, locally administered)'),
        Param('ssid', str, 'mobile_device_sim', aliases=('SSID', 'essid')),
        Param('channel', int, 6, check=_channel_ok, check_text='in 1..14 or 32..177', doc='2.4 GHz 1..14 or 5 GHz 32..177'),
        Param('frequency', float, None, unit='MHz', check='>0',
              doc='overrides channel'),
        Param('txPower', float, 20.0, aliases=('P_TX', 'p_tx', 'tx_power'), unit='dBm',
              doc='P_TX (thesis: commonly 10 to 20 dBm)'),
        Param('txGain', float, 6.0, aliases=('G_TX', 'g_tx', 'tx_gain'), unit='dBi',
              doc='G_TX (thesis: commonly 6 to 9 dBi)'),
        Param('txLoss', float, 3.0, aliases=('L_TX', 'l_tx', 'tx_loss'), unit='dB',
              doc='L_TX, cable and connector losses (magnitude; thesis: 3 to 10 dB)'),
    ]

    def make_transmitter(self):
        p = self.p
        bssid = (p.bssid or _derived_bssid(self.model.name + '/' + (self.spec.name or ''))
                 ).lower()
        freq = p.frequency if p.frequency is not None else rb.wifi_frequency(p.channel)
        chan = rb.wifi_channel(freq) if p.frequency is not None else p.channel
        return rb.Transmitter('wifi', bssid, p.ssid, freq, p.txPower, p.txGain, p.txLoss,
                              self.position, model=self.model.name, channel=chan, owner=self)


class RadioSwitch(object):
    """The on/off switch the phone's radios share (WiFi, cellular, Bluetooth, NFC): the
    parameter ``enabled`` (on at start), ``<ENABLE_TOPIC>`` (std_msgs/Bool) switches it at
    run time, and the power bus sees flag ``FLAG`` and a draw of ``power`` W while on.
    A mixin of a Sensor: call ``setup_switch()`` in ``setup``; ``on_switch(on)`` is called
    after each change."""
    ENABLE_TOPIC = None
    FLAG = None
    enabled = True

    @staticmethod
    def switch_params(power):
        return [Param('enabled', bool, True, doc='radio on at start'),
                Param('power', float, power, unit='W', check='>=0', doc='draw while on')]

    def setup_switch(self):
        from std_msgs.msg import Bool
        self.enabled = bool(self.p.enabled)
        self.subscribe(self.ENABLE_TOPIC, Bool, self._on_enable)
        self._set_power()

    def _on_enable(self, msg):
        self.set_enabled(msg.data)

    def set_enabled(self, on):
        self.enabled = bool(on)
        self._set_power()
        self.on_switch(self.enabled)

    def on_switch(self, on):
        pass

    def _set_power(self):
        self.power_flag(self.FLAG, self.enabled)
        self.power(self.FLAG, self.p.power if self.enabled else 0.0)


class RadioReceiver(RadioSwitch, Sensor):
    """Shared part of the phone's WiFi and cellular receivers: the budget to every
    transmitter of ``KIND``, switched by ``<prefix>/enable``."""
    KIND = None
    ENABLE_TOPIC = None
    FLAG = None
    ALWAYS_MEASURE = True
    COMMON = [
        Param('rxGain', float, 0.0, aliases=('G_RX', 'g_rx', 'rx_gain'), unit='dBi',
              doc='G_RX'),
        Param('rxLoss', float, 0.0, aliases=('L_RX', 'l_rx', 'rx_loss'), unit='dB',
              doc='L_RX (magnitude)'),
        Param('wallModel', rb.WALL_MODELS, 'multiwall', aliases=('wall_model',),
              doc="obstacle loss L_OB: 'multiwall' (COST 231: a loss per wall crossed) or "
                  "'per_metre' (the thesis: dB per metre inside solids)"),
        Param('wallLoss', float, rb.DEFAULT_WALL_LOSS, aliases=('wall_loss',), unit='dB',
              check='>=0', doc='multiwall: loss of a wall of no known material (COST 231 '
                               'light wall)'),
        Param('materialWallLoss', rb.parse_wall_losses, {}, aliases=('wallMaterials',),
              unit='dB', doc='multiwall: per collision <material>, e.g. "drywall:3 glass:2" '
                             '(over the built-in table)'),
        Param('maxIncidence', float, rb.DEFAULT_MAX_INCIDENCE, aliases=('max_incidence',),
              check=(1.0, 100.0), doc='multiwall: bound of the slant-path factor (length inside '
                                    '/ wall thickness = 1/cos(incidence))'),
        Param('wallThickness', float, rb.DEFAULT_WALL_THICKNESS, unit='m', check='>0',
              doc='multiwall: thickness of a solid whose shape gives none'),
        Param('attenuation', float, rb.DEFAULT_ATTENUATION,
              aliases=('obstacleAttenuation',), unit='dB/m', check='>=0',
              doc='per_metre: loss per metre inside a solid (thesis: 110 dB/m)'),
        Param('materialAttenuation', rb.parse_materials, {}, aliases=('materials',),
              unit='dB/m', doc='per_metre: per material, e.g. "glass:30 wood:40" '
                               '(collision <material>)'),
        Param('fading', rb.FADING, 'lognormal', doc='miscellaneous loss L_M'),
        Param('fadingSigma', float, 2.0, aliases=('sigma',), unit='dB', check='>=0',
              doc='standard deviation of the log-normal shadowing'),
    ] + RadioSwitch.switch_params(0.0)

    def setup(self):
        self.heard = []           # [(transmitter, P_RX dBm, terms)] of the last scan
        self.setup_switch()

    def wall_args(self):
        """The obstacle-loss model's keyword arguments for ``radio_budget.budget_to``."""
        p = self.p
        return dict(wall_model=p.wallModel, per_wall=p.wallLoss,
                    wall_materials=p.materialWallLoss, max_incidence=p.maxIncidence,
                    thickness=p.wallThickness, attenuation=p.attenuation,
                    materials=p.materialAttenuation)

    def budget(self, pos, draw=True):
        """[(transmitter, P_RX, terms)] for every transmitter of KIND (one L_M draw each,
        in a stable order, whether heard or not)."""
        p = self.p
        out = []
        seg = self.world.segment_intervals
        for tx in self.world.transmitters(self.KIND):
            l_m = rb.misc_loss(self.rng, p.fading, p.fadingSigma) if draw else 0.0
            try:
                prx, terms = rb.budget_to(tx, pos, p.rxGain, p.rxLoss, seg,
                                          ignore=(self.model.name,),
                                          l_m=l_m, **self.wall_args())
            except Exception as e:  # noqa: BLE001 - one broken transmitter, the rest work
                self.log_error('%s: transmitter %s of model %s: %s' % (
                    self.label, tx.id, tx.model, e))
                continue
            out.append((tx, prx, terms))
        return out

    def measure(self, state, dt):
        if not self.enabled:
            self.heard = []
            return self.on_scan([])
        pos = state.body_pose.p
        heard = [h for h in self.budget(pos) if h[1] >= self.p.sensitivity]
        heard.sort(key=lambda h: -h[1])
        self.heard = heard
        return self.on_scan(heard)

    def on_scan(self, heard):
        return heard


@register('libgazebo_ros_wifi.so', 'libwifi.so')
class WifiReceiver(RadioReceiver):
    KIND = 'wifi'
    FLAG = 'wifi'
    ENABLE_TOPIC = 'wifi/enable'
    DEFAULT_TOPIC = 'wifi/scan'
    DEFAULT_RATE = 1.0
    PARAMS = RadioReceiver.COMMON[:-1] + [
        Param('power', float, 0.25, unit='W', check='>=0', doc='draw while on'),
        Param('sensitivity', float, -90.0, unit='dBm', doc='receiver sensitivity'),
        Param('ssid', str, '', doc='network to join (empty: the strongest of any)'),
        Param('roamHysteresis', float, 5.0, unit='dB', check='>=0',
              doc='roam when another access point is this much stronger'),
        Param('linkTopicName', str, 'wifi/link', aliases=('link_topic',)),
    ]

    def setup(self):
        from mobile_device_sim.msg import WifiAccessPoint, WifiLink, WifiScan
        self.WifiScan, self.WifiLink, self.WifiAccessPoint = WifiScan, WifiLink, WifiAccessPoint
        self.output('main', WifiScan)
        self.link_pub = self.output('link', WifiLink, topic=self.p.linkTopicName)
        self.link = None          # (transmitter, P_RX) of the connected access point
        self.last_link = None
        RadioReceiver.setup(self)

    def on_scan(self, heard):
        cand = [h for h in heard if not self.p.ssid or h[0].name == self.p.ssid]
        cur = None
        if self.link is not None:
            cur = next((h for h in cand if h[0] is self.link[0]), None)
        best = cand[0] if cand else None
        if cur is None or (best is not None and best[1] > cur[1] + self.p.roamHysteresis):
            cur = best
        self.link = None if cur is None else (cur[0], cur[1])
        return heard

    def link_msg(self, stamp):
        m = self.WifiLink()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.enabled = self.enabled
        if self.enabled and self.link is not None:
            tx, prx = self.link
            m.connected = True
            m.bssid, m.ssid = tx.id, tx.name
            m.rssi = int(round(prx))
            m.link_speed = rb.link_speed(prx, self.p.sensitivity)
            m.frequency = int(round(tx.frequency))
        return m

    def to_msg(self, value, stamp):
        m = self.WifiScan()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.enabled = self.enabled
        for tx, prx, _ in value:
            a = self.WifiAccessPoint()
            a.bssid, a.ssid = tx.id, tx.name
            a.level = int(round(prx))
            a.frequency = int(round(tx.frequency))
            a.channel = tx.channel
            m.access_points.append(a)
        return m

    def messages(self, value, stamp):
        return {'main': lambda: self.to_msg(value, stamp),
                'link': lambda: self._link(stamp)}

    def _link(self, stamp):
        self.last_link = self.link_msg(stamp)
        return self.last_link

    def reset(self):
        RadioReceiver.reset(self)
        self.link = None
