#!/usr/bin/env python3
"""Test helper for test/test_scenarios.py: ends this launch's sim_world (which it started)
at ~at seconds of sim time, so the runner must report the world's death as an ERROR."""
import rospy
import rosnode

if __name__ == '__main__':
    rospy.init_node('world_killer')
    at = rospy.get_param('~at', 1.0)
    while not rospy.is_shutdown() and rospy.get_time() < at:
        rospy.sleep(0.01)
    rospy.logerr('world_killer: killing /sim_world at sim time %.3f', rospy.get_time())
    rosnode.kill_nodes(['/sim_world'])
