"""spawn_model: put a URDF/xacro/SDF model into the running world (as gazebo_ros's).

    rosrun mobile_device_sim spawn_model -urdf -param robot_description -model mobile_device \
        -x 3.32 -y -2.1 -z 1.0 [-R r -P p -Y y] [-reference_frame desk] [-robot_namespace ns]
    rosrun mobile_device_sim spawn_model -file sim_world/urdf/flycam.urdf.xacro -model flycam
    rosrun mobile_device_sim spawn_model -sdf -file box.sdf -model box

A .xacro file is expanded first. Exit status 0 when the world accepted the model, 1 with
one line saying why otherwise.

``-robot_namespace NS`` (the spawn services' ``robot_namespace``) follows gazebo_ros's rule
(gazebo_ros_api_plugin's walkChildAddRobotNamespace): every plugin of the model that names no
``<robotNamespace>`` of its own gets ``<robotNamespace>NS</robotNamespace>``; a plugin's own
wins (an empty one too: the global namespace). So one description spawned twice, with
``-robot_namespace /phone2`` the second time, gives two phones side by side. A URDF robot
spawned in NS publishes its tf frames as ``NS/<link>`` unless the parameter ``/NS/tf_prefix``
says otherwise (ROS 1's tf_prefix; office.launch sets ``/mobile_device/tf_prefix`` to '' so
the phone keeps its plain frame names). A model whose plugins would take a topic or service
of another model's is refused (sim_world.world.World.add_model), naming both and the name.
"""
import argparse
import sys

__all__ = ['parse_args', 'main', 'spawn_xml', 'one_line', 'fill_robot_namespace',
           'model_description', 'parse_description']


def one_line(text):
    """``text`` with every unprintable character (newlines in a name...) escaped: a status
    message and its log line stay one line whatever the request held."""
    return ''.join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def fill_robot_namespace(model, namespace):
    """gazebo_ros's spawn rule: each plugin of ``model`` whose element has no
    ``<robotNamespace>`` child gets one holding ``namespace``; a plugin's own stays (an empty
    own one becomes '/', the global namespace it means, so that the model's namespace is not
    taken for it). Nothing happens for an empty ``namespace``. Returns how many were filled."""
    import xml.etree.ElementTree as ET
    if not (namespace or '').strip('/'):
        return 0
    filled = 0
    for spec in model.plugins:
        el = spec.element
        if el is None:
            continue
        own = [c for c in el if isinstance(c.tag, str)
               and c.tag.rsplit('}', 1)[-1].split(':')[-1] == 'robotNamespace']
        for c in own:
            if not (c.text or '').strip():
                c.text = '/'
        if not own:
            ET.SubElement(el, 'robotNamespace').text = namespace
            filled += 1
    return filled


def _tf_prefix(world, namespace):
    """tf frame prefix of a URDF robot spawned in ``namespace``: the namespace, or the
    parameter ``/<namespace>/tf_prefix`` where it is set (read only with ROS)."""
    if not namespace or not world.ros_enabled:
        return namespace
    try:
        import rospy
        return str(rospy.get_param('/%s/tf_prefix' % namespace, namespace)).strip('/')
    except Exception:  # noqa: BLE001 - no master: the namespace
        return namespace


def spawn_xml(world, kind, name, xml, robot_namespace='', initial_pose=None,
              reference_frame=''):
    """What /gazebo/spawn_urdf_model (kind 'urdf') and /gazebo/spawn_sdf_model ('sdf') do
    with a request: parse ``xml``, place the model at ``initial_pose`` (a
    sim_world.transforms.Pose, or a geometry_msgs/Pose) in ``reference_frame`` and add it to
    ``world``. Returns ``(success, status_message)``; a bad request is ``False`` with a
    message naming what is wrong, and leaves nothing of the model in the world."""
    ok, msg = _spawn_xml(world, kind, name, xml, robot_namespace, initial_pose,
                         reference_frame)
    return ok, one_line(msg)


