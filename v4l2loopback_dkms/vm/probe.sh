#!/bin/bash
# quick timing probe (not part of the test)
t0=$(date +%s.%N)
echo "VMTEST probe: in chroot, root=$MDS_ROOT"
source "$MDS_ROOT/build/env.sh"
python3 -c "import rospy, numpy, cv2, sensor_msgs.msg; print('VMTEST probe: imports ok')"
echo "VMTEST probe: imports took $(echo "$(date +%s.%N) - $t0" | bc 2>/dev/null || python3 -c "import time;print(time.time()-$t0)")"
insmod /run/vmtest/v4l2loopback-unpatched.ko exclusive_caps=1 && ls -la /dev/video*
v4l2-ctl --all -d /dev/video0 | head -5
echo "VMTEST RESULT: PASS"
