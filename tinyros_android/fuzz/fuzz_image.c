/* libFuzzer target: sensor_msgs/Image decoder and the NV21/RGB conversion that
 * consumes its output (a hostile image must not make the camera shim read past
 * the data). */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "tinyros/camera_shim.h"
#include "tr_internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* a copy of exactly size bytes, so ASan sees any read past the message */
    uint8_t *msg = (uint8_t *)malloc(size ? size : 1);
    if (!msg) return 0;
    memcpy(msg, data, size);
    tr_image img;
    char err[256];
    if (tr_image_decode(msg, size, &img, err, sizeof err) == 0) {
        if (img.data_len && (img.data < msg || img.data + img.data_len > msg + size)) __builtin_trap();
        uint8_t nv[tr_nv21_size(8, 6)];
        uint8_t rgb[5 * 3 * 3];
        tr_image_to_nv21(&img, nv, 8, 6, err, sizeof err);
        tr_image_to_rgb(&img, rgb, 5, 3, err, sizeof err);
        tr_crc32(0, img.data, img.data_len);
    }
    free(msg);
    return 0;
}
