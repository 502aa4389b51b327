#!/bin/bash
# Runs inside the test VM (chroot into the host root, see vm/init): the project's
# environment, then guest_checks.py, which prints the VMTEST lines the host reads.
set +u
cd "$MDS_ROOT"
# shellcheck disable=SC1091
source "$MDS_ROOT/build/env.sh"
export PYTHONUNBUFFERED=1
# Under emulation every directory read over 9p is slow: keep ROS from crawling /usr/share
# for its logging configuration in every node, and let rospack keep its cache.
export ROS_PYTHON_LOG_CONFIG_FILE=/etc/ros/python_logging.conf
export ROS_CACHE_TIMEOUT=86400
echo "VMTEST guest: $(nproc) cpus, $(awk '/MemTotal/{print $2/1024 " MiB"}' /proc/meminfo), python $(command -v python3)"
exec python3 "$MDS_ROOT/v4l2loopback_dkms/vm/guest_checks.py"
