/* Serializes a sensor_msgs/Image the way roscpp/rospy do (little-endian), for tests. */
#ifndef TR_IMAGE_UTIL_H
#define TR_IMAGE_UTIL_H
#include <string.h>
#include "tr_internal.h"

static void put_u32(tr_buf *b, uint32_t v)
{
    uint8_t le[4];
    tr_put_le32(le, v);
    tr_buf_append(b, le, 4);
}
static void put_str(tr_buf *b, const char *s)
{
    put_u32(b, (uint32_t)strlen(s));
    tr_buf_append(b, s, strlen(s));
}
static void serialize_image(tr_buf *b, uint32_t seq, uint32_t sec, uint32_t nsec, const char *frame_id,
                            uint32_t h, uint32_t w, const char *enc, uint8_t be, uint32_t step,
                            const uint8_t *data, uint32_t n)
{
    put_u32(b, seq); put_u32(b, sec); put_u32(b, nsec);
    put_str(b, frame_id);
    put_u32(b, h); put_u32(b, w);
    put_str(b, enc);
    tr_buf_append(b, &be, 1);
    put_u32(b, step);
    put_u32(b, n);
    tr_buf_append(b, data, n);
}
#endif
