"""rosrun mobile_device_sim studio [--attach] [--world LAUNCH] [--port N] [--host ADDR]
[name:=value ...]: the studio in a browser (sim_studio/README.md)."""
import argparse
import asyncio
import os
import secrets
import sys
import tempfile

__all__ = ['main', 'parser']

DEFAULT_PORT = 8470


def parser():
    p = argparse.ArgumentParser(
        prog='studio', description='The studio: the running world in a browser, driven by '
        'a versioned JSON protocol (/ws, POST /api/cmd, GET /api/scene).')
    p.add_argument('--attach', action='store_true',
                   help='join the world already running at ROS_MASTER_URI')
    p.add_argument('--world', default='office',
                   help='launch file of the world to start: office or a path (default office)')
    p.add_argument('--port', type=int, default=DEFAULT_PORT,
                   help='HTTP port (default %d; 0: a free one)' % DEFAULT_PORT)
    p.add_argument('--host', default='127.0.0.1',
                   help='address to bind (default 127.0.0.1; another one needs the token '
                        'printed at start)')
    p.add_argument('--rate', type=float, default=40.0, help='pose stream rate, Hz')
    p.add_argument('--camera-rate', type=float, default=15.0,
                   help='camera panel frames per second at most')
    p.add_argument('--camera-topic', default='/mobile_device/image_raw')
    p.add_argument('--foxglove', nargs='?', const='', metavar='PORT',
                   help='also serve the scene, tf, images and location to Foxglove / '
                        'Lichtblick on ws://127.0.0.1:PORT (default 8765; foxglove_server.py)')
    p.add_argument('args', nargs='*', metavar='name:=value', help='launch file arguments')
    return p


def _launch_path(world):
    from testing_instance.world.worldside import LAUNCHES
    path = LAUNCHES.get(world, world)
    if not os.path.isfile(path):
        raise SystemExit('studio: --world %s: no such launch file (office or a path)' % world)
    return path


def _scene_models(rospy, assets=None):
    """The known models' descriptions: the world file's, and the launch file's URDFs (their
    meshes and textures registered in ``assets``)."""
    from . import scene
    out = []
    wf = rospy.get_param('/sim_world/world_file', None)
    if wf:
        try:
            out += scene.describe_world_file(wf, assets)
        except Exception as e:  # noqa: BLE001 - the view then shows boxes for them
            print('studio: cannot read the world file %s: %s' % (wf, e), flush=True)
    for param, name in (('/robot_description', 'mobile_device'),
                        ('/flycam_description', 'flycam')):
        text = rospy.get_param(param, None)
        if text:
            try:
                out.append(scene.describe_urdf(text, name, assets))
            except Exception as e:  # noqa: BLE001
                print('studio: cannot read %s: %s' % (param, e), flush=True)
    return out


def _health(started, uri):
    """None while the world is there; else why not and the last lines of its log."""
    from .launcher import world_running

    def health():
        if started is not None:
            if not started.alive():
                return 'the world exited (roslaunch %s)' % started.launch.p.returncode, \
                    started.log_tail()
            return None
        if not world_running(uri):
            return 'the world at %s is gone (no /gazebo/get_model_state)' % uri, []
        return None
    return health


def main(argv=None):
    import signal
    import rospy

    def _term(_sig, _frame):
        raise KeyboardInterrupt
    signal.signal(signal.SIGTERM, _term)       # stopped like Ctrl-C: its world goes too
    # Ctrl-C stops it even when it was started with SIGINT ignored (a child of a
    # non-interactive shell's background job, CI): Python then installs no handler itself
    signal.signal(signal.SIGINT, _term)
    # not rospy.myargv: it drops every name:=value, and those are the launch arguments
    argv = list(sys.argv if argv is None else argv)[1:]
    a = parser().parse_args(argv)
    from .foxglove_server import split_port
    a.foxglove, a.args = split_port(a.foxglove, a.args)
    bad = [x for x in a.args if ':=' not in x]
    if bad:
        print('studio: launch arguments are name:=value, got %s' % ' '.join(bad), flush=True)
        return 2
    from aiohttp import web
    from .launcher import LaunchError, StartedWorld, master_answers, world_running
    from .server import Studio, make_app
    from .world import WorldLink
    import rosgraph
    uri = rosgraph.get_master_uri()
    run_dir = tempfile.mkdtemp(prefix='studio-')
    started = None
    token = None
    fox = None
    if a.host not in ('127.0.0.1', 'localhost', '::1'):
        token = secrets.token_urlsafe(16)
    try:
        if a.attach:
            if not master_answers(uri) or not world_running(uri):
                print('studio: --attach: no world at %s (ROS_MASTER_URI); start one or run '
                      'without --attach' % uri, flush=True)
                return 2
        else:
            print('studio: starting the world %s on %s' % (a.world, uri), flush=True)
            try:
                started = StartedWorld(uri, _launch_path(a.world), a.args, run_dir)
            except LaunchError as e:
                print('studio: %s' % e, flush=True)
                return 2
        # argv without the launch arguments (rospy would take them as remappings)
        rospy.init_node('studio', argv=[sys.argv[0]], anonymous=True, disable_signals=True)
        from .scene import Assets
        assets = Assets()
        models = _scene_models(rospy, assets)
        world = WorldLink(rospy, a.camera_topic)
        world.articulated = {m['name']: [ln['name'] for ln in m['links']
                                         if ln['name'] != 'world']
                             for m in models if m.get('articulated')}
        world.start()
        studio = Studio(world, models, rate=a.rate, camera_rate=a.camera_rate, assets=assets,
                        token=token, run_dir=run_dir,
                        launch=a.world if a.world == 'office' else os.path.abspath(a.world))
        phones = [m['name'] for m in models if m.get('display')]
        if phones:
            from .device import DeviceWatch
            studio.device = DeviceWatch(rospy, phones)
        studio.health = _health(started, uri)
        app = make_app(studio)
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        runner = web.AppRunner(app, handle_signals=False)
        loop.run_until_complete(runner.setup())
        site = web.TCPSite(runner, a.host, a.port)
        loop.run_until_complete(site.start())
        port = runner.addresses[0][1]
        if a.foxglove is not None:
            from .foxglove_server import start as start_foxglove
            fox = start_foxglove(studio, rospy, a.foxglove, loop)
        host = a.host if ':' not in a.host else '[%s]' % a.host
        print('studio: http://%s:%d/%s' % (host, port, '?token=%s' % token if token else ''),
              flush=True)
        if token:
            print('studio: token %s (the page, /ws and /api need it)' % token, flush=True)
        # from here Ctrl-C and SIGTERM stop the loop from inside it: a KeyboardInterrupt
        # raised by a Python-level handler lands wherever the interpreter is, and once it
        # landed in a transport's __del__ during garbage collection, which swallows it, and
        # the studio never stopped (fresh clone of 2026-12-06 13:55)
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, loop.stop)
        try:
            loop.run_forever()
        except KeyboardInterrupt:
            pass
        finally:
            for sig in (signal.SIGINT, signal.SIGTERM):   # a second Ctrl-C ends the clean-up
                loop.remove_signal_handler(sig)
                signal.signal(sig, _term)
            if fox is not None:
                fox.stop()
            loop.run_until_complete(runner.cleanup())
            world.close()
            if studio.device is not None:
                studio.device.close()
            rospy.signal_shutdown('studio stopped')
        return 0
    except KeyboardInterrupt:
        return 0
    finally:
        if started is not None:
            started.stop()
        print('studio: stopped', flush=True)
