/* sensor_msgs/Image decoding: fields, zero-copy data, and every malformed case. */
#include <stdlib.h>
#include "image_util.h"
#include "tr_test.h"

static void test_decode(void)
{
    uint8_t px[4 * 3 * 2];
    for (size_t i = 0; i < sizeof px; i++) px[i] = (uint8_t)(i * 7);
    tr_buf b;
    tr_buf_init(&b);
    serialize_image(&b, 42, 1300000000, 123456789, "camera_link", 2, 4, "rgb8", 0, 12, px, sizeof px);
    tr_image img;
    char err[256];
    CHECK_EQ_INT(tr_image_decode((const uint8_t *)b.p, b.len, &img, err, sizeof err), 0);
    CHECK_EQ_INT(img.seq, 42);
    CHECK_EQ_INT(img.stamp_sec, 1300000000);
    CHECK_EQ_INT(img.stamp_nsec, 123456789);
    CHECK_STR(img.frame_id, "camera_link");
    CHECK_EQ_INT(img.height, 2);
    CHECK_EQ_INT(img.width, 4);
    CHECK_STR(img.encoding, "rgb8");
    CHECK_EQ_INT(img.is_bigendian, 0);
    CHECK_EQ_INT(img.step, 12);
    CHECK_EQ_INT(img.data_len, sizeof px);
    CHECK(img.data == (const uint8_t *)b.p + b.len - sizeof px);   /* zero-copy */
    CHECK(!memcmp(img.data, px, sizeof px));
    CHECK_EQ_INT(tr_crc32(0, img.data, img.data_len), tr_crc32(0, px, sizeof px));

    /* every truncation fails with a message, never reads past the end */
    int all_fail = 1;
    for (size_t n = 0; n < b.len; n++) {
        uint8_t *copy = (uint8_t *)malloc(n ? n : 1);
        memcpy(copy, b.p, n);
        err[0] = 0;
        if (tr_image_decode(copy, n, &img, err, sizeof err) != -1 || !err[0]) all_fail = 0;
        free(copy);
    }
    CHECK(all_fail);
    /* trailing bytes */
    tr_buf_append(&b, "x", 1);
    CHECK_EQ_INT(tr_image_decode((const uint8_t *)b.p, b.len, &img, err, sizeof err), -1);
    CHECK_CONTAINS(err, "stray");
    tr_buf_free(&b);
}

static void expect_bad(tr_buf *b, const char *why)
{
    tr_image img;
    char err[256] = "";
    CHECK_EQ_INT(tr_image_decode((const uint8_t *)b->p, b->len, &img, err, sizeof err), -1);
    CHECK_CONTAINS(err, why);
    tr_buf_free(b);
}

static void test_malformed(void)
{
    uint8_t px[16] = { 0 };
    tr_buf b;
    /* data length disagrees with step*height */
    tr_buf_init(&b);
    serialize_image(&b, 0, 0, 0, "", 2, 4, "mono8", 0, 4, px, 7);
    expect_bad(&b, "step*height");
    /* step*height overflows 32 bits */
    tr_buf_init(&b);
    serialize_image(&b, 0, 0, 0, "", 2, 1, "mono8", 0, 0x80000000u, px, 0);
    expect_bad(&b, "step*height");
    /* declared data length beyond the message */
    tr_buf_init(&b);
    put_u32(&b, 0); put_u32(&b, 0); put_u32(&b, 0); put_str(&b, "");
    put_u32(&b, 1); put_u32(&b, 1); put_str(&b, "mono8");
    tr_buf_append(&b, "\0", 1);
    put_u32(&b, 1); put_u32(&b, 0xFFFFFFF0u);
    tr_buf_append(&b, "z", 1);
    expect_bad(&b, "exceeds");
    /* string length beyond the message */
    tr_buf_init(&b);
    put_u32(&b, 0); put_u32(&b, 0); put_u32(&b, 0); put_u32(&b, 0x7FFFFFFFu);
    tr_buf_append(&b, "abc", 3);
    expect_bad(&b, "frame_id length");
    /* encoding too long, encoding with NUL */
    char longenc[100];
    memset(longenc, 'e', 99);
    longenc[99] = 0;
    tr_buf_init(&b);
    serialize_image(&b, 0, 0, 0, "", 1, 1, longenc, 0, 1, px, 1);
    expect_bad(&b, "encoding is 99 bytes");
    tr_buf_init(&b);
    put_u32(&b, 0); put_u32(&b, 0); put_u32(&b, 0); put_str(&b, "");
    put_u32(&b, 1); put_u32(&b, 1);
    put_u32(&b, 3); tr_buf_append(&b, "a\0b", 3);
    tr_buf_append(&b, "\0", 1);
    put_u32(&b, 1); put_u32(&b, 1); tr_buf_append(&b, "q", 1);
    expect_bad(&b, "NUL");
    /* frame_id longer than 255 */
    char fid[300];
    memset(fid, 'f', 299);
    fid[299] = 0;
    tr_buf_init(&b);
    serialize_image(&b, 0, 0, 0, fid, 1, 1, "mono8", 0, 1, px, 1);
    expect_bad(&b, "frame_id is 299 bytes");
    /* empty message */
    tr_image img;
    char err[128];
    CHECK_EQ_INT(tr_image_decode((const uint8_t *)"", 0, &img, err, sizeof err), -1);
    /* an empty 0x0 image is valid */
    tr_buf_init(&b);
    serialize_image(&b, 1, 2, 3, "f", 0, 0, "rgb8", 0, 0, px, 0);
    CHECK_EQ_INT(tr_image_decode((const uint8_t *)b.p, b.len, &img, err, sizeof err), 0);
    CHECK_EQ_INT(img.data_len, 0);
    tr_buf_free(&b);
}

static void test_crc(void)
{
    CHECK_EQ_INT(tr_crc32(0, (const uint8_t *)"123456789", 9), 0xCBF43926u);
    CHECK_EQ_INT(tr_crc32(0, (const uint8_t *)"", 0), 0);
    /* incremental == one shot */
    uint32_t c = tr_crc32(0, (const uint8_t *)"1234", 4);
    CHECK_EQ_INT(tr_crc32(c, (const uint8_t *)"56789", 5), 0xCBF43926u);
}

int main(void)
{
    test_decode();
    test_malformed();
    test_crc();
    TEST_DONE();
}
