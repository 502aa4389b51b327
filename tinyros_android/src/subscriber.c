/* tinyros subscriber: master registration, XML-RPC slave server, TCPROS client,
 * newest-frame triple buffer. POSIX sockets + pthreads only. */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>

#include "tr_internal.h"

#ifndef MSG_NOSIGNAL
#define MSG_NOSIGNAL 0
#endif

#define TR_MAX_PUBS 16

static const char IMAGE_DEFINITION[] =
    "Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\n"
    "uint32 step\nuint8[] data\n\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";

typedef struct fbuf { uint8_t *p; size_t cap; } fbuf;

typedef struct pub {
    char uri[256];
    char peer[128];       /* publisher's callerid from its TCPROS header */
    int listed;
    int fd;               /* TCPROS socket, -1 when not streaming */
    int64_t next_try;
    uint8_t lenb[4];
    size_t lenhave;
    uint32_t need;
    size_t have;
    fbuf w;               /* frame being received */
    char last_err[256];   /* to log a repeated failure only once */
} pub;

struct tr_sub {
    char master_uri[256], topic[256], caller_id[256], host[256], node_uri[320];
    uint32_t max_msg;
    int timeout_ms, retry_ms;
    tr_log_fn log;
    void *log_ctx;
    int log_level;

    int listen_fd;
    int wake[2];
    pthread_t th;
    int th_started;
    int stop;             /* set by tr_close; read and written under mu */
    int shutdown;         /* master asked us to shut down */

    pthread_mutex_t mu;
    pthread_cond_t cv;
    fbuf ready, reading;
    tr_image ready_img;
    int fresh;
    tr_stats st;
    char last_err[512];

    pub pubs[TR_MAX_PUBS];
    int npubs;
};

/* ---- small helpers ------------------------------------------------------------- */
static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

static void default_log(void *ctx, int level, const char *msg)
{
    static const char *names[] = { "DEBUG", "INFO", "WARN", "ERROR" };
    (void)ctx;
    fprintf(stderr, "[tinyros] %s: %s\n", names[level < 0 ? 0 : level > 3 ? 3 : level], msg);
}

static void slog(tr_sub *s, int level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void slog(tr_sub *s, int level, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    tr_printable(msg);
    if (level >= TR_LOG_ERROR) {
        pthread_mutex_lock(&s->mu);
        snprintf(s->last_err, sizeof s->last_err, "%s", msg);
        pthread_mutex_unlock(&s->mu);
    }
    if (level >= s->log_level) s->log(s->log_ctx, level, msg);
}

static void copy_str(char *dst, size_t cap, const char *src)
{
    snprintf(dst, cap, "%s", src ? src : "");
}

static int set_nonblock(int fd)
{
    int fl = fcntl(fd, F_GETFL, 0);
    if (fl < 0 || fcntl(fd, F_SETFL, fl | O_NONBLOCK) < 0) return -1;
    fcntl(fd, F_SETFD, FD_CLOEXEC);
    return 0;
}

static int wait_fd(int fd, short ev, int64_t deadline)
{
    for (;;) {
        int64_t left = deadline - now_ms();
        if (left <= 0) return 0;
        struct pollfd p = { fd, ev, 0 };
        int r = poll(&p, 1, (int)(left > 1000000 ? 1000000 : left));
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) return -1;
        if (r > 0) return 1;
    }
}

/* non-blocking connect with a deadline; returns a non-blocking fd or -1 */
static int tcp_connect(const char *host, int port, int timeout_ms, char *err, size_t errlen)
{
    struct addrinfo hints, *res = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    char ps[16];
    snprintf(ps, sizeof ps, "%d", port);
    int gr = getaddrinfo(host, ps, &hints, &res);
    if (gr) return tr_seterr(err, errlen, "cannot resolve host \"%s\": %s", host, gai_strerror(gr));
    int64_t deadline = now_ms() + timeout_ms;
    int fd = -1, last = ECONNREFUSED;
    for (struct addrinfo *a = res; a; a = a->ai_next) {
        fd = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
        if (fd < 0) { last = errno; continue; }
        set_nonblock(fd);
        if (connect(fd, a->ai_addr, a->ai_addrlen) == 0) break;
        if (errno == EINPROGRESS) {
            int w = wait_fd(fd, POLLOUT, deadline);
            if (w > 0) {
                int so = 0;
                socklen_t sl = sizeof so;
                getsockopt(fd, SOL_SOCKET, SO_ERROR, &so, &sl);
                if (so == 0) break;
                last = so;
            } else {
                last = w == 0 ? ETIMEDOUT : errno;
            }
        } else {
            last = errno;
        }
        close(fd);
        fd = -1;
    }
    freeaddrinfo(res);
    if (fd < 0) return tr_seterr(err, errlen, "connect to %s:%d failed: %s", host, port, strerror(last));
    return fd;
}

