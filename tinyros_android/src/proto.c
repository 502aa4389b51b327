/* tinyros wire formats without I/O: HTTP framing, URIs, TCPROS headers and
 * sensor_msgs/Image. Every length is checked against the bytes at hand. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tr_internal.h"

void tr_put_le32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); p[2] = (uint8_t)(v >> 16); p[3] = (uint8_t)(v >> 24);
}

uint32_t tr_get_le32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* ---- HTTP ------------------------------------------------------------------- */
static int ci_prefix(const char *s, size_t n, const char *lit)
{
    size_t k = strlen(lit);
    if (n < k) return 0;
    for (size_t i = 0; i < k; i++)
        if (tolower((unsigned char)s[i]) != tolower((unsigned char)lit[i])) return 0;
    return 1;
}

int tr_http_parse(const char *data, size_t len, int is_response, int eof, int *status,
                  const char **body, size_t *body_len, char *err, size_t errlen)
{
    size_t hend = (size_t)-1, bstart = 0;
    for (size_t i = 0; i + 1 < len; i++) {
        if (data[i] == '\n' && data[i + 1] == '\n') { hend = i; bstart = i + 2; break; }
        if (i + 3 < len && !memcmp(data + i, "\r\n\r\n", 4)) { hend = i; bstart = i + 4; break; }
    }
    if (hend == (size_t)-1) {
        if (len > 65536) return tr_seterr(err, errlen, "HTTP header larger than 64 KiB");
        if (eof) return tr_seterr(err, errlen, "connection closed inside the HTTP header (%zu bytes)", len);
        return 0;
    }
    /* first line */
    size_t l1 = 0;
    while (l1 < hend && data[l1] != '\r' && data[l1] != '\n') l1++;
    *status = 0;
    if (is_response) {
        if (!ci_prefix(data, l1, "HTTP/1.") || l1 < 12 || data[8] != ' ')
            return tr_seterr(err, errlen, "not an HTTP response: \"%.*s\"", (int)(l1 < 40 ? l1 : 40), data);
        int st = 0;
        for (int k = 9; k < 12; k++) {
            if (!isdigit((unsigned char)data[k])) return tr_seterr(err, errlen, "bad HTTP status line");
            st = st * 10 + (data[k] - '0');
        }
        *status = st;
    } else {
        if (!ci_prefix(data, l1, "POST "))
            return tr_seterr(err, errlen, "not an HTTP POST request: \"%.*s\"", (int)(l1 < 40 ? l1 : 40), data);
    }
    /* headers */
    long long clen = -1;
    size_t i = l1;
    while (i < hend) {
        while (i < hend && (data[i] == '\r' || data[i] == '\n')) i++;
        size_t e = i;
        while (e < hend && data[e] != '\r' && data[e] != '\n') e++;
        if (ci_prefix(data + i, e - i, "content-length:")) {
            size_t k = i + 15;
            while (k < e && (data[k] == ' ' || data[k] == '\t')) k++;
            if (k == e) return tr_seterr(err, errlen, "empty Content-Length");
            long long v = 0;
            for (; k < e && data[k] != ' ' && data[k] != '\t'; k++) {
                if (!isdigit((unsigned char)data[k])) return tr_seterr(err, errlen, "bad Content-Length");
                v = v * 10 + (data[k] - '0');
                if (v > (long long)TR_HTTP_MAX)
                    return tr_seterr(err, errlen, "HTTP body larger than %u bytes", TR_HTTP_MAX);
            }
            clen = v;
        } else if (ci_prefix(data + i, e - i, "transfer-encoding:")) {
            return tr_seterr(err, errlen, "HTTP Transfer-Encoding is not supported");
        }
        i = e;
    }
    size_t have = len - bstart;
    if (clen < 0) {
        if (!is_response) return tr_seterr(err, errlen, "HTTP request without Content-Length");
        if (have > TR_HTTP_MAX) return tr_seterr(err, errlen, "HTTP body larger than %u bytes", TR_HTTP_MAX);
        if (!eof) return 0;
        *body = data + bstart;
        *body_len = have;
        return 1;
    }
    if (have < (size_t)clen) {
        if (eof) return tr_seterr(err, errlen, "HTTP body truncated: %zu of %lld bytes", have, clen);
        return 0;
    }
    *body = data + bstart;
    *body_len = (size_t)clen;
    return 1;
}