def _spawn_xml(world, kind, name, xml, robot_namespace, initial_pose, reference_frame):
    from .model import ModelError
    from .transforms import InvalidPose, Pose
    if not name:
        return False, 'SpawnModel: model_name is empty'
    try:
        if initial_pose is None:
            initial = Pose()
        elif isinstance(initial_pose, Pose):
            initial = initial_pose
        else:
            initial = Pose.from_msg(initial_pose)
    except InvalidPose as e:
        return False, 'SpawnModel: model %r: bad initial_pose: %s' % (name, e)
    namespace = (robot_namespace or '').strip('/')
    tf_prefix = _tf_prefix(world, namespace) if kind != 'sdf' else None
    with world.lock:
        if name in world.models:
            return False, 'SpawnModel: a model named %r already exists' % name
        try:
            model = parse_description(kind, xml, name, robot_namespace)
            if kind != 'sdf':
                model.tf_prefix = tf_prefix
            if reference_frame not in ('', 'world', 'map', '/world', '/map'):
                frame, _, _ = world.entity_state(reference_frame)
                initial = frame * initial
            model.pose = initial * model.pose if kind == 'sdf' else initial
            world.add_model(model)
        except (ModelError, InvalidPose) as e:
            return False, 'SpawnModel: model %r not spawned: %s' % (name, e)
        except KeyError as e:
            return False, 'SpawnModel: model %r not spawned: reference_frame: %s' % (
                name, e.args[0])
    return True, 'SpawnModel: Successfully spawned entity'


def parse_description(kind, xml, name, robot_namespace='', base_dir=None):
    """The Model of a description as the spawn services read it: ``kind`` 'urdf'
    (sim_world.urdf) or 'sdf' (one <model>, sim_world.sdf), named ``name``, in
    ``robot_namespace`` (its plugins filled in: fill_robot_namespace); ``base_dir``: the folder
    relative meshes resolve against. ModelError when it cannot be read; ValueError for
    another kind. Also what the studio reads /gazebo/get_model_description's answer with."""
    namespace = (robot_namespace or '').strip('/')
    if kind == 'sdf':
        from .sdf import parse_sdf_model
        model = parse_sdf_model(xml, base_dir)
        model.name = name
        model.robot_namespace = namespace
    elif kind == 'urdf':
        from .urdf import parse_urdf
        model = parse_urdf(xml, name=name, base_dir=base_dir, robot_namespace=namespace)
    else:
        raise ValueError('model %s: unknown description format %r (urdf or sdf)'
                         % (name, kind))
    fill_robot_namespace(model, robot_namespace)
    return model


def model_description(world, name, spawned=None):
    """What /gazebo/get_model_description answers for model ``name`` of ``world``:
    ``(success, status_message, format, xml, robot_namespace, base_dir)``. A spawned model
    (``spawned``: {name: (kind, SpawnModel request)}, gazebo_api's) gives its request's
    ``model_xml`` and ``robot_namespace`` as sent (kind 'urdf' or 'sdf'); a model of the world
    file its ``<model>`` element ('sdf', no namespace); ``base_dir`` is the folder the model's
    relative mesh and texture paths resolve against. An unknown model, or one the world keeps
    no description of (added by code), is ``False`` with a message naming it."""
    with world.lock:
        model = world.models.get(name)
        if model is None:
            return (False, one_line('GetModelDescription: no model named %r (the world has: %s)'
                                    % (name, ', '.join(sorted(world.models)) or 'none')),
                    '', '', '', '')
        base_dir = model.base_dir or ''
        source = model.source_xml
    entry = (spawned or {}).get(name)
    if entry is not None:
        kind, req = entry
        return (True, 'GetModelDescription: model %r as spawned' % name, kind,
                req.model_xml, req.robot_namespace or '', base_dir)
    if not source:
        return (False, one_line('GetModelDescription: the world keeps no description of model '
                                '%r (not spawned, not from the world file)' % name),
                '', '', '', '')
    return (True, 'GetModelDescription: model %r as the world file has it' % name,
            'urdf' if _urdf_text(source) else 'sdf', source, model.robot_namespace or '', base_dir)


