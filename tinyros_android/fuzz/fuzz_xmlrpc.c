/* libFuzzer target: XML-RPC response and call parsers and the HTTP framing. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "tr_internal.h"

static size_t walk(const xr_value *v)
{
    size_t n = 1;
    if ((v->type == XR_STRING || v->type == XR_BASE64) && strlen(v->s) > v->slen) __builtin_trap();
    for (size_t i = 0; i < v->n; i++) n += walk(&v->items[i]);
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *s = (const char *)data;
    char err[256], method[128];
    xr_value v;
    int fault;
    if (xr_parse_response(s, size, &v, &fault, err, sizeof err) == 0) {
        walk(&v);
        xr_at(&v, 2, XR_ARRAY);
        xr_free(&v);
    }
    if (xr_parse_call(s, size, method, sizeof method, &v, err, sizeof err) == 0) {
        walk(&v);
        xr_free(&v);
    }
    const char *body;
    size_t blen;
    int status;
    for (int resp = 0; resp < 2; resp++)
        for (int eof = 0; eof < 2; eof++)
            if (tr_http_parse(s, size, resp, eof, &status, &body, &blen, err, sizeof err) == 1)
                if (body < s || body + blen > s + size) __builtin_trap();
    /* URIs come from the network too (publisher lists) */
    char *z = (char *)malloc(size + 1);
    if (z) {
        memcpy(z, data, size);
        z[size] = 0;
        char host[256];
        int port;
        tr_uri_parse(z, host, sizeof host, &port, err, sizeof err);
        free(z);
    }
    return 0;
}