static int send_all(int fd, const void *data, size_t n, int64_t deadline, char *err, size_t errlen)
{
    const char *p = (const char *)data;
    while (n) {
        ssize_t r = send(fd, p, n, MSG_NOSIGNAL);
        if (r > 0) { p += r; n -= (size_t)r; continue; }
        if (r < 0 && errno == EINTR) continue;
        if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            int w = wait_fd(fd, POLLOUT, deadline);
            if (w == 0) return tr_seterr(err, errlen, "send timed out");
            if (w < 0) return tr_seterr(err, errlen, "send failed: %s", strerror(errno));
            continue;
        }
        return tr_seterr(err, errlen, "send failed: %s", strerror(errno));
    }
    return 0;
}

/* reads exactly n bytes before the deadline */
static int recv_exact(int fd, void *data, size_t n, int64_t deadline, const char *what, char *err, size_t errlen)
{
    char *p = (char *)data;
    size_t got = 0;
    while (got < n) {
        ssize_t r = recv(fd, p + got, n - got, 0);
        if (r > 0) { got += (size_t)r; continue; }
        if (r == 0)
            return tr_seterr(err, errlen, "connection closed after %zu of %zu bytes of the %s", got, n, what);
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
            int w = wait_fd(fd, POLLIN, deadline);
            if (w == 0) return tr_seterr(err, errlen, "timed out after %zu of %zu bytes of the %s", got, n, what);
            if (w < 0) return tr_seterr(err, errlen, "poll failed: %s", strerror(errno));
            continue;
        }
        return tr_seterr(err, errlen, "receive failed: %s", strerror(errno));
    }
    return 0;
}

/* ---- XML-RPC client -------------------------------------------------------------------- */
/* POSTs body to uri and parses the response. On success *res must be freed with
 * xr_free. ROS results ([code, statusMessage, value]) are checked by ros_call. */
static int http_call(const char *uri, const tr_buf *body, int timeout_ms, xr_value *res,
                     char *err, size_t errlen)
{
    char host[256], e2[300];
    int port;
    if (tr_uri_parse(uri, host, sizeof host, &port, err, errlen)) return -1;
    if (body->oom) return tr_seterr(err, errlen, "out of memory building the request");
    int fd = tcp_connect(host, port, timeout_ms, e2, sizeof e2);
    if (fd < 0) return tr_seterr(err, errlen, "%s", e2);
    int64_t deadline = now_ms() + timeout_ms;
    tr_buf req;
    tr_buf_init(&req);
    tr_buf_printf(&req, "POST /RPC2 HTTP/1.0\r\nHost: %s:%d\r\nUser-Agent: tinyros\r\n"
                  "Content-Type: text/xml\r\nContent-Length: %zu\r\n\r\n", host, port, body->len);
    tr_buf_append(&req, body->p, body->len);
    int rc = req.oom ? tr_seterr(e2, sizeof e2, "out of memory") : send_all(fd, req.p, req.len, deadline, e2, sizeof e2);
    tr_buf_free(&req);
    if (rc) { close(fd); return tr_seterr(err, errlen, "%s", e2); }
    tr_buf in;
    tr_buf_init(&in);
    const char *rb = NULL;
    size_t rblen = 0;
    int status = 0, done = 0, eof = 0;
    char chunk[16384];
    while (!done) {
        ssize_t r = recv(fd, chunk, sizeof chunk, 0);
        if (r > 0) tr_buf_append(&in, chunk, (size_t)r);
        else if (r == 0) eof = 1;
        else if (errno == EINTR) continue;
        else if (errno == EAGAIN || errno == EWOULDBLOCK) {
            int w = wait_fd(fd, POLLIN, deadline);
            if (w <= 0) { rc = tr_seterr(e2, sizeof e2, "no complete XML-RPC answer within %d ms", timeout_ms); break; }
            continue;
        } else { rc = tr_seterr(e2, sizeof e2, "receive failed: %s", strerror(errno)); break; }
        if (in.oom) { rc = tr_seterr(e2, sizeof e2, "out of memory"); break; }
        if (in.len == 0 && eof) { rc = tr_seterr(e2, sizeof e2, "connection closed without an answer"); break; }
        int pr = tr_http_parse(in.p, in.len, 1, eof, &status, &rb, &rblen, e2, sizeof e2);
        if (pr < 0) { rc = -1; break; }
        if (pr == 1) done = 1;
    }
    close(fd);
    if (rc == 0 && status != 200) rc = tr_seterr(e2, sizeof e2, "HTTP status %d", status);
    if (rc == 0) {
        int fault = 0;
        rc = xr_parse_response(rb, rblen, res, &fault, e2, sizeof e2);
        if (rc == 0 && fault) {
            const char *fs = "?";
            for (size_t i = 0; res->type == XR_STRUCT && i < res->n; i++)
                if (res->items[i].name && !strcmp(res->items[i].name, "faultString") && res->items[i].s)
                    fs = res->items[i].s;
            rc = tr_seterr(e2, sizeof e2, "XML-RPC fault: %.200s", fs);
            xr_free(res);
        }
    }
    tr_buf_free(&in);
    if (rc) return tr_seterr(err, errlen, "%s", e2);
    return 0;
}

