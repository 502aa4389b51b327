"""The battery of thesis section 3.3.10 (code snippet 3.3.4, table 3.1):
``libgazebo_ros_power_monitor.so`` (the 2011 ``<controller:gazebo_ros_power_monitor>``).

The thesis's parameters with its defaults: ``powerStateTopic`` (power_state),
``powerStateRate`` (10 Hz), ``fullChargeCapacity`` (1.400 Ah), ``dischargeRate`` (0.100 W),
``chargeRate`` (5 W), ``dischargeVoltage`` (4.95 V), ``chargeVoltage`` (5.05 V),
``updateRate`` (1.0 Hz), ``timeout`` (accepted, unused as in 2011's dummy interface).

Better than the thesis's static rate (its own proposal at the end of 3.3.10): the power drawn
is ``dischargeRate`` (the phone idle: SoC, memory, standby radio) plus what each component
draws NOW, read every tick from the world's power bus (``world.power``):

* a draw a plugin reports itself (``Sensor.power(component, W)`` ->
  ``world.power.draws(model)``) counts as it is;
* a component that is switched on by a flag (``world.power.flag(model, name)``) but reports
  no draw costs the figure of the component table (``COMPONENT_POWER``, each overridable as
  a parameter ``<name>Power``). The display is on unless its flag says otherwise and draws
  ``displayPower`` + ``backlightPower`` x brightness (flag ``display_brightness``, 0..1,
  default 0.5).

The battery charges while the charger is plugged in (std_msgs/Bool on ``charger``, or the
flag ``charger``): ``chargeRate`` W flow in, the phone's draw flows out. Energy is booked in
ampere-hours at ``dischargeVoltage`` (discharging) or ``chargeVoltage`` (charging), exactly
over each period of sim time. An empty battery stays at 0 and sets the flag
``battery_empty`` on the power bus.

Topics (in the robot namespace): ``power_state`` (mobile_device_sim/PowerState, pr2_msgs'
fields and md5sum; ``powerStateRate`` Hz), ``battery_state`` (sensor_msgs/BatteryState,
``updateRate`` Hz); in: ``charger`` (std_msgs/Bool), ``display/enable`` (std_msgs/Bool),
``display/brightness`` (std_msgs/Float32, 0..1).
"""
import math

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor
from sim_world.plugins.timer import UpdateTimer

__all__ = ['Battery', 'BatteryModel', 'COMPONENT_POWER', 'component_power']

#: W each component draws while on (flag set, no draw reported by a plugin). Figures of the
#: smartphone measurements of Carroll and Heiser, "An Analysis of Power Consumption in a
#: Smartphone", USENIX ATC 2010 (Openmoko Freerunner / HTC Dream): LCD panel 33 mW, backlight
#: up to 414 mW at full brightness, GPS 143 mW, audio (speaker) about 300 mW, WiFi
#: associated and idle about 100 mW (transfer up to 700 mW), GSM radio idle about 100 mW;
#: camera streaming about 1 W, vibration motor about 100 mW and a notification LED 20 mW are
#: typical datasheet figures.
COMPONENT_POWER = {
    'display': 0.033,        # LCD panel while on (W)
    'backlight': 0.414,      # backlight at full brightness (W), scaled by the brightness
    'camera': 1.0,
    'gps': 0.143,
    'wifi': 0.1,
    'cellular': 0.1,
    'bluetooth': 0.015,
    'vibration': 0.1,
    'led': 0.02,
    'speaker': 0.3,
    'projector': 1.5,
}

#: components whose flag is on by default (a phone's screen is on unless told otherwise)
DEFAULT_ON = ('display',)


def component_power(draws, flags, table=COMPONENT_POWER):
    """W of every component now: reported draws win; flagged components without a draw cost
    their table figure. ``flags`` is callable(name, default). Returns {component: W}."""
    out = dict(draws)
    for name, watts in table.items():
        if name == 'backlight' or name in out:
            continue
        on = flags(name, name in DEFAULT_ON)
        if not on:
            continue
        w = watts
        if name == 'display':
            b = flags('display_brightness', 0.5)
            try:
                b = min(1.0, max(0.0, float(b)))
            except (TypeError, ValueError):
                b = 0.5
            w = watts + table.get('backlight', 0.0) * b
        out[name] = w
    return out


