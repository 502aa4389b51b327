"""The rospy this layer was written for, and the check made when it is imported.

The transport replaces and reads parts of rospy that its public API does not offer (see
``sim_world.transport``'s doc): a rospy whose internals differ would not fail at once but
mid-run, as a traceback in a writer thread or a wrong count at a slice's end. So the
facade's import checks, in a few milliseconds and without importing anything rospy does not
import itself, that rospy is the version the layer was written for (Debian 12's
``python3-rospy``, rospy 1.15.15: ``dpkg -s python3-rospy``, /usr/share/rospy/package.xml)
and that every class, function and attribute the layer patches or reads is there.

On a mismatch it raises :class:`RospyMismatch`: a SystemExit whose text is one line
naming the version and the attribute, so the sim_world node and run_scenario (both import
the facade as they start) stop with that line and no traceback, before anything runs.
``SIM_WORLD_ANY_ROSPY=1`` lets another rospy version through when every attribute is there.
"""
import os
import re

__all__ = ['WRITTEN_FOR', 'RospyMismatch', 'check', 'missing', 'rospy_version']

#: the rospy version this layer was written for (Debian 12's python3-rospy 1.15.15+ds-2)
WRITTEN_FOR = '1.15.15'
ANY_ENV = 'SIM_WORLD_ANY_ROSPY'

#: (module, dotted attribute): classes, functions and class attributes the layer patches,
#: wraps or calls
ATTRIBUTES = [
    ('rospy.impl.tcpros_pubsub', 'QueuedConnection'),
    ('rospy.impl.tcpros_pubsub', 'QueuedConnection.write_data'),
    ('rospy.impl.tcpros_pubsub', 'QueuedConnection._run'),
    ('rospy.impl.tcpros_base', 'TCPROSServer._tcp_server_callback'),
    ('rospy.impl.tcpros_base', '_tcpros_server'),
    ('rospy.impl.tcpros_service', 'ServiceImpl._handle_request'),
    ('rospy.impl.tcpros_service', 'ServiceImpl.handle'),
    ('rospy.impl.tcpros_service', 'convert_return_to_response'),
    ('rospy.impl.registration', 'get_topic_manager'),
    ('rospy.impl.registration', 'get_service_manager'),
    ('rospy.impl.registration', 'get_registration_listeners'),
    ('rospy.impl.registration', 'Registration.PUB'),
    ('rospy.impl.registration', 'RegistrationListener'),
    ('rospy.topics', '_SubscriberImpl.receive_callback'),
    ('rospy.topics', '_SubscriberImpl._invoke_callback'),
    ('rospy.topics', '_PublisherImpl.add_connection'),
    ('rospy.topics', '_PublisherImpl.acquire'),
    ('rospy.topics', '_PublisherImpl.release'),
    ('rospy.names', '_set_caller_id'),
    ('rospy.msg', 'args_kwds_to_message'),
    ('rospy.exceptions', 'TransportTerminated'),
]

#: (module, instance attribute): fields set in the module's classes' code (``self.X =``)
#: that the layer reads or sets on rospy's objects
FIELDS = [
    ('rospy.impl.tcpros_pubsub', '_connection'),
    ('rospy.impl.tcpros_pubsub', '_queue'),
    ('rospy.impl.tcpros_pubsub', '_queue_size'),
    ('rospy.impl.tcpros_pubsub', '_lock'),
    ('rospy.impl.tcpros_pubsub', '_cond_data_available'),
    ('rospy.impl.tcpros_pubsub', '_error'),
    ('rospy.impl.tcpros_pubsub', 'is_latch'),
    ('rospy.impl.tcpros_base', 'socket'),
    ('rospy.impl.tcpros_base', 'endpoint_id'),
    ('rospy.impl.tcpros_base', 'tcp_ros_server'),
    ('rospy.impl.tcpros_base', 'inbound_handler'),
    ('rospy.impl.transport', 'done'),
    ('rospy.impl.transport', 'stat_bytes'),
    ('rospy.impl.transport', 'stat_num_msg'),
    ('rospy.topics', 'impl'),
    ('rospy.topics', 'connections'),
    ('rospy.topics', 'callbacks'),
    ('rospy.topics', 'closed'),
    ('rospy.topics', 'queue_size'),
    ('rospy.topics', 'latch'),
    ('rospy.topics', 'publock'),
    ('rospy.topics', 'seq'),
    ('rospy.topics', 'resolved_name'),
    ('rospy.impl.tcpros_base', '_connection_header'),
    ('rospy.impl.registration', 'listeners'),
    ('rospy.impl.tcpros_service', 'handler'),
    ('rospy.service', 'request_class'),
    ('rospy.service', 'response_class'),
]


class RospyMismatch(SystemExit):
    """This rospy is not the one the transport was written for (one line: its text)."""


def rospy_version():
    """The installed rospy's version: its package.xml (share/rospy/ under the prefix of
    its Python library: /usr for Debian's, /opt/ros/DISTRO for ROS's own packages), else
    its distribution's metadata, else None."""
    import rospy
    d = os.path.dirname(os.path.dirname(os.path.abspath(rospy.__file__)))
    while True:
        xml = os.path.join(d, 'share', 'rospy', 'package.xml')
        if os.path.isfile(xml):
            with open(xml) as f:
                m = re.search(r'<version>\s*([^<\s]+)\s*</version>', f.read())
            if m:
                return m.group(1)
            break
        up = os.path.dirname(d)
        if up == d:
            break
        d = up
    try:
        from importlib.metadata import version
        return version('rospy')
    except Exception:  # noqa: BLE001 - PackageNotFoundError, a broken egg-info
        return None


def missing(attributes=None, fields=None):
    """'module.attribute' of the first attribute or field this rospy lacks, or None."""
    import importlib
    attributes = ATTRIBUTES if attributes is None else attributes
    fields = FIELDS if fields is None else fields
    for mod, dotted in attributes:
        try:
            obj = importlib.import_module(mod)
        except ImportError:
            return mod
        for part in dotted.split('.'):
            if not hasattr(obj, part):
                return '%s.%s' % (mod, dotted)
            obj = getattr(obj, part)
    sources = {}
    for mod, field in fields:
        if mod not in sources:
            try:
                path = importlib.import_module(mod).__file__
                with open(path) as f:
                    sources[mod] = f.read()
            except (ImportError, OSError, TypeError):
                return mod
        if not re.search(r'\.%s\s*=[^=]' % re.escape(field), sources[mod]):
            return '%s: the field %s' % (mod, field)
    return None


def check(version=None, attributes=None, fields=None, env=None):
    """Raise :class:`RospyMismatch` (one line) unless rospy is ``WRITTEN_FOR`` (or
    ``SIM_WORLD_ANY_ROSPY`` is set) and has every attribute and field the layer uses.
    ``version``, ``attributes``, ``fields``, ``env``: the tests' stand-ins."""
    env = os.environ if env is None else env
    found = rospy_version() if version is None else version
    lacking = missing(attributes, fields)
    if lacking is not None:
        raise RospyMismatch(
            'sim_world.transport: written for rospy %s (Debian 12\'s python3-rospy), found '
            'rospy %s without %s, which the lockstep\'s transport uses: this world cannot '
            'run with this rospy' % (WRITTEN_FOR, found, lacking))
    if found != WRITTEN_FOR and not env.get(ANY_ENV):
        raise RospyMismatch(
            'sim_world.transport: written for rospy %s (Debian 12\'s python3-rospy), found '
            'rospy %s (every attribute it uses is there: %s=1 runs it anyway)'
            % (WRITTEN_FOR, found, ANY_ENV))