/* Calls a ROS API method; on success *val points at the third element of the
 * [code, statusMessage, value] result held in *res. */
static int ros_call(const char *uri, const tr_buf *body, int timeout_ms, xr_value *res,
                    const xr_value **val, char *err, size_t errlen)
{
    if (http_call(uri, body, timeout_ms, res, err, errlen)) return -1;
    const xr_value *code = xr_at(res, 0, XR_INT);
    const xr_value *msg = xr_at(res, 1, XR_STRING);
    if (!code || !msg || res->n < 3) {
        xr_free(res);
        return tr_seterr(err, errlen, "answer is not a ROS [code, statusMessage, value] triple");
    }
    if (code->i != 1) {
        int c = (int)code->i;
        tr_seterr(err, errlen, "call failed with code %d: %.200s", c, msg->s);
        xr_free(res);
        return -1;
    }
    *val = &res->items[2];
    return 0;
}

/* ---- publishers ----------------------------------------------------------------------------- */
static void pub_close(tr_sub *s, pub *p)
{
    if (p->fd >= 0) {
        close(p->fd);
        p->fd = -1;
        pthread_mutex_lock(&s->mu);
        s->st.connected--;
        pthread_mutex_unlock(&s->mu);
    }
    p->lenhave = 0;
    p->have = 0;
    p->need = 0;
}

static void pub_fail(tr_sub *s, pub *p, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void pub_fail(tr_sub *s, pub *p, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pub_close(s, p);
    p->next_try = now_ms() + s->retry_ms;
    pthread_mutex_lock(&s->mu);
    s->st.errors++;
    pthread_mutex_unlock(&s->mu);
    /* a publisher that keeps failing the same way is reported once */
    int repeat = strcmp(msg, p->last_err) == 0;
    copy_str(p->last_err, sizeof p->last_err, msg);
    slog(s, repeat ? TR_LOG_DEBUG : TR_LOG_ERROR, "publisher %s: %s", p->uri, msg);
}

/* requestTopic + TCPROS handshake; leaves p->fd streaming or calls pub_fail */
static void pub_connect(tr_sub *s, pub *p)
{
    char err[256];
    tr_buf b;
    tr_buf_init(&b);
    xw_call_begin(&b, "requestTopic");
    xw_param_begin(&b); xw_string(&b, s->caller_id); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, s->topic); xw_param_end(&b);
    xw_param_begin(&b);
    xw_array_begin(&b); xw_array_begin(&b); xw_string(&b, "TCPROS"); xw_array_end(&b); xw_array_end(&b);
    xw_param_end(&b);
    xw_call_end(&b);
    xr_value res;
    const xr_value *proto = NULL;
    int rc = ros_call(p->uri, &b, s->timeout_ms, &res, &proto, err, sizeof err);
    tr_buf_free(&b);
    if (rc) { pub_fail(s, p, "requestTopic: %s", err); return; }
    const xr_value *pn = xr_at(proto, 0, XR_STRING);
    const xr_value *ph = xr_at(proto, 1, XR_STRING);
    const xr_value *pp = xr_at(proto, 2, XR_INT);
    if (!pn || strcmp(pn->s, "TCPROS") != 0 || !ph || !pp || pp->i < 1 || pp->i > 65535 || !ph->s[0]) {
        xr_free(&res);
        pub_fail(s, p, "requestTopic answered no usable [\"TCPROS\", host, port]");
        return;
    }
    char host[256];
    copy_str(host, sizeof host, ph->s);
    int port = (int)pp->i;
    xr_free(&res);

    int fd = tcp_connect(host, port, s->timeout_ms, err, sizeof err);
    if (fd < 0) { pub_fail(s, p, "TCPROS %s", err); return; }
    int64_t deadline = now_ms() + s->timeout_ms;
    const char *kv[] = { "message_definition", IMAGE_DEFINITION, "callerid", s->caller_id,
                         "topic", s->topic, "md5sum", TR_IMAGE_MD5, "type", TR_IMAGE_TYPE,
                         "tcp_nodelay", "1", NULL };
    tr_buf_init(&b);
    tr_header_build(&b, kv);
    rc = b.oom ? tr_seterr(err, sizeof err, "out of memory") : send_all(fd, b.p, b.len, deadline, err, sizeof err);
    tr_buf_free(&b);
    if (rc) { close(fd); pub_fail(s, p, "TCPROS handshake: %s", err); return; }
    uint8_t lb[4];
    if (recv_exact(fd, lb, 4, deadline, "connection header length", err, sizeof err)) {
        close(fd); pub_fail(s, p, "TCPROS handshake: %s", err); return;
    }
    uint32_t hl = tr_get_le32(lb);
    if (hl > TR_HEADER_MAX_BYTES || hl > s->max_msg) {
        close(fd);
        pub_fail(s, p, "TCPROS handshake: connection header length %u exceeds the limit %u", hl,
                 TR_HEADER_MAX_BYTES < s->max_msg ? TR_HEADER_MAX_BYTES : s->max_msg);
        return;
    }
    uint8_t *hb = (uint8_t *)malloc(hl ? hl : 1);
    if (!hb) { close(fd); pub_fail(s, p, "out of memory for a %u byte header", hl); return; }
    if (recv_exact(fd, hb, hl, deadline, "connection header", err, sizeof err)) {
        free(hb); close(fd); pub_fail(s, p, "TCPROS handshake: %s", err); return;
    }
    tr_header h;
    char v[256], md5[64], type[128];
    if (tr_header_parse(hb, hl, &h, err, sizeof err)) {
        free(hb); close(fd); pub_fail(s, p, "%s", err); return;
    }
    if (tr_header_get(&h, "error", v, sizeof v)) {
        free(hb); close(fd); pub_fail(s, p, "publisher refused the connection: %s", v); return;
    }
    if (!tr_header_get(&h, "md5sum", md5, sizeof md5)) {
        free(hb); close(fd); pub_fail(s, p, "TCPROS header has no md5sum"); return;
    }
    if (strcmp(md5, TR_IMAGE_MD5) != 0 && strcmp(md5, "*") != 0) {
        free(hb); close(fd);
        pub_fail(s, p, "wrong md5sum %.40s (sensor_msgs/Image is %s)", md5, TR_IMAGE_MD5);
        return;
    }
    if (tr_header_get(&h, "type", type, sizeof type) && strcmp(type, TR_IMAGE_TYPE) != 0 && strcmp(type, "*") != 0) {
        free(hb); close(fd); pub_fail(s, p, "wrong type %.60s (expected %s)", type, TR_IMAGE_TYPE); return;
    }
    if (!tr_header_get(&h, "callerid", p->peer, sizeof p->peer)) copy_str(p->peer, sizeof p->peer, "?");
    free(hb);

    /* no SO_RCVBUF: setting it caps the buffer at net.core.rmem_max (208 KiB by default)
     * and switches off the kernel's autotuning, so a 900 KB frame would need several
     * round trips through the publisher's poll loop */
    int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    p->fd = fd;
    p->lenhave = p->have = 0;
    p->need = 0;
    p->last_err[0] = 0;
    pthread_mutex_lock(&s->mu);
    s->st.connected++;
    pthread_mutex_unlock(&s->mu);
    slog(s, TR_LOG_INFO, "subscribed to %s from %s (%s, TCPROS %s:%d)", s->topic, p->peer, p->uri, host, port);
}