class BatteryModel(object):
    """Charge bookkeeping in Ah (no ROS, no world): ``step(dt, load_w, charging)``."""

    def __init__(self, capacity_ah=1.4, charge_ah=None, charge_w=5.0, discharge_v=4.95,
                 charge_v=5.05):
        self.capacity = float(capacity_ah)
        self.charge = self.capacity if charge_ah is None else float(charge_ah)
        self.charge_w = float(charge_w)
        self.discharge_v = float(discharge_v)
        self.charge_v = float(charge_v)
        self.load = 0.0
        self.charging = False
        self.current = 0.0        # A into the battery (negative while discharging)

    @property
    def fraction(self):
        return self.charge / self.capacity if self.capacity > 0 else 0.0

    @property
    def voltage(self):
        return self.charge_v if self.charging else self.discharge_v

    def net_power(self):
        """W flowing into the battery (negative while discharging)."""
        return (self.charge_w if self.charging else 0.0) - self.load

    def step(self, dt, load_w, charging):
        self.load = float(load_w)
        self.charging = bool(charging)
        net = self.net_power()
        self.current = net / self.voltage
        self.charge = min(self.capacity, max(0.0, self.charge + self.current * dt / 3600.0))
        if self.charge >= self.capacity and net > 0:
            self.current = 0.0        # full: the charger feeds the phone, nothing more flows in

    def time_remaining(self):
        """s until empty (discharging) or full (charging); inf when nothing changes."""
        if self.current < 0:
            return self.charge / -self.current * 3600.0
        if self.current > 0:
            return (self.capacity - self.charge) / self.current * 3600.0
        return math.inf


