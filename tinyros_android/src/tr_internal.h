/* Internal pieces of tinyros: growable buffer, XML-RPC values, HTTP framing,
 * URIs and TCPROS connection headers. Pure functions (no I/O) so the unit tests
 * and the fuzzers reach them directly. */
#ifndef TINYROS_INTERNAL_H
#define TINYROS_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include "tinyros/tinyros.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- growable byte buffer ---------------------------------------------- */
typedef struct tr_buf {
    char *p;
    size_t len, cap;
    int oom;            /* set once an allocation failed; further appends are ignored */
} tr_buf;
void tr_buf_init(tr_buf *b);
void tr_buf_free(tr_buf *b);
void tr_buf_append(tr_buf *b, const void *data, size_t n);
void tr_buf_puts(tr_buf *b, const char *s);
void tr_buf_printf(tr_buf *b, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* ---- XML-RPC ---------------------------------------------------------------- */
typedef enum {
    XR_NIL = 0, XR_INT, XR_BOOL, XR_DOUBLE, XR_STRING, XR_ARRAY, XR_STRUCT, XR_BASE64
} xr_type;

typedef struct xr_value {
    xr_type type;
    int64_t i;              /* XR_INT, XR_BOOL */
    double d;               /* XR_DOUBLE */
    char *s;                /* XR_STRING, XR_BASE64 (raw text): NUL-terminated, decoded */
    size_t slen;
    struct xr_value *items; /* XR_ARRAY, XR_STRUCT */
    size_t n;
    char *name;             /* member name when inside a struct */
} xr_value;

#define XR_MAX_DEPTH 32
#define XR_MAX_NODES 100000

void xr_free(xr_value *v);   /* frees the contents, not v itself */

/* Parse a <methodResponse>. On success returns 0, *is_fault says whether it was a
 * <fault>, and *out holds the single value (caller frees with xr_free). */
int xr_parse_response(const char *xml, size_t len, xr_value *out, int *is_fault,
                      char *err, size_t errlen);

/* Parse a <methodCall>. method gets the name; params the values as an XR_ARRAY. */
int xr_parse_call(const char *xml, size_t len, char *method, size_t method_cap,
                  xr_value *params, char *err, size_t errlen);

/* Writers: append XML-RPC text to a buffer. Strings are escaped. */
void xw_call_begin(tr_buf *b, const char *method);
void xw_call_end(tr_buf *b);
void xw_response_begin(tr_buf *b);
void xw_response_end(tr_buf *b);
void xw_param_begin(tr_buf *b);
void xw_param_end(tr_buf *b);
void xw_string(tr_buf *b, const char *s);
void xw_int(tr_buf *b, int64_t i);
void xw_bool(tr_buf *b, int v);
void xw_array_begin(tr_buf *b);
void xw_array_end(tr_buf *b);

/* Helpers for reading ROS-style [code, statusMessage, value] results. */
const xr_value *xr_at(const xr_value *arr, size_t i, xr_type want);

/* ---- HTTP (the XML-RPC transport) --------------------------------------------- */
#define TR_HTTP_MAX (1u << 20)   /* largest XML-RPC request/response accepted */

/* Examine buffered bytes of an HTTP message. Returns 1 when complete (*body, *body_len
 * set; *status set for responses, *status = 0 for requests), 0 when more bytes are
 * needed, -1 on a malformed or oversized message (err says why). If eof is set, a
 * response without Content-Length ends at the end of data. */
int tr_http_parse(const char *data, size_t len, int is_response, int eof, int *status,
                  const char **body, size_t *body_len, char *err, size_t errlen);

/* ---- URIs --------------------------------------------------------------------------- */
/* "http://host:port/path" -> host, port (path ignored). Returns 0 or -1. */
int tr_uri_parse(const char *uri, char *host, size_t host_cap, int *port, char *err, size_t errlen);

/* ---- TCPROS connection header --------------------------------------------------------- */
#define TR_HEADER_MAX_FIELDS 64
#define TR_HEADER_MAX_BYTES (1u << 20)

typedef struct tr_field {
    const char *key; size_t klen;
    const char *val; size_t vlen;
} tr_field;

typedef struct tr_header {
    tr_field f[TR_HEADER_MAX_FIELDS];
    size_t n;
} tr_header;

/* Parse the bytes after the 4-byte total length. Fields point into data. */
int tr_header_parse(const uint8_t *data, size_t len, tr_header *h, char *err, size_t errlen);
/* Value of key as a NUL-terminated copy into out (truncated to cap-1). Returns 1 if
 * found, 0 if not. */
int tr_header_get(const tr_header *h, const char *key, char *out, size_t cap);
/* Append a complete header (with its 4-byte length) built from key/value pairs;
 * kv is {"key","value",...,NULL}. */
void tr_header_build(tr_buf *b, const char *const *kv);

void tr_put_le32(uint8_t *p, uint32_t v);
uint32_t tr_get_le32(const uint8_t *p);

/* Replaces control characters (newlines included) by '?', in place. */
void tr_printable(char *s);

/* Writes a formatted message into err (NULL-safe). Returns -1 for convenience. */
int tr_seterr(char *err, size_t errlen, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#ifdef __cplusplus
}
#endif
#endif