/* a complete frame sits in p->w: decode and publish it as the newest */
static void frame_done(tr_sub *s, pub *p, uint32_t len)
{
    char err[256];
    tr_image img;
    if (tr_image_decode(p->w.p, len, &img, err, sizeof err)) {
        pthread_mutex_lock(&s->mu);
        s->st.bad_frames++;
        pthread_mutex_unlock(&s->mu);
        slog(s, TR_LOG_ERROR, "publisher %s: dropped a bad frame: %s", p->uri, err);
        return;
    }
    pthread_mutex_lock(&s->mu);
    fbuf t = s->ready;
    s->ready = p->w;
    p->w = t;
    s->ready_img = img;          /* img.data points into the buffer now held by ready */
    if (s->fresh) s->st.dropped++;
    s->fresh = 1;
    s->st.frames++;
    s->st.bytes += len;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

/* drains what the socket has; never blocks */
static void pub_read(tr_sub *s, pub *p)
{
    for (int rounds = 0; rounds < 256 && p->fd >= 0; rounds++) {
        ssize_t r;
        if (p->lenhave < 4) {
            r = recv(p->fd, p->lenb + p->lenhave, 4 - p->lenhave, 0);
            if (r > 0) {
                p->lenhave += (size_t)r;
                if (p->lenhave == 4) {
                    p->need = tr_get_le32(p->lenb);
                    p->have = 0;
                    if (p->need > s->max_msg) {
                        pub_fail(s, p, "message length %u exceeds the limit of %u bytes; connection dropped",
                                 p->need, s->max_msg);
                        return;
                    }
                    if (p->need > p->w.cap) {
                        free(p->w.p);
                        p->w.cap = 0;
                        p->w.p = (uint8_t *)malloc(p->need);
                        if (!p->w.p) { pub_fail(s, p, "out of memory for a %u byte message", p->need); return; }
                        p->w.cap = p->need;
                    }
                    if (p->need == 0) { p->lenhave = 0; frame_done(s, p, 0); }
                }
                continue;
            }
        } else {
            r = recv(p->fd, p->w.p + p->have, p->need - p->have, 0);
            if (r > 0) {
                p->have += (size_t)r;
                if (p->have == p->need) {
                    p->lenhave = 0;
                    frame_done(s, p, p->need);
                }
                continue;
            }
        }
        if (r == 0) {
            if (p->lenhave > 0)
                pub_fail(s, p, "connection closed mid-frame (%zu of %u bytes received)",
                         p->lenhave < 4 ? 0 : p->have, p->lenhave < 4 ? 0 : p->need);
            else {
                slog(s, TR_LOG_INFO, "publisher %s (%s) closed the connection", p->uri, p->peer);
                pub_close(s, p);
                p->next_try = now_ms() + s->retry_ms;
            }
            return;
        }
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) return;
        pub_fail(s, p, "receive failed: %s", strerror(errno));
        return;
    }
}

