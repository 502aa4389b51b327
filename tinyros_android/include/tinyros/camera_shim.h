/*
 * The Android camera-service shim: the preview source that the thesis put into
 * the emulator's fake camera (CameraHardwareStub / EmulatedFakeCamera). It
 * subscribes with tinyros, takes the newest frame, scales it to the preview size
 * and converts it to YUV420SP (NV21, Android's default preview format), and to
 * JPEG for takePicture when built with TR_HAVE_JPEG (libjpeg / libjpeg-turbo).
 */
#ifndef TINYROS_CAMERA_SHIM_H
#define TINYROS_CAMERA_SHIM_H

#include <stddef.h>
#include <stdint.h>
#include "tinyros/tinyros.h"

#ifdef __cplusplus
extern "C" {
#endif

/* NV21 frame size for an even w x h */
static inline size_t tr_nv21_size(int w, int h) { return (size_t)w * (size_t)h * 3u / 2u; }

/* Scales (nearest neighbour) and converts img into NV21 of out_w x out_h (both even,
 * > 0); out holds tr_nv21_size(out_w, out_h) bytes. BT.601 studio range, chroma is
 * the mean of each 2x2 block. Encodings: rgb8 bgr8 rgba8 bgra8 mono8 8UC1 8UC3
 * (as bgr8) 8UC4 (as bgra8) mono16 yuv422 (UYVY) yuv422_yuy2 (YUYV).
 * Returns 0, or -1 with one line in err naming what was wrong. */
int tr_image_to_nv21(const tr_image *img, uint8_t *out, int out_w, int out_h, char *err, size_t errlen);

/* Same scaling, to packed RGB (3 bytes a pixel); out holds out_w*out_h*3 bytes. */
int tr_image_to_rgb(const tr_image *img, uint8_t *out, int out_w, int out_h, char *err, size_t errlen);

/* 1 when the library was built with JPEG support */
int tr_have_jpeg(void);

/* JPEG of img scaled to out_w x out_h; *jpeg is malloc'ed (free it). Returns 0 or -1. */
int tr_image_to_jpeg(const tr_image *img, int out_w, int out_h, int quality, uint8_t **jpeg, size_t *len,
                     char *err, size_t errlen);

typedef struct tr_camera tr_camera;

/* Opens the subscription (see tr_open) for a preview of preview_w x preview_h. */
tr_camera *tr_camera_open(const tr_options *o, int preview_w, int preview_h, char *err, size_t errlen);

/* Fills nv21 (tr_nv21_size bytes) with the newest frame. Waits up to timeout_ms for
 * a new frame; without one the previous preview is repeated (black before the first
 * frame; a frame that cannot be converted is reported once and skipped). Returns 1
 * for a new frame, 0 for a repeat, -1 when the subscription ended. If frame is not
 * NULL and 1 is returned, *frame describes the source frame (data valid until the
 * next call). */
int tr_camera_preview(tr_camera *c, uint8_t *nv21, int timeout_ms, tr_image *frame);

/* JPEG of the newest frame at w x h (0, 0: the frame's own size). Returns 0 or -1
 * (no frame yet, no JPEG support, bad encoding: see tr_camera_error). */
int tr_camera_take_picture(tr_camera *c, int w, int h, int quality, uint8_t **jpeg, size_t *len);

/* The last error line of the camera or its subscription. */
void tr_camera_error(tr_camera *c, char *buf, size_t len);

tr_sub *tr_camera_subscriber(tr_camera *c);
void tr_camera_close(tr_camera *c);

#ifdef __cplusplus
}
#endif
#endif
