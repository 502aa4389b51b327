/* TCPROS connection headers: building, parsing (thesis snippet 5.1.6), and
 * rejection of malformed headers. */
#include <stdlib.h>
#include "tr_internal.h"
#include "tr_test.h"

static void test_roundtrip(void)
{
    const char *kv[] = { "topic", "/mobile_device/image_raw", "type", "sensor_msgs/Image",
                         "md5sum", "060021388200f6f0f447d0fcd9c64743", "callerid", "/vmi_ros_android", NULL };
    tr_buf b;
    tr_buf_init(&b);
    tr_header_build(&b, kv);
    /* 4-byte total + 4 fields of (4 + len) */
    size_t want = 4 + (4 + strlen("topic=/mobile_device/image_raw")) + (4 + strlen("type=sensor_msgs/Image")) +
                  (4 + strlen("md5sum=060021388200f6f0f447d0fcd9c64743")) + (4 + strlen("callerid=/vmi_ros_android"));
    CHECK_EQ_INT(b.len, want);
    CHECK_EQ_INT(tr_get_le32((const uint8_t *)b.p), want - 4);
    CHECK_EQ_INT(tr_get_le32((const uint8_t *)b.p + 4), strlen("topic=/mobile_device/image_raw"));
    CHECK(!memcmp(b.p + 8, "topic=/mobile_device/image_raw", 30));
    tr_header h;
    char err[256], v[128];
    CHECK_EQ_INT(tr_header_parse((const uint8_t *)b.p + 4, b.len - 4, &h, err, sizeof err), 0);
    CHECK_EQ_INT(h.n, 4);
    CHECK(tr_header_get(&h, "md5sum", v, sizeof v));
    CHECK_STR(v, TR_IMAGE_MD5);
    CHECK(tr_header_get(&h, "callerid", v, sizeof v));
    CHECK_STR(v, "/vmi_ros_android");
    CHECK(!tr_header_get(&h, "error", v, sizeof v));
    /* truncating copy */
    char small[5];
    CHECK(tr_header_get(&h, "topic", small, sizeof small));
    CHECK_STR(small, "/mob");
    tr_buf_free(&b);
}

static void test_values_with_equals(void)
{
    /* only the first '=' separates: message_definition text contains '=' */
    uint8_t buf[64];
    const char *f = "message_definition=a=b\n===";
    tr_put_le32(buf, (uint32_t)strlen(f));
    memcpy(buf + 4, f, strlen(f));
    tr_header h;
    char err[256], v[64];
    CHECK_EQ_INT(tr_header_parse(buf, 4 + strlen(f), &h, err, sizeof err), 0);
    CHECK(tr_header_get(&h, "message_definition", v, sizeof v));
    CHECK_STR(v, "a=b\n===");
    /* empty value is allowed, empty header too */
    tr_put_le32(buf, 6);
    memcpy(buf + 4, "latch=", 6);
    CHECK_EQ_INT(tr_header_parse(buf, 10, &h, err, sizeof err), 0);
    CHECK(tr_header_get(&h, "latch", v, sizeof v));
    CHECK_STR(v, "");
    CHECK_EQ_INT(tr_header_parse(buf, 0, &h, err, sizeof err), 0);
    CHECK_EQ_INT(h.n, 0);
}

static void test_malformed(void)
{
    uint8_t buf[64];
    tr_header h;
    char err[256];
    /* field length beyond the data */
    tr_put_le32(buf, 100);
    memcpy(buf + 4, "topic=/x", 8);
    CHECK_EQ_INT(tr_header_parse(buf, 12, &h, err, sizeof err), -1);
    CHECK_CONTAINS(err, "exceeds");
    /* huge length does not wrap */
    tr_put_le32(buf, 0xFFFFFFFFu);
    CHECK_EQ_INT(tr_header_parse(buf, 12, &h, err, sizeof err), -1);
    /* no '=' */
    tr_put_le32(buf, 5);
    memcpy(buf + 4, "topic", 5);
    CHECK_EQ_INT(tr_header_parse(buf, 9, &h, err, sizeof err), -1);
    CHECK_CONTAINS(err, "without '='");
    /* peer text in a message never breaks the one-line rule */
    tr_put_le32(buf, 6);
    memcpy(buf + 4, "ab\ncd\r", 6);
    CHECK_EQ_INT(tr_header_parse(buf, 10, &h, err, sizeof err), -1);
    CHECK(strchr(err, '\n') == NULL && strchr(err, '\r') == NULL);
    CHECK_CONTAINS(err, "ab?cd?");
    /* empty name */
    tr_put_le32(buf, 2);
    memcpy(buf + 4, "=x", 2);
    CHECK_EQ_INT(tr_header_parse(buf, 6, &h, err, sizeof err), -1);
    CHECK_CONTAINS(err, "empty name");
    /* stray bytes shorter than a length */
    tr_put_le32(buf, 3);
    memcpy(buf + 4, "a=b", 3);
    buf[7] = 1; buf[8] = 2;
    CHECK_EQ_INT(tr_header_parse(buf, 9, &h, err, sizeof err), -1);
    CHECK_CONTAINS(err, "stray");
    /* too many fields */
    tr_buf b;
    tr_buf_init(&b);
    for (int i = 0; i < TR_HEADER_MAX_FIELDS + 1; i++) {
        uint8_t le[4];
        tr_put_le32(le, 3);
        tr_buf_append(&b, le, 4);
        tr_buf_append(&b, "a=b", 3);
    }
    CHECK_EQ_INT(tr_header_parse((const uint8_t *)b.p, b.len, &h, err, sizeof err), -1);
    CHECK_CONTAINS(err, "more than");
    tr_buf_free(&b);
    /* every truncation of a valid header either parses fewer fields or fails */
    const char *kv[] = { "topic", "/t", "md5sum", "*", NULL };
    tr_buf_init(&b);
    tr_header_build(&b, kv);
    int ok = 1;
    for (size_t n = 0; n + 4 < b.len; n++) {
        int rc = tr_header_parse((const uint8_t *)b.p + 4, n, &h, err, sizeof err);
        if (rc == 0 && h.n >= 2) ok = 0;
    }
    CHECK(ok);
    tr_buf_free(&b);
}

int main(void)
{
    test_roundtrip();
    test_values_with_equals();
    test_malformed();
    TEST_DONE();
}