/* ---- URIs ------------------------------------------------------------------------ */
int tr_uri_parse(const char *uri, char *host, size_t host_cap, int *port, char *err, size_t errlen)
{
    size_t n = strlen(uri);
    if (!ci_prefix(uri, n, "http://"))
        return tr_seterr(err, errlen, "URI \"%.200s\" does not start with http://", uri);
    const char *h = uri + 7, *e;
    if (*h == '[') {
        e = strchr(h, ']');
        if (!e) return tr_seterr(err, errlen, "URI \"%.200s\": unterminated [", uri);
        h++;
    } else {
        e = h;
        while (*e && *e != ':' && *e != '/') e++;
    }
    size_t hl = (size_t)(e - h);
    if (hl == 0) return tr_seterr(err, errlen, "URI \"%.200s\" has no host", uri);
    if (hl >= host_cap) return tr_seterr(err, errlen, "URI \"%.200s\": host name too long", uri);
    memcpy(host, h, hl);
    host[hl] = 0;
    if (*e == ']') e++;
    *port = 80;
    if (*e == ':') {
        long v = 0;
        const char *d = e + 1;
        if (!isdigit((unsigned char)*d)) return tr_seterr(err, errlen, "URI \"%.200s\": bad port", uri);
        while (isdigit((unsigned char)*d)) {
            v = v * 10 + (*d - '0');
            if (v > 65535) return tr_seterr(err, errlen, "URI \"%.200s\": port out of range", uri);
            d++;
        }
        if (*d && *d != '/') return tr_seterr(err, errlen, "URI \"%.200s\": bad port", uri);
        if (v == 0) return tr_seterr(err, errlen, "URI \"%.200s\": port 0", uri);
        *port = (int)v;
    } else if (*e && *e != '/') {
        return tr_seterr(err, errlen, "URI \"%.200s\": bad host", uri);
    }
    return 0;
}

/* ---- TCPROS connection header ---------------------------------------------------------- */
int tr_header_parse(const uint8_t *data, size_t len, tr_header *h, char *err, size_t errlen)
{
    size_t off = 0;
    h->n = 0;
    while (off < len) {
        if (len - off < 4)
            return tr_seterr(err, errlen, "TCPROS header: %zu stray bytes at the end", len - off);
        uint32_t fl = tr_get_le32(data + off);
        off += 4;
        if (fl > len - off)
            return tr_seterr(err, errlen, "TCPROS header: field length %u exceeds the %zu bytes left",
                             fl, len - off);
        const char *f = (const char *)data + off;
        const char *eq = (const char *)memchr(f, '=', fl);
        if (!eq)
            return tr_seterr(err, errlen, "TCPROS header: field without '=' (\"%.*s\")", (int)(fl < 40 ? fl : 40), f);
        if (eq == f) return tr_seterr(err, errlen, "TCPROS header: field with empty name");
        if (h->n >= TR_HEADER_MAX_FIELDS)
            return tr_seterr(err, errlen, "TCPROS header: more than %d fields", TR_HEADER_MAX_FIELDS);
        tr_field *x = &h->f[h->n++];
        x->key = f;
        x->klen = (size_t)(eq - f);
        x->val = eq + 1;
        x->vlen = fl - x->klen - 1;
        off += fl;
    }
    return 0;
}

int tr_header_get(const tr_header *h, const char *key, char *out, size_t cap)
{
    size_t kl = strlen(key);
    for (size_t i = 0; i < h->n; i++) {
        if (h->f[i].klen == kl && !memcmp(h->f[i].key, key, kl)) {
            if (out && cap) {
                size_t n = h->f[i].vlen < cap - 1 ? h->f[i].vlen : cap - 1;
                memcpy(out, h->f[i].val, n);
                out[n] = 0;
            }
            return 1;
        }
    }
    return 0;
}

void tr_header_build(tr_buf *b, const char *const *kv)
{
    size_t start = b->len;
    uint8_t le[4] = { 0, 0, 0, 0 };
    tr_buf_append(b, le, 4);
    for (size_t i = 0; kv[i] && kv[i + 1]; i += 2) {
        size_t kl = strlen(kv[i]), vl = strlen(kv[i + 1]);
        tr_put_le32(le, (uint32_t)(kl + 1 + vl));
        tr_buf_append(b, le, 4);
        tr_buf_append(b, kv[i], kl);
        tr_buf_append(b, "=", 1);
        tr_buf_append(b, kv[i + 1], vl);
    }
    if (!b->oom) tr_put_le32((uint8_t *)b->p + start, (uint32_t)(b->len - start - 4));
}

/* ---- sensor_msgs/Image ---------------------------------------------------------------------- */
typedef struct rd { const uint8_t *p; size_t len, off; } rd;

static int rd_u32(rd *r, uint32_t *v)
{
    if (r->len - r->off < 4) return -1;
    *v = tr_get_le32(r->p + r->off);
    r->off += 4;
    return 0;
}

