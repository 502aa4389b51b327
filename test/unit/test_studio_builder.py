"""The studio's device builder (sim_studio.builder), without a roscore: the form of the
phone's description (every plugin's declared rows with the description's values), saving
changed values where the plugins read them, the world's own checks naming each bad field
(nothing written), and the saved file spawned by the world's loader (spawn_xml) with the
changed parameters in effect."""
import json
import os
import sys

import pytest

from sim_studio import builder
from sim_world.urdf import process_xacro

sys.path.insert(0, __file__.rsplit('/', 1)[0])
from test_studio_protocol import run, studio  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
XACRO = os.path.join(ROOT, 'sim_world', 'urdf', 'mobile_device.urdf.xacro')


@pytest.fixture(scope='module')
def phone():
    return process_xacro(XACRO)


def fields(groups):
    return {f['key']: f for g in groups for f in g['fields']}


def test_the_form_has_every_plugins_declared_rows_with_the_descriptions_values(phone):
    from sim_world import plugins
    from sim_world.urdf import parse_urdf
    groups = builder.form(phone)
    model = parse_urdf(phone, name='mobile_device')
    assert [g['filename'] for g in groups] == [s.filename for s in model.plugins]
    for g, spec in zip(groups, model.plugins):
        assert [f['name'] for f in g['fields']] == \
            [r.name for r in plugins.lookup(spec.filename).param_rows()]
    f = fields(groups)
    assert f['imu_controller/updateRate']['value'] == '100.0' and \
        f['imu_controller/updateRate']['given'] and f['imu_controller/updateRate']['unit'] == 'Hz'
    # camera intrinsics from the <sensor>'s SDF paths; the sensor's own rate shown beside
    assert f['camera_controller/width']['value'] == '480'
    assert f['camera_controller/horizontal_fov']['value'] == '1.0472'
    assert f['camera_controller/updateRate']['also'] == ['30.0']
    # a row the description does not give: its default, not given
    touch = f['touch/displayWidth']
    assert not touch['given'] and touch['value'] == touch['default']
    assert f['nfc/mode']['choices'] == ['active', 'passive']
    assert f['imu_controller/alwaysOn']['choices'] == ['true', 'false']
    json.dumps(groups)                         # the reply is JSON


def test_the_holder_is_the_element_the_plugin_reads(phone):
    from sim_world.plugins.params import find_text
    from sim_world.urdf import parse_urdf
    model = parse_urdf(phone, name='mobile_device')
    n = 0
    for _key, spec in builder.plugin_keys(model):
        for row in builder._rows(spec)[1]:
            el = builder._holder(spec, row)
            text = find_text(spec, row)
            assert (el is None and text is None) or el.text == text
            n += el is not None
    assert n > 50


def test_bad_values_are_named_by_the_plugins_own_checks_and_nothing_is_written(phone,
                                                                               tmp_path):
    path = tmp_path / 'phone.urdf'
    with pytest.raises(builder.BuildError) as e:
        builder.save(phone, {'imu_controller/updateRate': '-5', 'touch/displayWidth': 'wide',
                             'gps/updateRate': '2', 'nfc/mode': 'loud'}, str(path))
    assert e.value.fields == {
        'imu_controller/updateRate': "plugin libgazebo_ros_imu.so of model mobile_device: "
                                     "updateRate must be a number >= 0, got '-5'",
        'touch/displayWidth': "plugin libgazebo_ros_touch.so of model mobile_device: "
                              "displayWidth must be a whole number > 0, got 'wide'",
        'nfc/mode': "plugin libgazebo_ros_nfc.so of model mobile_device: mode must be one of "
                    "active, passive, got 'loud'"}
    assert not path.exists() and not os.listdir(str(tmp_path))
    with pytest.raises(builder.BuildError) as e:
        builder.save(phone, {'imu_controller/rate': '5', 'radio/updateRate': '1'}, str(path))
    assert set(e.value.fields) == {'imu_controller/rate', 'radio/updateRate'}
    with pytest.raises(builder.BuildError, match='ending in .urdf'):
        builder.save(phone, {}, str(tmp_path / 'phone.txt'))
    with pytest.raises(builder.BuildError, match='no folder'):
        builder.save(phone, {}, str(tmp_path / 'nowhere' / 'phone.urdf'))
    assert not os.listdir(str(tmp_path))


def test_a_saved_device_spawns_with_the_new_values(phone, tmp_path):
    """The file, through the world's own loader and spawn (what spawn_model -urdf -file and
    /gazebo/spawn_urdf_model do), gives plugins that run with the changed values."""
    from sim_world.spawn import spawn_xml
    from sim_world.urdf import load_urdf_file
    from sim_world.world import World
    path = str(tmp_path / 'phone.urdf')
    out = builder.save(phone, {'imu_controller/updateRate': '20', 'touch/displayWidth': '600',
                               'camera_controller/width': '240', 'gps/warmStartTime': ''},
                       path)
    assert out['path'] == path and len(out['changed']) == 4
    f = fields(builder.form(open(path).read()))
    assert f['imu_controller/updateRate']['value'] == '20'
    assert f['touch/displayWidth']['value'] == '600' and f['touch/displayWidth']['given']
    assert f['camera_controller/width']['value'] == '240'
    assert not f['gps/warmStartTime']['given']         # taken out: the default applies
    # unchanged fields keep their text
    assert f['gps/coldStartTime']['value'] == '30'
    load_urdf_file(path)                               # the loader reads it as a file
    w = World(physics='ode', step_size=0.001, seed=1)
    try:
        ok, msg = spawn_xml(w, 'urdf', 'phone2', open(path).read(), robot_namespace='phone2')
        assert ok, msg
        by = {p.spec.name: p for p in w.plugins['phone2']}
        assert by['imu_controller'].update_rate == 20.0
        assert by['touch'].p.displayWidth == 600
        assert by['camera_controller'].p.width == 240
    finally:
        w.shutdown()


def test_the_ops_read_the_parameter_and_refuse_with_the_fields_errors(phone, tmp_path):
    from sim_studio import extensions
    extensions.load()
    s = studio()
    world = s.world
    world.get_param = lambda name, default=None: phone if name == '/robot_description' \
        else default
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'device_params'})))
    assert rep['ok'] and len(rep['groups']) == 23
    path = str(tmp_path / 'p.urdf')
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'save_device', 'path': path,
                                        'values': {'gps/updateRate': 'x'}})))
    assert not rep['ok'] and list(rep['errors']) == ['gps/updateRate']
    assert 'updateRate must be a number >= 0' in rep['error'] and not os.path.exists(path)
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'save_device', 'path': path,
                                        'values': {'gps/updateRate': '4'}})))
    assert rep['ok'] and rep['path'] == path and os.path.exists(path)
    rep = run(s.handle_text(json.dumps({'v': 1, 'op': 'device_params',
                                        'param': '/nothing'})))
    assert not rep['ok'] and 'no description at the parameter /nothing' in rep['error']
