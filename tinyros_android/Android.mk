# Android build of tinyros (AOSP tree or ndk-build): the subscriber library with the
# camera-service shim, and tinyros_echo for a smoke test from `adb shell`.
# Only POSIX sockets and pthreads (both in bionic's libc): no roscpp, no cURL, no STL.
#
# In an AOSP tree, drop this folder under external/tinyros and add libtinyros to the
# camera HAL's LOCAL_STATIC_LIBRARIES (see README.md, "Android integration").
# JPEG for takePicture needs a libjpeg with jpeg_mem_dest (libjpeg-turbo, AOSP's
# external/libjpeg-turbo): build with TINYROS_JPEG=true.
LOCAL_PATH := $(call my-dir)

include $(CLEAR_VARS)
LOCAL_MODULE := libtinyros
LOCAL_SRC_FILES := src/xmlrpc.c src/proto.c src/subscriber.c src/camera_shim.c
LOCAL_C_INCLUDES := $(LOCAL_PATH)/include $(LOCAL_PATH)/src
LOCAL_EXPORT_C_INCLUDE_DIRS := $(LOCAL_PATH)/include
LOCAL_CFLAGS := -std=c99 -Wall -Wextra -Wno-unused-parameter -O2
ifeq ($(TINYROS_JPEG),true)
LOCAL_CFLAGS += -DTR_HAVE_JPEG=1
LOCAL_STATIC_LIBRARIES += libjpeg
endif
include $(BUILD_STATIC_LIBRARY)

include $(CLEAR_VARS)
LOCAL_MODULE := tinyros_echo
LOCAL_SRC_FILES := tools/tinyros_echo.c
LOCAL_CFLAGS := -std=c99 -Wall -O2
LOCAL_STATIC_LIBRARIES := libtinyros
ifeq ($(TINYROS_JPEG),true)
LOCAL_STATIC_LIBRARIES += libjpeg
endif
include $(BUILD_EXECUTABLE)
