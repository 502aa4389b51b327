"""testing_instance.world.embed without a roscore: a launch file split for an embedded world
(roslaunch's own loader), the world node's argv, the world's services as function calls."""
import os

import pytest

pytest.importorskip('roslaunch')

from sim_world import transport  # noqa: E402
from testing_instance.world import embed  # noqa: E402
from testing_instance.scenario.results import RunError  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OFFICE = os.path.join(ROOT, 'sim_world', 'launch', 'office.launch')


def test_the_office_launch_splits_into_the_world_node_and_the_rest():
    plan = embed.plan_launch(OFFICE, ['paused:=true', 'seed:=5', 'real_time_factor:=0',
                                      'flycam:=false', 'camera_rate:=2'], 11311)
    assert (plan.world.package, plan.world.type, plan.world.name) == \
        ('mobile_device_sim', 'sim_world', 'sim_world')
    assert plan.world_name == '/sim_world' and plan.why is None
    params = dict(plan.params)
    assert params['/sim_world/seed'] == '5' and params['/sim_world/paused'] is True
    assert params['/sim_world/real_time_factor'] == 0
    assert params['/sim_world/world_file'].endswith('office.world')
    assert params['/use_sim_time'] is True
    # xacro ran (roslaunch's command= parameter) with the launch arguments
    # (camera_rate:=2 reached the camera's <update_rate>)
    assert '<robot' in params['/robot_description']
    assert '<update_rate>2</update_rate>' in params['/robot_description']
    assert [n.name for n in plan.nodes] == ['spawn_phone']          # flycam:=false
    assert plan.world_argv() == ['sim_world']


def test_the_world_node_keeps_its_namespace_remappings_and_args(tmp_path):
    f = tmp_path / 'ns.launch'
    f.write_text('<launch><group ns="lab"><node name="w" pkg="mobile_device_sim" '
                 'type="sim_world" args="%s/x.world"><remap from="/clock" to="/c2"/>'
                 '</node></group></launch>' % tmp_path)
    plan = embed.plan_launch(str(f), [], 11311)
    assert plan.world_name == '/lab/w'
    assert plan.world_argv() == ['sim_world', '%s/x.world' % tmp_path, '/clock:=/c2',
                                 '__ns:=/lab/']
    assert plan.nodes == []


def test_a_launch_file_without_one_world_node_says_so(tmp_path):
    f = tmp_path / 'two.launch'
    f.write_text('<launch><node name="a" pkg="mobile_device_sim" type="sim_world"/>'
                 '<node name="b" pkg="mobile_device_sim" type="sim_world"/></launch>')
    plan = embed.plan_launch(str(f), [], 11311)
    assert plan.world is None and 'has 2 mobile_device_sim/sim_world nodes' in plan.why
    assert len(plan.nodes) == 2                  # run as they are (--world-node)
    bad = tmp_path / 'bad.launch'
    bad.write_text('<launch><node name="a"')
    with pytest.raises(RunError, match='bad.launch cannot be read'):
        embed.plan_launch(str(bad), [], 11311)
    need = tmp_path / 'need.launch'
    need.write_text('<launch><arg name="must"/><param name="x" value="$(arg must)"/></launch>')
    with pytest.raises(RunError, match='need.launch cannot be read: .*must'):
        embed.plan_launch(str(need), [], 11311)
    assert dict(embed.plan_launch(str(need), ['must:=3'], 11311).params)['/x'] == 3


class _Impl(object):
    """What rospy's service manager holds for a service (ServiceImpl's fields used)."""

    def __init__(self, handler):
        from std_srvs.srv import SetBool, SetBoolRequest, SetBoolResponse
        self.handler = handler
        self.resolved_name = '/probe'
        self.service_class = SetBool
        self.request_class = SetBoolRequest
        self.response_class = SetBoolResponse


def test_a_local_service_is_called_as_a_proxy_would_call_it():
    import rospy
    seen = []

    def handler(req):
        seen.append(req.data)
        if req.data:
            return True, 'on'                     # a tuple, as rospy handlers may answer
        raise ValueError('refused')
    svc = transport.LocalService(_Impl(handler))
    res = svc(True)
    assert (res.success, res.message) == (True, 'on')
    assert svc(data=True).message == 'on'        # keyword fields
    with pytest.raises(rospy.ServiceException, match=r'service \[/probe\] responded with an '
                                                     r'error: refused'):
        svc(False)
    assert seen == [True, True, False]
    svc.close()                                  # nothing to close


def test_the_launch_files_other_nodes_start_with_their_ros_names(tmp_path):
    """Each of the launch file's other nodes runs as roslaunch would run it, and its Proc
    carries its ROS name (namespace and all): what the run says of it (WorldSide.stop)."""
    f = tmp_path / 'other.launch'
    f.write_text('<launch><node name="sim_world" pkg="mobile_device_sim" type="sim_world"/>'
                 '<group ns="lab"><node name="talker" pkg="rostopic" type="rostopic" '
                 'args="pub /x std_msgs/Empty -r 1"/></group></launch>')
    plan = embed.plan_launch(str(f), [], 11311)
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:1')    # nobody answers there
    procs_ = plan.start_nodes(env, str(tmp_path))
    try:
        assert [p.node_name for p in procs_] == ['/lab/talker']
        assert any(a.endswith('rostopic') for a in procs_[0].cmd[:2])
        assert '__name:=talker' in procs_[0].cmd
        assert (tmp_path / 'talker.log').exists()
    finally:
        for p in procs_:
            p.finish(0)                         # SIGKILL now, log closed