static void pub_remove(tr_sub *s, int i)
{
    pub *p = &s->pubs[i];
    pub_close(s, p);
    free(p->w.p);
    s->pubs[i] = s->pubs[s->npubs - 1];
    s->npubs--;
}

/* the master's list of publisher URIs (registerSubscriber or publisherUpdate) */
static void set_publishers(tr_sub *s, const xr_value *list)
{
    for (int i = 0; i < s->npubs; i++) s->pubs[i].listed = 0;
    for (size_t k = 0; list && k < list->n; k++) {
        const xr_value *u = xr_at(list, k, XR_STRING);
        if (!u || !u->s[0]) { slog(s, TR_LOG_WARN, "ignoring a publisher entry that is not a URI string"); continue; }
        int found = 0;
        for (int i = 0; i < s->npubs; i++)
            if (!strcmp(s->pubs[i].uri, u->s)) { s->pubs[i].listed = 1; found = 1; }
        if (found) continue;
        if (s->npubs >= TR_MAX_PUBS) {
            slog(s, TR_LOG_WARN, "more than %d publishers; ignoring %.200s", TR_MAX_PUBS, u->s);
            continue;
        }
        if (u->slen >= sizeof s->pubs[0].uri) { slog(s, TR_LOG_WARN, "publisher URI too long; ignored"); continue; }
        pub *p = &s->pubs[s->npubs++];
        memset(p, 0, sizeof *p);
        copy_str(p->uri, sizeof p->uri, u->s);
        p->fd = -1;
        p->listed = 1;
        p->next_try = 0;
    }
    for (int i = s->npubs - 1; i >= 0; i--)
        if (!s->pubs[i].listed) {
            slog(s, TR_LOG_INFO, "publisher %s is gone", s->pubs[i].uri);
            pub_remove(s, i);
        }
    pthread_mutex_lock(&s->mu);
    s->st.publishers = s->npubs;
    pthread_mutex_unlock(&s->mu);
}

/* ---- XML-RPC slave server ------------------------------------------------------------------------ */
static void respond(int fd, const tr_buf *body, int64_t deadline)
{
    tr_buf r;
    char err[64];
    tr_buf_init(&r);
    tr_buf_printf(&r, "HTTP/1.0 200 OK\r\nServer: tinyros\r\nContent-Type: text/xml\r\n"
                  "Content-Length: %zu\r\nConnection: close\r\n\r\n", body->len);
    tr_buf_append(&r, body->p, body->len);
    if (!r.oom) send_all(fd, r.p, r.len, deadline, err, sizeof err);
    tr_buf_free(&r);
}

static void result_begin(tr_buf *b, int code, const char *msg)
{
    xw_response_begin(b);
    xw_param_begin(b);
    xw_array_begin(b);
    xw_int(b, code);
    xw_string(b, msg);
}
static void result_end(tr_buf *b)
{
    xw_array_end(b);
    xw_param_end(b);
    xw_response_end(b);
}

/* serves one XML-RPC request on a fresh connection; returns a publisher list to
 * apply after the answer went out (or NULL) */
