/*
 * tinyros: a small ROS 1 subscriber for sensor_msgs/Image in plain C99 + POSIX.
 *
 * No roscpp, no XML or HTTP library: the master and slave XML-RPC calls, the
 * TCPROS handshake and the Image decoding are all in this library, so it can be
 * built into the Android mediaserver (Android.mk beside this file).
 *
 *   tr_options o; tr_options_init(&o);
 *   o.master_uri = "http://localhost:11311/"; o.topic = "/mobile_device/image_raw";
 *   char err[256]; tr_sub *s = tr_open(&o, err, sizeof err);
 *   if (!s) { fprintf(stderr, "%s\n", err); ... }
 *   tr_image img;
 *   while (tr_wait(s, &img, 1000) >= 0) { ... img.data, img.width ... }
 *   tr_close(s);
 *
 * One background thread does all network I/O: it serves the node's XML-RPC slave
 * API (publisherUpdate from the master), connects to every publisher of the topic
 * (requestTopic + TCPROS), and keeps the newest complete frame. tr_wait() hands
 * that frame out without copying it. Publishers that go away are dropped; the
 * master's publisherUpdate brings new ones; a listed publisher whose connection
 * failed is retried every retry_ms. A frame whose declared length is above
 * max_message_bytes is rejected before any allocation.
 */
#ifndef TINYROS_TINYROS_H
#define TINYROS_TINYROS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define TR_IMAGE_MD5 "060021388200f6f0f447d0fcd9c64743"
#define TR_IMAGE_TYPE "sensor_msgs/Image"
#define TR_DEFAULT_CALLER_ID "/vmi_ros_android"
#define TR_DEFAULT_TOPIC "/mobile_device/image_raw"
#define TR_DEFAULT_MAX_MESSAGE (64u * 1024u * 1024u)

enum tr_log_level { TR_LOG_DEBUG = 0, TR_LOG_INFO = 1, TR_LOG_WARN = 2, TR_LOG_ERROR = 3 };

typedef void (*tr_log_fn)(void *ctx, int level, const char *msg);

typedef struct tr_options {
    const char *master_uri;      /* NULL: $ROS_MASTER_URI, else http://localhost:11311/ */
    const char *topic;           /* NULL: TR_DEFAULT_TOPIC */
    const char *caller_id;       /* NULL: TR_DEFAULT_CALLER_ID */
    const char *host;            /* advertised host; NULL: $ROS_HOSTNAME, $ROS_IP, "localhost" */
    uint32_t max_message_bytes;  /* 0: TR_DEFAULT_MAX_MESSAGE */
    int timeout_ms;              /* per network step (XML-RPC call, connect, handshake); 0: 2000 */
    int retry_ms;                /* delay before reconnecting to a listed publisher; 0: 1000 */
    tr_log_fn log;               /* NULL: one line per event on stderr ("[tinyros] ERROR: ...") */
    void *log_ctx;
    int log_level;               /* lowest level passed to log; default TR_LOG_INFO */
} tr_options;

/* A decoded sensor_msgs/Image. data points into the library's buffer and stays
 * valid until the next tr_wait() or tr_close() on the same subscriber. */
typedef struct tr_image {
    uint32_t seq, stamp_sec, stamp_nsec;
    char frame_id[256];
    uint32_t height, width;
    char encoding[64];
    uint8_t is_bigendian;
    uint32_t step;
    const uint8_t *data;
    uint32_t data_len;
} tr_image;

typedef struct tr_stats {
    uint64_t frames;         /* complete, valid frames received */
    uint64_t dropped;        /* valid frames overwritten before tr_wait took them */
    uint64_t bad_frames;     /* frames rejected by the decoder (connection kept) */
    uint64_t errors;         /* connection-level errors (connection dropped) */
    uint64_t bytes;          /* payload bytes received */
    int publishers;          /* publishers listed by the master */
    int connected;           /* publishers currently streaming */
} tr_stats;

typedef struct tr_sub tr_sub;

void tr_options_init(tr_options *o);

/* Registers at the master and starts the I/O thread. On failure returns NULL and
 * writes one line naming what was wrong into err (e.g. the master is absent). */
tr_sub *tr_open(const tr_options *o, char *err, size_t errlen);

/* Waits up to timeout_ms (<0: forever) for a frame newer than the last one
 * returned. Returns 1 with *img filled, 0 on timeout, -1 if the subscriber is
 * shutting down. */
int tr_wait(tr_sub *s, tr_image *img, int timeout_ms);

void tr_get_stats(tr_sub *s, tr_stats *st);

/* The last error line (connection or decoding), "" if none. Copied into buf. */
void tr_last_error(tr_sub *s, char *buf, size_t len);

/* The node's XML-RPC URI (http://host:port/). */
const char *tr_node_uri(const tr_sub *s);

/* Unregisters from the master, stops the thread, frees everything. */
void tr_close(tr_sub *s);

/* ---- the parsers, exposed for tests, fuzzers and other transports ---------- */

/* Decodes one serialized sensor_msgs/Image (the bytes after TCPROS's 4-byte
 * length). Checks every length against the buffer and data_len == step*height.
 * Returns 0 or -1 with a message in err. */
int tr_image_decode(const uint8_t *msg, size_t len, tr_image *img, char *err, size_t errlen);

/* CRC-32 (zlib's polynomial), used by the tools to prove frames are byte-identical. */
uint32_t tr_crc32(uint32_t crc, const uint8_t *p, size_t n);

#ifdef __cplusplus
}
#endif
#endif
