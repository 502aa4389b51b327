"""The studio (issue 47): an aiohttp server beside rospy that shows the running world in a
browser and drives it through one versioned JSON command protocol (``protocol``)."""
