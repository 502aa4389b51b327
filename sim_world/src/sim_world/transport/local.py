"""This process's own node, as rospy keeps it: its services called as functions, its new
publishers heard as rospy tells the master, its namespace set before init_node, and what
rospy noted of a received message and of a subscription's connections.

Moved here from testing_instance's embed.py and intake.py (issue 45): rospy's public API
has none of these; they are the parts of the testing instance that reached into
``rospy.impl`` and rospy's private attributes. The testing instance uses them through the
facade (``sim_world.transport``).
"""

__all__ = ['LocalService', 'connection_header', 'local_service', 'on_new_publisher',
           'received_count', 'remove_listener', 'set_namespace']


class LocalService(object):
    """A service of this very process, called as a function: a ServiceProxy's interface
    (positional or keyword fields, or a request; ``close``) without the master lookup,
    the serialization and the socket. A handler's exception becomes rospy's
    ServiceException, as a remote caller would see it."""

    def __init__(self, impl):
        self.impl = impl
        self.resolved_name = impl.resolved_name

    def __call__(self, *args, **kwds):
        import rospy
        from rospy.impl.tcpros_service import convert_return_to_response
        from rospy.msg import args_kwds_to_message
        impl = self.impl
        req = args_kwds_to_message(impl.request_class, args, kwds)
        try:
            res = impl.handler(req)
            return convert_return_to_response(res, impl.response_class)
        except rospy.ServiceException:
            raise
        except Exception as e:  # noqa: BLE001 - as rospy reports a handler's error
            raise rospy.ServiceException('service [%s] responded with an error: %s'
                                         % (self.resolved_name, e))

    call = __call__

    def close(self):
        pass


def local_service(name):
    """LocalService of the service ``name`` this process serves, or None."""
    import rospy
    from rospy.impl.registration import get_service_manager
    impl = get_service_manager().get_service(rospy.resolve_name(name))
    return LocalService(impl) if impl is not None else None


def on_new_publisher(callback):
    """callback(topic) whenever this process declares a publisher from now on (rospy's
    registration listeners, through which rospy itself tells the master). Returns the
    listener, for :func:`remove_listener`."""
    from rospy.impl import registration

    class Listener(registration.RegistrationListener):
        def reg_added(self, resolved_name, data_type_or_uri, reg_type):
            if reg_type == registration.Registration.PUB:
                callback(resolved_name)

        def reg_removed(self, resolved_name, data_type_or_uri, reg_type):
            pass
    listener = Listener()
    registration.get_registration_listeners().add_listener(listener)
    return listener


def remove_listener(listener):
    """Stop telling ``listener`` (from :func:`on_new_publisher`; None: nothing to do)."""
    if listener is None:
        return
    from rospy.impl.registration import get_registration_listeners
    regs = get_registration_listeners()
    with regs.lock:
        if listener in regs.listeners:
            regs.listeners.remove(listener)


def set_namespace(ns):
    """This process's node namespace (global, ending in '/'), before rospy.init_node:
    rospy takes it from ROS_NAMESPACE or the process's own argv when it is imported, never
    from init_node's argv (``__ns:=``); this sets it as roslaunch's ROS_NAMESPACE would."""
    import rospy.names
    rospy.names._set_caller_id(ns + 'unnamed')


def connection_header(msg):
    """The TCPROS connection header rospy attached to a received message ({'callerid': the
    publishing node, ...}), or None: a message handed over in this process (an embedded
    world's local delivery) has none."""
    return getattr(msg, '_connection_header', None)


def received_count(subscriber):
    """Messages rospy has read and deserialised for the rospy.Subscriber ``subscriber``
    over its connections so far (its callbacks may not have had them yet)."""
    impl = getattr(subscriber, 'impl', None)
    return sum(getattr(c, 'stat_num_msg', 0) for c in list(getattr(impl, 'connections', ())))