def _urdf_text(text):
    """Whether description text is a URDF (its root is <robot>)."""
    import xml.etree.ElementTree as ET
    try:
        return ET.fromstring(text).tag == 'robot'
    except ET.ParseError:
        return False


def parse_args(argv):
    p = argparse.ArgumentParser(prog='spawn_model', description=__doc__.split('\n\n')[0])
    p.add_argument('-urdf', action='store_true')
    p.add_argument('-sdf', action='store_true')
    p.add_argument('-file')
    p.add_argument('-param')
    p.add_argument('-model', required=True)
    for k in ('x', 'y', 'z', 'R', 'P', 'Y'):
        p.add_argument('-' + k, type=float, default=0.0)
    p.add_argument('-reference_frame', default='')
    p.add_argument('-robot_namespace', default=None,
                   help="the plugins' ROS namespace (default the node's, as gazebo_ros's)")
    p.add_argument('-timeout', type=float, default=30.0)
    p.add_argument('-J', nargs=2, action='append', default=[], metavar=('JOINT', 'VALUE'),
                   help='a joint position set after spawning (set_model_configuration)')
    a = p.parse_args(argv)
    try:
        a.J = [(n, float(v)) for n, v in a.J]
    except ValueError:
        p.error('-J takes a joint name and a number, got %s' % a.J)
    if bool(a.file) == bool(a.param):
        p.error('give exactly one of -file and -param')
    return a


def main(argv=None):
    import rospy
    from mobile_device_sim.srv import SpawnModel, SpawnModelRequest
    from .model import ModelError
    from .transforms import Pose
    from .urdf import process_xacro
    argv = rospy.myargv(argv if argv is not None else sys.argv)[1:]
    a = parse_args(argv)
    rospy.init_node('spawn_model', anonymous=True)
    if a.param:
        if not rospy.has_param(a.param):
            rospy.logfatal('spawn_model: parameter %s is not set' % a.param)
            return 1
        xml = rospy.get_param(a.param)
    else:
        try:
            if a.file.endswith('.xacro'):
                xml = process_xacro(a.file)
            else:
                with open(a.file) as f:
                    xml = f.read()
        except (OSError, ModelError) as e:
            rospy.logfatal('spawn_model: cannot read %s: %s' % (a.file, e))
            return 1
    sdf = a.sdf or (not a.urdf and xml.lstrip().find('<sdf') >= 0)
    srv = '/gazebo/spawn_sdf_model' if sdf else '/gazebo/spawn_urdf_model'
    from .netutil import wait_for_service
    if not wait_for_service(srv, timeout=a.timeout, caller=rospy.get_name()):
        rospy.logfatal('spawn_model: service %s did not appear within %g s (is sim_world '
                       'running?)' % (srv, a.timeout))
        return 1
    req = SpawnModelRequest()
    req.model_name = a.model
    req.model_xml = xml
    req.robot_namespace = a.robot_namespace if a.robot_namespace is not None \
        else rospy.get_namespace()
    req.initial_pose = Pose.from_xyz_rpy((a.x, a.y, a.z), (a.R, a.P, a.Y)).to_msg()
    req.reference_frame = a.reference_frame
    res = rospy.ServiceProxy(srv, SpawnModel)(req)
    if not res.success:
        rospy.logfatal('spawn_model: %s' % res.status_message)
        return 1
    rospy.loginfo('spawn_model: %s' % res.status_message)
    if a.J:       # as gazebo_ros's spawn_model: the joints set right after the spawn
        from mobile_device_sim.srv import SetModelConfiguration
        conf = '/gazebo/set_model_configuration'
        if not wait_for_service(conf, timeout=a.timeout, caller=rospy.get_name()):
            rospy.logfatal('spawn_model: service %s did not appear' % conf)
            return 1
        res = rospy.ServiceProxy(conf, SetModelConfiguration)(
            a.model, '', [n for n, _ in a.J], [v for _, v in a.J])
        if not res.success:
            rospy.logfatal('spawn_model: %s' % res.status_message)
            return 1
    return 0
