"""Names and readers of a run_scenario recording (rosbag): the meta and timeline topics."""
import json

# not recorded unless named in `record:` or used by an expectation (each one makes the
# renderer draw a frame per message)
HEAVY_TYPES = ('sensor_msgs/Image', 'sensor_msgs/CompressedImage', 'sensor_msgs/PointCloud2')
EVENTS_TOPIC = '/scenario/events'
META_TOPIC = '/scenario/meta'

__all__ = ['HEAVY_TYPES', 'EVENTS_TOPIC', 'META_TOPIC', 'read_meta']


def read_meta(bag):
    """The run's meta dict (seed, inputs, t0, duration...) of an open rosbag.Bag, or None."""
    for _topic, msg, _t in bag.read_messages(topics=[META_TOPIC]):
        return json.loads(msg.data)
    return None