static int serve_slave(tr_sub *s, int fd, xr_value *update)
{
    int64_t deadline = now_ms() + s->timeout_ms;
    tr_buf in, out;
    tr_buf_init(&in);
    tr_buf_init(&out);
    char chunk[8192], err[256], method[128];
    const char *body = NULL;
    size_t blen = 0;
    int status, pr = 0, has_update = 0;
    set_nonblock(fd);
    while (pr == 0) {
        ssize_t r = recv(fd, chunk, sizeof chunk, 0);
        int eof = 0;
        if (r > 0) tr_buf_append(&in, chunk, (size_t)r);
        else if (r == 0) eof = 1;
        else if (errno == EINTR) continue;
        else if (errno == EAGAIN || errno == EWOULDBLOCK) {
            if (wait_fd(fd, POLLIN, deadline) <= 0) { pr = tr_seterr(err, sizeof err, "request timed out"); break; }
            continue;
        } else { pr = tr_seterr(err, sizeof err, "receive failed: %s", strerror(errno)); break; }
        if (in.oom) { pr = tr_seterr(err, sizeof err, "out of memory"); break; }
        pr = tr_http_parse(in.p ? in.p : "", in.len, 0, eof, &status, &body, &blen, err, sizeof err);
        if (pr == 0 && eof) pr = tr_seterr(err, sizeof err, "connection closed inside the request");
    }
    if (pr < 0) {
        slog(s, TR_LOG_WARN, "XML-RPC server: bad request: %s", err);
        tr_buf_free(&in);
        return 0;
    }
    xr_value params;
    if (xr_parse_call(body, blen, method, sizeof method, &params, err, sizeof err)) {
        slog(s, TR_LOG_WARN, "XML-RPC server: %s", err);
        result_begin(&out, -1, err);
        xw_int(&out, 0);
        result_end(&out);
        respond(fd, &out, deadline);
        tr_buf_free(&in);
        tr_buf_free(&out);
        return 0;
    }
    if (!strcmp(method, "publisherUpdate")) {
        const xr_value *topic = xr_at(&params, 1, XR_STRING);
        const xr_value *list = xr_at(&params, 2, XR_ARRAY);
        if (!topic || !list) {
            slog(s, TR_LOG_WARN, "publisherUpdate with bad parameters ignored");
            result_begin(&out, -1, "publisherUpdate(caller_id, topic, publishers[]) expected");
        } else if (strcmp(topic->s, s->topic) != 0) {
            result_begin(&out, 0, "not subscribed to that topic");
        } else {
            result_begin(&out, 1, "publisher update received");
            *update = *list;                  /* take ownership of the list */
            memset(&params.items[2], 0, sizeof params.items[2]);
            has_update = 1;
        }
        xw_int(&out, 0);
    } else if (!strcmp(method, "getPid")) {
        result_begin(&out, 1, "");
        xw_int(&out, getpid());
    } else if (!strcmp(method, "getMasterUri")) {
        result_begin(&out, 1, "");
        xw_string(&out, s->master_uri);
    } else if (!strcmp(method, "getSubscriptions")) {
        result_begin(&out, 1, "");
        xw_array_begin(&out); xw_array_begin(&out);
        xw_string(&out, s->topic); xw_string(&out, TR_IMAGE_TYPE);
        xw_array_end(&out); xw_array_end(&out);
    } else if (!strcmp(method, "getPublications")) {
        result_begin(&out, 1, "");
        xw_array_begin(&out); xw_array_end(&out);
    } else if (!strcmp(method, "getBusInfo")) {
        result_begin(&out, 1, "");
        xw_array_begin(&out);
        for (int i = 0; i < s->npubs; i++) {
            if (s->pubs[i].fd < 0) continue;
            xw_array_begin(&out);
            xw_int(&out, i + 1); xw_string(&out, s->pubs[i].uri); xw_string(&out, "i");
            xw_string(&out, "TCPROS"); xw_string(&out, s->topic); xw_bool(&out, 1);
            xw_array_end(&out);
        }
        xw_array_end(&out);
    } else if (!strcmp(method, "getBusStats")) {
        result_begin(&out, 1, "");
        xw_array_begin(&out);
        xw_array_begin(&out); xw_array_end(&out);
        xw_array_begin(&out); xw_array_end(&out);
        xw_array_begin(&out); xw_array_end(&out);
        xw_array_end(&out);
    } else if (!strcmp(method, "paramUpdate")) {
        result_begin(&out, 1, "");
        xw_int(&out, 0);
    } else if (!strcmp(method, "shutdown")) {
        const xr_value *why = xr_at(&params, 1, XR_STRING);
        slog(s, TR_LOG_ERROR, "the master shut this node down: %.200s", why ? why->s : "(no reason)");
        result_begin(&out, 1, "shutdown");
        xw_int(&out, 0);
        pthread_mutex_lock(&s->mu);
        s->shutdown = 1;
        pthread_cond_broadcast(&s->cv);
        pthread_mutex_unlock(&s->mu);
    } else {
        slog(s, TR_LOG_WARN, "XML-RPC server: unknown method %.100s", method);
        result_begin(&out, -1, "unknown method");
        xw_int(&out, 0);
    }
    result_end(&out);
    respond(fd, &out, deadline);
    xr_free(&params);
    tr_buf_free(&in);
    tr_buf_free(&out);
    return has_update;
}

/* ---- I/O thread -------------------------------------------------------------------------------------- */
static int stopping(tr_sub *s)
{
    pthread_mutex_lock(&s->mu);
    int r = s->stop || s->shutdown;
    pthread_mutex_unlock(&s->mu);
    return r;
}