static int rd_str(rd *r, char *out, size_t cap, const char *what, char *err, size_t errlen)
{
    uint32_t n;
    if (rd_u32(r, &n)) return tr_seterr(err, errlen, "Image: message ends before the length of %s", what);
    if (n > r->len - r->off)
        return tr_seterr(err, errlen, "Image: %s length %u exceeds the %zu bytes left", what, n, r->len - r->off);
    if (n >= cap) return tr_seterr(err, errlen, "Image: %s is %u bytes, limit %zu", what, n, cap - 1);
    if (memchr(r->p + r->off, 0, n)) return tr_seterr(err, errlen, "Image: %s contains a NUL byte", what);
    memcpy(out, r->p + r->off, n);
    out[n] = 0;
    r->off += n;
    return 0;
}

int tr_image_decode(const uint8_t *msg, size_t len, tr_image *img, char *err, size_t errlen)
{
    rd r = { msg, len, 0 };
    memset(img, 0, sizeof *img);
    if (rd_u32(&r, &img->seq) || rd_u32(&r, &img->stamp_sec) || rd_u32(&r, &img->stamp_nsec))
        return tr_seterr(err, errlen, "Image: message of %zu bytes ends inside the header", len);
    if (rd_str(&r, img->frame_id, sizeof img->frame_id, "frame_id", err, errlen)) return -1;
    if (rd_u32(&r, &img->height) || rd_u32(&r, &img->width))
        return tr_seterr(err, errlen, "Image: message ends before height/width");
    if (rd_str(&r, img->encoding, sizeof img->encoding, "encoding", err, errlen)) return -1;
    if (r.len - r.off < 1) return tr_seterr(err, errlen, "Image: message ends before is_bigendian");
    img->is_bigendian = r.p[r.off++];
    uint32_t n;
    if (rd_u32(&r, &img->step) || rd_u32(&r, &n))
        return tr_seterr(err, errlen, "Image: message ends before step/data length");
    if (n > r.len - r.off)
        return tr_seterr(err, errlen, "Image: data length %u exceeds the %zu bytes left", n, r.len - r.off);
    if (n < r.len - r.off)
        return tr_seterr(err, errlen, "Image: %zu stray bytes after the data", r.len - r.off - n);
    if ((uint64_t)img->step * img->height != n)
        return tr_seterr(err, errlen, "Image: data is %u bytes but step*height = %u*%u = %llu",
                         n, img->step, img->height, (unsigned long long)img->step * img->height);
    img->data = r.p + r.off;
    img->data_len = n;
    return 0;
}