@register('libgazebo_ros_power_monitor.so', 'libgazebo_ros_battery.so')
class Battery(Sensor):
    DEFAULT_TOPIC = 'battery_state'
    DEFAULT_RATE = 1.0            # thesis snippet 3.3.4: updateRate 1.0
    ALWAYS_MEASURE = True         # the charge integrates whoever listens
    USES_POSE = False
    PARAMS = [
        Param('powerStateTopic', str, 'power_state', aliases=('power_state_topic',),
              doc='PowerState topic (pr2_msgs fields)'),
        Param('powerStateRate', float, 10.0, aliases=('power_state_rate',), unit='Hz',
              check='>=0', doc='publishing rate of power_state'),
        Param('fullChargeCapacity', float, 1.400, aliases=('full_charge_capacity',),
              unit='Ah', check='>0'),
        Param('dischargeRate', float, 0.100, aliases=('discharge_rate',), unit='W',
              check='>=0', doc='base draw of the idle phone'),
        Param('chargeRate', float, 5.0, aliases=('charge_rate',), unit='W', check='>=0'),
        Param('dischargeVoltage', float, 4.95, aliases=('discharge_voltage',), unit='V',
              check='>0'),
        Param('chargeVoltage', float, 5.05, aliases=('charge_voltage',), unit='V',
              check='>0'),
        Param('initialCharge', float, 1.0, aliases=('initial_charge',), unit='fraction',
              check=(0.0, 1.0), doc='charge at start and after reset, 0..1 of full'),
        Param('chargerTopic', str, 'charger', aliases=('charger_topic',)),
        Param('timeout', float, 5.0, unit='s', check='>=0',
              doc='2011 controller parameter, accepted and unused'),
    ] + [Param('%sPower' % name, float, w, unit='W', check='>=0',
               doc='draw of the %s while on' % name)
         for name, w in sorted(COMPONENT_POWER.items())]

    def setup(self):
        from mobile_device_sim.msg import PowerState
        from sensor_msgs.msg import BatteryState
        from std_msgs.msg import Bool, Float32
        self.PowerState, self.BatteryState = PowerState, BatteryState
        p = self.p
        self.table = dict((name, getattr(p, '%sPower' % name)) for name in COMPONENT_POWER)
        self.bs_timer = UpdateTimer(self.timer.rate)
        self.ps_timer = UpdateTimer(p.powerStateRate)
        self.timer.rate = max(self.timer.rate, p.powerStateRate)
        if self.timer.rate > 0 and 0 in (self.bs_timer.rate, self.ps_timer.rate):
            self.timer.rate = 0.0    # one of them every step: so the timer
        self.bs_pub = self.output('main', BatteryState)
        self.ps_pub = self.output('power_state', PowerState, topic=p.powerStateTopic)
        self.model_b = BatteryModel(p.fullChargeCapacity, p.initialCharge * p.fullChargeCapacity,
                                    p.chargeRate, p.dischargeVoltage, p.chargeVoltage)
        self._last_t = self.world.sim_time   # integrate from the spawn
        self._due = (False, False)
        self.subscribe(p.chargerTopic, Bool, lambda m: self.set_charger(m.data))
        self.subscribe('display/enable', Bool, lambda m: self._flag('display', bool(m.data)))
        self.subscribe('display/brightness', Float32, self._on_brightness)
        self.components = {}

    # -- inputs ----------------------------------------------------------------------------
    def _flag(self, name, value):
        self.power_flag(name, value)

    def set_charger(self, plugged):
        self._flag('charger', bool(plugged))

    def _on_brightness(self, msg):
        b = float(msg.data)
        if not (0.0 <= b <= 1.0):
            self.log_error('%s: display/brightness must be 0..1, got %r' % (self.label, b))
            return
        self._flag('display_brightness', b)

    # -- the load ---------------------------------------------------------------------------
    def load_now(self):
        """(total W, {component: W}) the phone draws now."""
        bus, name = self.world.power, self.model.name
        comps = component_power(bus.draws(name), lambda f, d: bus.flag(name, f, d), self.table)
        return self.p.dischargeRate + sum(comps.values()), comps

    # -- schedule ---------------------------------------------------------------------------
    def measure(self, state, dt):
        t = state.t
        dt = 0.0 if self._last_t is None else max(0.0, t - self._last_t)
        self._last_t = t
        total, self.components = self.load_now()
        charging = bool(self.world.power.flag(self.model.name, 'charger', False))
        self.model_b.step(dt, total, charging)
        self.power_flag('battery_empty', self.model_b.charge <= 0)
        self._due = (self.ps_timer.due(t), self.bs_timer.due(t))   # both timers run on
        return (self.model_b.charge, total, charging)

    def messages(self, value, stamp):
        ps, bs = self._due
        return {'power_state': (lambda: self.power_state_msg(stamp)) if ps else None,
                'main': (lambda: self.battery_state_msg(stamp)) if bs else None}

    def power_state_msg(self, stamp):
        import rospy
        b = self.model_b
        m = self.PowerState()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        full = b.charging and b.charge >= b.capacity
        m.power_consumption = 0.0 if full else -b.net_power()   # W, negative while charging
        rem = b.time_remaining()
        m.time_remaining = rospy.Duration.from_sec(min(rem, 2.0 ** 31 - 1))
        m.prediction_method = 'component power table (sim)'
        m.relative_capacity = int(round(100.0 * b.fraction))
        m.AC_present = 1 if b.charging else 0
        return m

    def battery_state_msg(self, stamp):
        b, BS = self.model_b, self.BatteryState
        m = BS()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.voltage = b.voltage
        m.temperature = float('nan')
        m.current = b.current
        m.charge = b.charge
        m.capacity = b.capacity
        m.design_capacity = b.capacity
        m.percentage = b.fraction
        if b.charging:
            m.power_supply_status = BS.POWER_SUPPLY_STATUS_FULL if b.charge >= b.capacity \
                else BS.POWER_SUPPLY_STATUS_CHARGING
        else:
            m.power_supply_status = BS.POWER_SUPPLY_STATUS_DISCHARGING
        m.power_supply_health = BS.POWER_SUPPLY_HEALTH_DEAD if b.charge <= 0 \
            else BS.POWER_SUPPLY_HEALTH_GOOD
        m.power_supply_technology = BS.POWER_SUPPLY_TECHNOLOGY_LION
        m.present = True
        m.location = self.model.name
        return m

    def reset(self):
        Sensor.reset(self)
        now = self.world.sim_time
        self.bs_timer.reset(now)
        self.ps_timer.reset(now)
        self._last_t = now
        self.model_b.charge = self.p.initialCharge * self.model_b.capacity