static void *io_main(void *arg)
{
    tr_sub *s = (tr_sub *)arg;
    struct pollfd pf[2 + TR_MAX_PUBS];
    int map[2 + TR_MAX_PUBS];
    while (!stopping(s)) {
        int64_t now = now_ms();
        /* (re)connect listed publishers that are due */
        for (int i = 0; i < s->npubs && !stopping(s); i++) {
            pub *p = &s->pubs[i];
            if (p->fd < 0 && p->listed && now >= p->next_try) { pub_connect(s, p); now = now_ms(); }
        }
        int n = 0, timeout = 200;
        pf[n].fd = s->wake[0]; pf[n].events = POLLIN; map[n++] = -1;
        pf[n].fd = s->listen_fd; pf[n].events = POLLIN; map[n++] = -2;
        for (int i = 0; i < s->npubs; i++) {
            pub *p = &s->pubs[i];
            if (p->fd >= 0) { pf[n].fd = p->fd; pf[n].events = POLLIN; map[n++] = i; }
            else if (p->listed) {
                int64_t d = p->next_try - now;
                if (d < timeout) timeout = d < 0 ? 0 : (int)d;
            }
        }
        int r = poll(pf, (nfds_t)n, timeout);
        if (r < 0) {
            if (errno == EINTR) continue;
            slog(s, TR_LOG_ERROR, "poll failed: %s", strerror(errno));
            break;
        }
        for (int k = 0; k < n; k++) {
            if (!pf[k].revents) continue;
            if (map[k] == -1) {
                char junk[64];
                while (read(s->wake[0], junk, sizeof junk) > 0) {}
            } else if (map[k] == -2) {
                int c = accept(s->listen_fd, NULL, NULL);
                if (c >= 0) {
                    xr_value upd;
                    memset(&upd, 0, sizeof upd);
                    int has = serve_slave(s, c, &upd);
                    close(c);
                    if (has) { set_publishers(s, &upd); xr_free(&upd); }
                    break;   /* the publisher table may have changed: rebuild the poll set */
                }
            } else {
                /* indices stay valid: pubs only change in set_publishers (above, with break) */
                pub_read(s, &s->pubs[map[k]]);
            }
        }
    }
    for (int i = 0; i < s->npubs; i++) pub_close(s, &s->pubs[i]);
    return NULL;
}

/* ---- public API ---------------------------------------------------------------------------------------- */
void tr_options_init(tr_options *o)
{
    memset(o, 0, sizeof *o);
    o->log_level = TR_LOG_INFO;
}

static int listen_socket(const char *host, int *port, char *err, size_t errlen)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return tr_seterr(err, errlen, "socket: %s", strerror(errno));
    int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = 0;
    /* a loopback name is served on loopback only; any other name on all interfaces */
    int loop = !strcmp(host, "localhost") || !strncmp(host, "127.", 4);
    a.sin_addr.s_addr = htonl(loop ? INADDR_LOOPBACK : INADDR_ANY);
    if (bind(fd, (struct sockaddr *)&a, sizeof a) < 0 || listen(fd, 16) < 0) {
        tr_seterr(err, errlen, "cannot open the XML-RPC server socket: %s", strerror(errno));
        close(fd);
        return -1;
    }
    socklen_t sl = sizeof a;
    getsockname(fd, (struct sockaddr *)&a, &sl);
    *port = ntohs(a.sin_port);
    set_nonblock(fd);
    return fd;
}

tr_sub *tr_open(const tr_options *o, char *err, size_t errlen)
{
    tr_options d;
    if (!o) { tr_options_init(&d); o = &d; }
    tr_sub *s = (tr_sub *)calloc(1, sizeof *s);
    if (!s) { tr_seterr(err, errlen, "out of memory"); return NULL; }
    const char *m = o->master_uri ? o->master_uri : getenv("ROS_MASTER_URI");
    copy_str(s->master_uri, sizeof s->master_uri, m && *m ? m : "http://localhost:11311/");
    copy_str(s->topic, sizeof s->topic, o->topic ? o->topic : TR_DEFAULT_TOPIC);
    copy_str(s->caller_id, sizeof s->caller_id, o->caller_id ? o->caller_id : TR_DEFAULT_CALLER_ID);
    const char *h = o->host;
    if (!h || !*h) h = getenv("ROS_HOSTNAME");
    if (!h || !*h) h = getenv("ROS_IP");
    copy_str(s->host, sizeof s->host, h && *h ? h : "localhost");
    s->max_msg = o->max_message_bytes ? o->max_message_bytes : TR_DEFAULT_MAX_MESSAGE;
    s->timeout_ms = o->timeout_ms > 0 ? o->timeout_ms : 2000;
    s->retry_ms = o->retry_ms > 0 ? o->retry_ms : 1000;
    s->log = o->log ? o->log : default_log;
    s->log_ctx = o->log_ctx;
    s->log_level = o->log_level;
    s->listen_fd = s->wake[0] = s->wake[1] = -1;
    pthread_mutex_init(&s->mu, NULL);
    /* tr_wait's timeout runs on the monotonic clock: wall-clock jumps do not stretch it */
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&s->cv, &ca);
    pthread_condattr_destroy(&ca);

    char e[300], host[256];
    int port;
    if (s->topic[0] != '/') { tr_seterr(err, errlen, "topic \"%s\" must be a global name starting with /", s->topic); goto fail; }
    if (tr_uri_parse(s->master_uri, host, sizeof host, &port, e, sizeof e)) {
        tr_seterr(err, errlen, "bad ROS master URI: %s", e);
        goto fail;
    }
    s->listen_fd = listen_socket(s->host, &port, e, sizeof e);
    if (s->listen_fd < 0) { tr_seterr(err, errlen, "%s", e); goto fail; }
    snprintf(s->node_uri, sizeof s->node_uri, "http://%s:%d/", s->host, port);
    if (pipe(s->wake) < 0) { tr_seterr(err, errlen, "pipe: %s", strerror(errno)); goto fail; }
    set_nonblock(s->wake[0]);
    set_nonblock(s->wake[1]);

    tr_buf b;
    tr_buf_init(&b);
    xw_call_begin(&b, "registerSubscriber");
    xw_param_begin(&b); xw_string(&b, s->caller_id); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, s->topic); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, TR_IMAGE_TYPE); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, s->node_uri); xw_param_end(&b);
    xw_call_end(&b);
    xr_value res;
    const xr_value *list = NULL;
    int rc = ros_call(s->master_uri, &b, s->timeout_ms, &res, &list, e, sizeof e);
    tr_buf_free(&b);
    if (rc) {
        tr_seterr(err, errlen, "cannot register %s at the ROS master %s: %s", s->topic, s->master_uri, e);
        goto fail;
    }
    if (list->type != XR_ARRAY) {
        xr_free(&res);
        tr_seterr(err, errlen, "the ROS master %s answered registerSubscriber without a publisher list", s->master_uri);
        goto fail;
    }
    set_publishers(s, list);
    xr_free(&res);
    slog(s, TR_LOG_INFO, "%s subscribed to %s at %s (%d publisher%s)", s->caller_id, s->topic, s->master_uri,
         s->npubs, s->npubs == 1 ? "" : "s");
    if (pthread_create(&s->th, NULL, io_main, s) != 0) {
        tr_seterr(err, errlen, "cannot start the I/O thread");
        goto fail;
    }
    s->th_started = 1;
    return s;