/* ---- CRC-32 ------------------------------------------------------------------------------------ */
static const uint32_t crc_table[256] = {
    0x00000000u, 0x77073096u, 0xee0e612cu, 0x990951bau, 0x076dc419u, 0x706af48fu,
    0xe963a535u, 0x9e6495a3u, 0x0edb8832u, 0x79dcb8a4u, 0xe0d5e91eu, 0x97d2d988u,
    0x09b64c2bu, 0x7eb17cbdu, 0xe7b82d07u, 0x90bf1d91u, 0x1db71064u, 0x6ab020f2u,
    0xf3b97148u, 0x84be41deu, 0x1adad47du, 0x6ddde4ebu, 0xf4d4b551u, 0x83d385c7u,
    0x136c9856u, 0x646ba8c0u, 0xfd62f97au, 0x8a65c9ecu, 0x14015c4fu, 0x63066cd9u,
    0xfa0f3d63u, 0x8d080df5u, 0x3b6e20c8u, 0x4c69105eu, 0xd56041e4u, 0xa2677172u,
    0x3c03e4d1u, 0x4b04d447u, 0xd20d85fdu, 0xa50ab56bu, 0x35b5a8fau, 0x42b2986cu,
    0xdbbbc9d6u, 0xacbcf940u, 0x32d86ce3u, 0x45df5c75u, 0xdcd60dcfu, 0xabd13d59u,
    0x26d930acu, 0x51de003au, 0xc8d75180u, 0xbfd06116u, 0x21b4f4b5u, 0x56b3c423u,
    0xcfba9599u, 0xb8bda50fu, 0x2802b89eu, 0x5f058808u, 0xc60cd9b2u, 0xb10be924u,
    0x2f6f7c87u, 0x58684c11u, 0xc1611dabu, 0xb6662d3du, 0x76dc4190u, 0x01db7106u,
    0x98d220bcu, 0xefd5102au, 0x71b18589u, 0x06b6b51fu, 0x9fbfe4a5u, 0xe8b8d433u,
    0x7807c9a2u, 0x0f00f934u, 0x9609a88eu, 0xe10e9818u, 0x7f6a0dbbu, 0x086d3d2du,
    0x91646c97u, 0xe6635c01u, 0x6b6b51f4u, 0x1c6c6162u, 0x856530d8u, 0xf262004eu,
    0x6c0695edu, 0x1b01a57bu, 0x8208f4c1u, 0xf50fc457u, 0x65b0d9c6u, 0x12b7e950u,
    0x8bbeb8eau, 0xfcb9887cu, 0x62dd1ddfu, 0x15da2d49u, 0x8cd37cf3u, 0xfbd44c65u,
    0x4db26158u, 0x3ab551ceu, 0xa3bc0074u, 0xd4bb30e2u, 0x4adfa541u, 0x3dd895d7u,
    0xa4d1c46du, 0xd3d6f4fbu, 0x4369e96au, 0x346ed9fcu, 0xad678846u, 0xda60b8d0u,
    0x44042d73u, 0x33031de5u, 0xaa0a4c5fu, 0xdd0d7cc9u, 0x5005713cu, 0x270241aau,
    0xbe0b1010u, 0xc90c2086u, 0x5768b525u, 0x206f85b3u, 0xb966d409u, 0xce61e49fu,
    0x5edef90eu, 0x29d9c998u, 0xb0d09822u, 0xc7d7a8b4u, 0x59b33d17u, 0x2eb40d81u,
    0xb7bd5c3bu, 0xc0ba6cadu, 0xedb88320u, 0x9abfb3b6u, 0x03b6e20cu, 0x74b1d29au,
    0xead54739u, 0x9dd277afu, 0x04db2615u, 0x73dc1683u, 0xe3630b12u, 0x94643b84u,
    0x0d6d6a3eu, 0x7a6a5aa8u, 0xe40ecf0bu, 0x9309ff9du, 0x0a00ae27u, 0x7d079eb1u,
    0xf00f9344u, 0x8708a3d2u, 0x1e01f268u, 0x6906c2feu, 0xf762575du, 0x806567cbu,
    0x196c3671u, 0x6e6b06e7u, 0xfed41b76u, 0x89d32be0u, 0x10da7a5au, 0x67dd4accu,
    0xf9b9df6fu, 0x8ebeeff9u, 0x17b7be43u, 0x60b08ed5u, 0xd6d6a3e8u, 0xa1d1937eu,
    0x38d8c2c4u, 0x4fdff252u, 0xd1bb67f1u, 0xa6bc5767u, 0x3fb506ddu, 0x48b2364bu,
    0xd80d2bdau, 0xaf0a1b4cu, 0x36034af6u, 0x41047a60u, 0xdf60efc3u, 0xa867df55u,
    0x316e8eefu, 0x4669be79u, 0xcb61b38cu, 0xbc66831au, 0x256fd2a0u, 0x5268e236u,
    0xcc0c7795u, 0xbb0b4703u, 0x220216b9u, 0x5505262fu, 0xc5ba3bbeu, 0xb2bd0b28u,
    0x2bb45a92u, 0x5cb36a04u, 0xc2d7ffa7u, 0xb5d0cf31u, 0x2cd99e8bu, 0x5bdeae1du,
    0x9b64c2b0u, 0xec63f226u, 0x756aa39cu, 0x026d930au, 0x9c0906a9u, 0xeb0e363fu,
    0x72076785u, 0x05005713u, 0x95bf4a82u, 0xe2b87a14u, 0x7bb12baeu, 0x0cb61b38u,
    0x92d28e9bu, 0xe5d5be0du, 0x7cdcefb7u, 0x0bdbdf21u, 0x86d3d2d4u, 0xf1d4e242u,
    0x68ddb3f8u, 0x1fda836eu, 0x81be16cdu, 0xf6b9265bu, 0x6fb077e1u, 0x18b74777u,
    0x88085ae6u, 0xff0f6a70u, 0x66063bcau, 0x11010b5cu, 0x8f659effu, 0xf862ae69u,
    0x616bffd3u, 0x166ccf45u, 0xa00ae278u, 0xd70dd2eeu, 0x4e048354u, 0x3903b3c2u,
    0xa7672661u, 0xd06016f7u, 0x4969474du, 0x3e6e77dbu, 0xaed16a4au, 0xd9d65adcu,
    0x40df0b66u, 0x37d83bf0u, 0xa9bcae53u, 0xdebb9ec5u, 0x47b2cf7fu, 0x30b5ffe9u,
    0xbdbdf21cu, 0xcabac28au, 0x53b39330u, 0x24b4a3a6u, 0xbad03605u, 0xcdd70693u,
    0x54de5729u, 0x23d967bfu, 0xb3667a2eu, 0xc4614ab8u, 0x5d681b02u, 0x2a6f2b94u,
    0xb40bbe37u, 0xc30c8ea1u, 0x5a05df1bu, 0x2d02ef8du,
};

uint32_t tr_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
    crc = ~crc;
    for (size_t i = 0; i < n; i++) crc = crc_table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
    return ~crc;
}
