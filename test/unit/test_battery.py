"""The battery (thesis 3.3.10, snippet 3.3.4, table 3.1) on the World, without ROS (bad
parameters: test_sensor_contract.py)."""
import math

import pytest

from sim_world.transforms import Pose

from simsensors.battery import COMPONENT_POWER, Battery, BatteryModel, component_power

import worlds

THESIS = ('<alwaysOn>true</alwaysOn><updateRate>1.0</updateRate><timeout>5</timeout>'
          '<robotNamespace>/mobile_device</robotNamespace><powerStateTopic>power_state</powerStateTopic>'
          '<powerStateRate>10.0</powerStateRate><fullChargeCapacity>1.400</fullChargeCapacity>'
          '<dischargeRate>0.100</dischargeRate><chargeRate>5</chargeRate>'
          '<dischargeVoltage>4.95</dischargeVoltage><chargeVoltage>5.05</chargeVoltage>')
world = worlds.world_fixture(seed=5, step_size=0.01)


def robot(name, params='', syntax='classic'):
    return worlds.sensor_robot(
        'libgazebo_ros_power_monitor.so', params, name, syntax, body=None, mass=0.129,
        box=(0.12, 0.06, 0.01),
        plugin='battery' if syntax == 'classic' else 'gazebo_ros_power_monitor_controller')


def battery_of(world, name):
    return worlds.plugin_of(world, Battery, name)


@pytest.mark.parametrize('syntax', ['classic', '2011'])
def test_thesis_parameters_both_syntaxes(world, syntax):
    world.add_model(robot('phone', THESIS, syntax), pose=Pose((0, 0, 1)))
    b = battery_of(world, 'phone')
    assert b.p.fullChargeCapacity == 1.4 and b.p.chargeRate == 5.0
    assert b.ps_pub.topic == '/mobile_device/power_state'
    assert b.bs_pub.topic == '/mobile_device/battery_state'
    assert b.ps_timer.rate == 10.0 and b.bs_timer.rate == 1.0
    world.step(200)                    # 2 s: 20 power states, 2 (3 with t=0) battery states
    assert b.ps_pub.count in (20, 21)
    assert b.bs_pub.count in (2, 3)


def test_drains_faster_with_display_on(world):
    """Two phones, display on and off: the one with the display on loses more charge, by
    exactly the display's table figure (panel + backlight x brightness) over the time."""
    world.add_model(robot('on'), pose=Pose((0, 0, 1)))
    world.add_model(robot('off'), pose=Pose((1, 0, 1)))
    world.power.set_flag('off', 'display', False)
    world.power.set_flag('on', 'display_brightness', 1.0)
    world.step(6000)                   # 60 s of sim time
    on, off = battery_of(world, 'on').model_b, battery_of(world, 'off').model_b
    used_on, used_off = 1.4 - on.charge, 1.4 - off.charge
    assert used_on > used_off > 0
    t = 60.0
    display = COMPONENT_POWER['display'] + COMPONENT_POWER['backlight'] * 1.0
    assert used_off == pytest.approx(0.1 / 4.95 * t / 3600, rel=1e-6)
    assert used_on == pytest.approx((0.1 + display) / 4.95 * t / 3600, rel=1e-6)
    # the message: percent, power and a time remaining that fits the draw
    msg = battery_of(world, 'on').power_state_msg(world.ros_now())
    assert msg.power_consumption == pytest.approx(0.1 + display)
    assert msg.AC_present == 0 and msg.relative_capacity == 100
    assert msg.time_remaining.to_sec() == pytest.approx(on.charge * 4.95 / (0.1 + display) * 3600,
                                                        rel=1e-6)


def test_reported_draws_and_flags(world):
    """A draw a plugin reports (world.power) counts as reported; a flag without a draw costs
    the table figure; the brightness scales the backlight."""
    world.add_model(robot('p'), pose=Pose((0, 0, 1)))
    b = battery_of(world, 'p')
    base, comps = b.load_now()
    assert comps == {'display': pytest.approx(0.033 + 0.414 * 0.5)}
    world.power.set_draw('p', 'gps', 0.2)          # reported by the GPS: wins over the table
    world.power.set_flag('p', 'gps', True)
    world.power.set_flag('p', 'camera', True)      # flagged, no draw: the table's 1 W
    world.power.set_flag('p', 'display_brightness', 0.0)
    total, comps = b.load_now()
    assert comps['gps'] == 0.2 and comps['camera'] == 1.0
    assert comps['display'] == pytest.approx(0.033)
    assert total == pytest.approx(0.1 + 0.2 + 1.0 + 0.033)


def test_charger_charges_and_reports(world):
    world.add_model(robot('p', '<initialCharge>0.5</initialCharge>'), pose=Pose((0, 0, 1)))
    b = battery_of(world, 'p')
    world.step(100)
    low = b.model_b.charge
    assert low < 0.7
    b.set_charger(True)
    world.step(3600)                   # 36 s at (5 W - load) / 5.05 V
    total, _ = b.load_now()
    assert b.model_b.charge - low == pytest.approx((5.0 - total) / 5.05 * 36.0 / 3600, rel=0.01)
    ps = b.power_state_msg(world.ros_now())
    assert ps.AC_present == 1 and ps.power_consumption < 0
    bs = b.battery_state_msg(world.ros_now())
    assert bs.power_supply_status == bs.POWER_SUPPLY_STATUS_CHARGING and bs.current > 0
    assert bs.percentage == pytest.approx(b.model_b.charge / 1.4)
    b.set_charger(False)
    world.step(10)
    assert b.battery_state_msg(world.ros_now()).current < 0


def test_empty_and_full_clamp():
    m = BatteryModel(capacity_ah=0.001, charge_ah=0.0005)
    m.step(3600, 1.0, False)
    assert m.charge == 0.0
    m.step(3600, 0.0, True)
    assert m.charge == 0.001 and m.current == 0.0
    assert math.isinf(m.time_remaining())


def test_component_power_pure():
    flags = {'display': False, 'led': True}
    out = component_power({'speaker': 0.25}, lambda n, d: flags.get(n, d))
    assert out == {'speaker': 0.25, 'led': COMPONENT_POWER['led']}


def test_same_seed_same_data():
    def run():
        with worlds.opened('ode', 11, step_size=0.01) as w:
            w.add_model(robot('p'), pose=Pose((0, 0, 1)))
            b = battery_of(w, 'p')
            return worlds.sample(w, 100, 5, lambda: (b.model_b.charge, b.last_msg.percentage,
                                                     b.last_msg.current))
    assert run() == run()