fail:
    if (s->listen_fd >= 0) close(s->listen_fd);
    if (s->wake[0] >= 0) { close(s->wake[0]); close(s->wake[1]); }
    for (int i = 0; i < s->npubs; i++) free(s->pubs[i].w.p);
    pthread_mutex_destroy(&s->mu);
    pthread_cond_destroy(&s->cv);
    free(s);
    return NULL;
}

int tr_wait(tr_sub *s, tr_image *img, int timeout_ms)
{
    struct timespec until;
    clock_gettime(CLOCK_MONOTONIC, &until);
    if (timeout_ms >= 0) {
        until.tv_sec += timeout_ms / 1000;
        until.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
        if (until.tv_nsec >= 1000000000L) { until.tv_sec++; until.tv_nsec -= 1000000000L; }
    }
    pthread_mutex_lock(&s->mu);
    while (!s->fresh && !s->stop && !s->shutdown) {
        if (timeout_ms < 0) pthread_cond_wait(&s->cv, &s->mu);
        else if (pthread_cond_timedwait(&s->cv, &s->mu, &until) == ETIMEDOUT) break;
    }
    int rc;
    if (s->fresh) {
        fbuf t = s->reading;
        s->reading = s->ready;
        s->ready = t;
        *img = s->ready_img;
        s->fresh = 0;
        rc = 1;
    } else {
        rc = (s->stop || s->shutdown) ? -1 : 0;
    }
    pthread_mutex_unlock(&s->mu);
    return rc;
}

void tr_get_stats(tr_sub *s, tr_stats *st)
{
    pthread_mutex_lock(&s->mu);
    *st = s->st;
    pthread_mutex_unlock(&s->mu);
}

void tr_last_error(tr_sub *s, char *buf, size_t len)
{
    pthread_mutex_lock(&s->mu);
    copy_str(buf, len, s->last_err);
    pthread_mutex_unlock(&s->mu);
}

const char *tr_node_uri(const tr_sub *s) { return s->node_uri; }

void tr_close(tr_sub *s)
{
    if (!s) return;
    pthread_mutex_lock(&s->mu);
    s->stop = 1;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
    if (s->wake[1] >= 0) { ssize_t w = write(s->wake[1], "x", 1); (void)w; }
    if (s->th_started) pthread_join(s->th, NULL);

    tr_buf b;
    tr_buf_init(&b);
    xw_call_begin(&b, "unregisterSubscriber");
    xw_param_begin(&b); xw_string(&b, s->caller_id); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, s->topic); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, s->node_uri); xw_param_end(&b);
    xw_call_end(&b);
    xr_value res;
    const xr_value *v;
    char e[300];
    if (ros_call(s->master_uri, &b, s->timeout_ms < 1000 ? s->timeout_ms : 1000, &res, &v, e, sizeof e) == 0)
        xr_free(&res);
    else
        slog(s, TR_LOG_WARN, "unregisterSubscriber at %s: %s", s->master_uri, e);
    tr_buf_free(&b);

    for (int i = 0; i < s->npubs; i++) { if (s->pubs[i].fd >= 0) close(s->pubs[i].fd); free(s->pubs[i].w.p); }
    free(s->ready.p);
    free(s->reading.p);
    close(s->listen_fd);
    close(s->wake[0]);
    close(s->wake[1]);
    pthread_mutex_destroy(&s->mu);
    pthread_cond_destroy(&s->cv);
    free(s);
}
