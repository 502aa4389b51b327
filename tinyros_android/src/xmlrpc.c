/* XML-RPC for tinyros: a small, bounded, allocation-checked parser for the subset
 * of XML that XML-RPC uses, and writers for calls and responses. */
#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tr_internal.h"

/* ---- buffer + errors ------------------------------------------------------- */
void tr_buf_init(tr_buf *b) { b->p = NULL; b->len = b->cap = 0; b->oom = 0; }
void tr_buf_free(tr_buf *b) { free(b->p); tr_buf_init(b); }

void tr_buf_append(tr_buf *b, const void *data, size_t n)
{
    if (b->oom) return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 256;
        while (cap < b->len + n + 1) cap *= 2;
        char *p = (char *)realloc(b->p, cap);
        if (!p) { b->oom = 1; return; }
        b->p = p; b->cap = cap;
    }
    if (n) memcpy(b->p + b->len, data, n);
    b->len += n;
    b->p[b->len] = 0;
}

void tr_buf_puts(tr_buf *b, const char *s) { tr_buf_append(b, s, strlen(s)); }

void tr_buf_printf(tr_buf *b, const char *fmt, ...)
{
    char tmp[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0) return;
    if ((size_t)n < sizeof tmp) { tr_buf_append(b, tmp, (size_t)n); return; }
    char *big = (char *)malloc((size_t)n + 1);
    if (!big) { b->oom = 1; return; }
    va_start(ap, fmt);
    vsnprintf(big, (size_t)n + 1, fmt, ap);
    va_end(ap);
    tr_buf_append(b, big, (size_t)n);
    free(big);
}

void tr_printable(char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20 || *s == 0x7f) *s = '?';
}

int tr_seterr(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
        tr_printable(err);   /* peer-supplied text never breaks the one-line message */
    }
    return -1;
}

/* ---- writers ------------------------------------------------------------------ */
static void xw_escaped(tr_buf *b, const char *s)
{
    const char *run = s;
    for (; *s; s++) {
        const char *rep = NULL;
        if (*s == '&') rep = "&amp;";
        else if (*s == '<') rep = "&lt;";
        else if (*s == '>') rep = "&gt;";
        if (rep) {
            tr_buf_append(b, run, (size_t)(s - run));
            tr_buf_puts(b, rep);
            run = s + 1;
        }
    }
    tr_buf_append(b, run, (size_t)(s - run));
}

void xw_call_begin(tr_buf *b, const char *method)
{
    tr_buf_puts(b, "<?xml version=\"1.0\"?>\n<methodCall><methodName>");
    xw_escaped(b, method);
    tr_buf_puts(b, "</methodName><params>");
}
void xw_call_end(tr_buf *b) { tr_buf_puts(b, "</params></methodCall>\n"); }
void xw_response_begin(tr_buf *b) { tr_buf_puts(b, "<?xml version=\"1.0\"?>\n<methodResponse><params>"); }
void xw_response_end(tr_buf *b) { tr_buf_puts(b, "</params></methodResponse>\n"); }
void xw_param_begin(tr_buf *b) { tr_buf_puts(b, "<param>"); }
void xw_param_end(tr_buf *b) { tr_buf_puts(b, "</param>"); }
void xw_string(tr_buf *b, const char *s)
{
    tr_buf_puts(b, "<value><string>");
    xw_escaped(b, s ? s : "");
    tr_buf_puts(b, "</string></value>");
}
void xw_int(tr_buf *b, int64_t i)
{
    /* XML-RPC's <int> is 32-bit; anything wider goes out as <i8>. */
    if (i >= -2147483647LL - 1 && i <= 2147483647LL)
        tr_buf_printf(b, "<value><int>%lld</int></value>", (long long)i);
    else
        tr_buf_printf(b, "<value><i8>%lld</i8></value>", (long long)i);
}
void xw_bool(tr_buf *b, int v) { tr_buf_printf(b, "<value><boolean>%d</boolean></value>", v ? 1 : 0); }
void xw_array_begin(tr_buf *b) { tr_buf_puts(b, "<value><array><data>"); }
void xw_array_end(tr_buf *b) { tr_buf_puts(b, "</data></array></value>"); }

/* ---- values ---------------------------------------------------------------------- */
void xr_free(xr_value *v)
{
    if (!v) return;
    for (size_t i = 0; i < v->n; i++) xr_free(&v->items[i]);
    free(v->items);
    free(v->s);
    free(v->name);
    memset(v, 0, sizeof *v);
}

const xr_value *xr_at(const xr_value *arr, size_t i, xr_type want)
{
    if (!arr || arr->type != XR_ARRAY || i >= arr->n) return NULL;
    if (arr->items[i].type != want) return NULL;
    return &arr->items[i];
}

/* ---- parser ------------------------------------------------------------------------- */
typedef struct xp {
    const char *s;
    size_t len, pos;
    int depth;
    size_t nodes;
    char *err;
    size_t errlen;
} xp;

enum { TAG_OPEN = 1, TAG_CLOSE = 2, TAG_SELF = 3 };

static int xp_fail(xp *p, const char *what)
{
    return tr_seterr(p->err, p->errlen, "XML-RPC parse error at byte %zu: %s", p->pos, what);
}

static int is_ws(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

static int starts(const xp *p, size_t at, const char *lit)
{
    size_t n = strlen(lit);
    return at + n <= p->len && memcmp(p->s + at, lit, n) == 0;
}

static size_t find_lit(const xp *p, size_t from, const char *lit)
{
    size_t n = strlen(lit);
    for (size_t i = from; i + n <= p->len; i++)
        if (memcmp(p->s + i, lit, n) == 0) return i;
    return (size_t)-1;
}

/* skips whitespace, <?...?>, <!--...--> and <!...> declarations */
static int skip_misc(xp *p)
{
    for (;;) {
        while (p->pos < p->len && is_ws(p->s[p->pos])) p->pos++;
        if (starts(p, p->pos, "<?")) {
            size_t e = find_lit(p, p->pos + 2, "?>");
            if (e == (size_t)-1) return xp_fail(p, "unterminated <?");
            p->pos = e + 2;
        } else if (starts(p, p->pos, "<!--")) {
            size_t e = find_lit(p, p->pos + 4, "-->");
            if (e == (size_t)-1) return xp_fail(p, "unterminated comment");
            p->pos = e + 3;
        } else if (starts(p, p->pos, "<!")) {
            size_t e = find_lit(p, p->pos + 2, ">");
            if (e == (size_t)-1) return xp_fail(p, "unterminated <!");
            p->pos = e + 1;
        } else {
            return 0;
        }
    }
}

/* reads a tag at p->pos (after skip_misc); on success advances past it */
static int read_tag(xp *p, char *name, size_t cap, int *kind)
{
    if (skip_misc(p)) return -1;
    if (p->pos >= p->len) return xp_fail(p, "unexpected end of document");
    if (p->s[p->pos] != '<') return xp_fail(p, "expected a tag");
    size_t i = p->pos + 1;
    *kind = TAG_OPEN;
    if (i < p->len && p->s[i] == '/') { *kind = TAG_CLOSE; i++; }
    size_t start = i;
    while (i < p->len && !is_ws(p->s[i]) && p->s[i] != '>' && p->s[i] != '/') i++;
    size_t n = i - start;
    if (n == 0) return xp_fail(p, "empty tag name");
    if (n >= cap) return xp_fail(p, "tag name too long");
    memcpy(name, p->s + start, n);
    name[n] = 0;
    /* attributes (ignored); quoted values may contain '>' */
    char quote = 0;
    while (i < p->len) {
        char c = p->s[i];
        if (quote) { if (c == quote) quote = 0; }
        else if (c == '"' || c == '\'') quote = c;
        else if (c == '>') break;
        i++;
    }
    if (i >= p->len) return xp_fail(p, "unterminated tag");
    if (p->s[i - 1] == '/' && !quote && i - 1 >= start + n) {
        if (*kind == TAG_CLOSE) return xp_fail(p, "malformed closing tag");
        *kind = TAG_SELF;
    }
    p->pos = i + 1;
    return 0;
}

static int expect_tag(xp *p, const char *want, int allow_self, int *kind_out)
{
    char name[64];
    int kind;
    size_t at = p->pos;
    if (read_tag(p, name, sizeof name, &kind)) return -1;
    if (strcmp(name, want) != 0 || kind == TAG_CLOSE || (kind == TAG_SELF && !allow_self)) {
        p->pos = at;
        char msg[128];
        snprintf(msg, sizeof msg, "expected <%s>, found <%s%s>", want, kind == TAG_CLOSE ? "/" : "", name);
        return xp_fail(p, msg);
    }
    if (kind_out) *kind_out = kind;
    return 0;
}

static int expect_close(xp *p, const char *want)
{
    char name[64];
    int kind;
    size_t at = p->pos;
    if (read_tag(p, name, sizeof name, &kind)) return -1;
    if (kind != TAG_CLOSE || strcmp(name, want) != 0) {
        p->pos = at;
        char msg[128];
        snprintf(msg, sizeof msg, "expected </%s>, found <%s%s>", want, kind == TAG_CLOSE ? "/" : "", name);
        return xp_fail(p, msg);
    }
    return 0;
}

/* is the next tag (after misc) a closing tag named want? does not consume */
static int next_is_close(xp *p, const char *want)
{
    size_t at = p->pos;
    char name[64];
    int kind;
    if (read_tag(p, name, sizeof name, &kind)) { p->pos = at; return 0; }
    p->pos = at;
    return kind == TAG_CLOSE && strcmp(name, want) == 0;
}

static void put_utf8(char *out, size_t *o, unsigned long cp)
{
    if (cp < 0x80) out[(*o)++] = (char)cp;
    else if (cp < 0x800) { out[(*o)++] = (char)(0xC0 | (cp >> 6)); out[(*o)++] = (char)(0x80 | (cp & 0x3F)); }
    else if (cp < 0x10000) {
        out[(*o)++] = (char)(0xE0 | (cp >> 12)); out[(*o)++] = (char)(0x80 | ((cp >> 6) & 0x3F));
        out[(*o)++] = (char)(0x80 | (cp & 0x3F));
    } else {
        out[(*o)++] = (char)(0xF0 | (cp >> 18)); out[(*o)++] = (char)(0x80 | ((cp >> 12) & 0x3F));
        out[(*o)++] = (char)(0x80 | ((cp >> 6) & 0x3F)); out[(*o)++] = (char)(0x80 | (cp & 0x3F));
    }
}

/* decodes character data [a, b) into a fresh NUL-terminated string */
static int decode_text(xp *p, size_t a, size_t b, char **out, size_t *outlen)
{
    /* an entity never expands: "&#x10FFFF;" (10 bytes) -> 4 bytes */
    char *s = (char *)malloc(b - a + 1);
    if (!s) return xp_fail(p, "out of memory");
    size_t o = 0;
    for (size_t i = a; i < b;) {
        char c = p->s[i];
        if (c != '&') { s[o++] = c; i++; continue; }
        size_t semi = i + 1;
        while (semi < b && semi - i <= 12 && p->s[semi] != ';') semi++;
        if (semi >= b || p->s[semi] != ';') { free(s); return xp_fail(p, "unterminated entity"); }
        const char *e = p->s + i + 1;
        size_t en = semi - i - 1;
        if (en == 2 && !memcmp(e, "lt", 2)) s[o++] = '<';
        else if (en == 2 && !memcmp(e, "gt", 2)) s[o++] = '>';
        else if (en == 3 && !memcmp(e, "amp", 3)) s[o++] = '&';
        else if (en == 4 && !memcmp(e, "quot", 4)) s[o++] = '"';
        else if (en == 4 && !memcmp(e, "apos", 4)) s[o++] = '\'';
        else if (en >= 2 && e[0] == '#') {
            unsigned long cp = 0;
            int hex = (e[1] == 'x' || e[1] == 'X');
            size_t k = hex ? 2 : 1;
            if (k >= en) { free(s); return xp_fail(p, "empty character reference"); }
            for (; k < en; k++) {
                int d;
                char h = e[k];
                if (h >= '0' && h <= '9') d = h - '0';
                else if (hex && h >= 'a' && h <= 'f') d = h - 'a' + 10;
                else if (hex && h >= 'A' && h <= 'F') d = h - 'A' + 10;
                else { free(s); return xp_fail(p, "bad character reference"); }
                cp = cp * (hex ? 16u : 10u) + (unsigned long)d;
                if (cp > 0x10FFFF) { free(s); return xp_fail(p, "character reference out of range"); }
            }
            if (cp == 0) { free(s); return xp_fail(p, "NUL character reference"); }
            put_utf8(s, &o, cp);
        } else {
            free(s);
            return xp_fail(p, "unknown entity");
        }
        i = semi + 1;
    }
    s[o] = 0;
    *out = s;
    if (outlen) *outlen = o;
    return 0;
}

/* text up to the next '<' (CDATA not supported: XML-RPC peers do not send it) */
static int read_text(xp *p, char **out, size_t *outlen)
{
    size_t a = p->pos;
    while (p->pos < p->len && p->s[p->pos] != '<') p->pos++;
    if (p->pos >= p->len) return xp_fail(p, "unexpected end of document in text");
    return decode_text(p, a, p->pos, out, outlen);
}

static void trim(char *s)
{
    size_t n = strlen(s), a = 0;
    while (a < n && is_ws(s[a])) a++;
    while (n > a && is_ws(s[n - 1])) n--;
    memmove(s, s + a, n - a);
    s[n - a] = 0;
}

static int parse_value(xp *p, xr_value *v);

static int push_item(xp *p, xr_value *parent, size_t *cap)
{
    if (parent->n == *cap) {
        size_t nc = *cap ? *cap * 2 : 4;
        xr_value *it = (xr_value *)realloc(parent->items, nc * sizeof *it);
        if (!it) return xp_fail(p, "out of memory");
        parent->items = it;
        *cap = nc;
    }
    memset(&parent->items[parent->n], 0, sizeof parent->items[0]);
    parent->n++;
    return 0;
}

static int parse_scalar_text(xp *p, const char *tag, int kind, char **out, size_t *outlen)
{
    if (kind == TAG_SELF) {
        *out = (char *)calloc(1, 1);
        if (!*out) return xp_fail(p, "out of memory");
        if (outlen) *outlen = 0;
        return 0;
    }
    if (read_text(p, out, outlen)) return -1;
    if (expect_close(p, tag)) { free(*out); *out = NULL; return -1; }
    return 0;
}

static int parse_typed(xp *p, xr_value *v, const char *tag, int kind)
{
    if (!strcmp(tag, "i4") || !strcmp(tag, "int") || !strcmp(tag, "i8") || !strcmp(tag, "boolean")) {
        char *t = NULL;
        if (parse_scalar_text(p, tag, kind, &t, NULL)) return -1;
        trim(t);
        char *end = NULL;
        errno = 0;
        long long x = strtoll(t, &end, 10);
        int bad = (t[0] == 0 || *end != 0 || errno == ERANGE);
        free(t);
        if (bad) return xp_fail(p, "bad integer");
        if (!strcmp(tag, "boolean")) {
            if (x != 0 && x != 1) return xp_fail(p, "boolean must be 0 or 1");
            v->type = XR_BOOL;
        } else {
            if (strcmp(tag, "i8") && (x < -2147483647LL - 1 || x > 2147483647LL))
                return xp_fail(p, "int out of 32-bit range");
            v->type = XR_INT;
        }
        v->i = x;
        return 0;
    }
    if (!strcmp(tag, "double")) {
        char *t = NULL;
        if (parse_scalar_text(p, tag, kind, &t, NULL)) return -1;
        trim(t);
        char *end = NULL;
        double d = strtod(t, &end);
        int bad = (t[0] == 0 || *end != 0);
        free(t);
        if (bad) return xp_fail(p, "bad double");
        v->type = XR_DOUBLE;
        v->d = d;
        return 0;
    }
    if (!strcmp(tag, "string") || !strcmp(tag, "base64") || !strcmp(tag, "dateTime.iso8601")) {
        v->type = !strcmp(tag, "base64") ? XR_BASE64 : XR_STRING;
        return parse_scalar_text(p, tag, kind, &v->s, &v->slen);
    }
    if (!strcmp(tag, "nil")) {
        v->type = XR_NIL;
        return kind == TAG_SELF ? 0 : expect_close(p, "nil");
    }
    if (!strcmp(tag, "array")) {
        v->type = XR_ARRAY;
        if (kind == TAG_SELF) return 0;
        int k;
        if (expect_tag(p, "data", 1, &k)) return -1;
        if (k == TAG_OPEN) {
            size_t cap = 0;
            while (!next_is_close(p, "data")) {
                if (push_item(p, v, &cap)) return -1;
                if (parse_value(p, &v->items[v->n - 1])) return -1;
            }
            if (expect_close(p, "data")) return -1;
        }
        return expect_close(p, "array");
    }
    if (!strcmp(tag, "struct")) {
        v->type = XR_STRUCT;
        if (kind == TAG_SELF) return 0;
        size_t cap = 0;
        while (!next_is_close(p, "struct")) {
            if (expect_tag(p, "member", 0, NULL)) return -1;
            if (push_item(p, v, &cap)) return -1;
            xr_value *m = &v->items[v->n - 1];
            int k;
            if (expect_tag(p, "name", 1, &k)) return -1;
            if (parse_scalar_text(p, "name", k, &m->name, NULL)) return -1;
            if (parse_value(p, m)) return -1;
            if (expect_close(p, "member")) return -1;
        }
        return expect_close(p, "struct");
    }
    char msg[96];
    snprintf(msg, sizeof msg, "unknown value type <%s>", tag);
    return xp_fail(p, msg);
}

static int parse_value(xp *p, xr_value *v)
{
    char *keep_name = v->name;   /* a struct member's name survives the value parse */
    v->name = NULL;
    memset(v, 0, sizeof *v);
    v->name = keep_name;
    if (++p->depth > XR_MAX_DEPTH) return xp_fail(p, "nesting too deep");
    if (++p->nodes > XR_MAX_NODES) return xp_fail(p, "too many values");
    int kind;
    if (expect_tag(p, "value", 1, &kind)) return -1;
    if (kind == TAG_SELF) {
        v->type = XR_STRING;
        v->s = (char *)calloc(1, 1);
        if (!v->s) return xp_fail(p, "out of memory");
        p->depth--;
        return 0;
    }
    size_t text_start = p->pos;
    while (p->pos < p->len && p->s[p->pos] != '<') p->pos++;
    if (p->pos >= p->len) return xp_fail(p, "unexpected end of document in <value>");
    int typed = 0;
    if (!starts(p, p->pos, "</")) {
        /* whitespace (or a comment) before a type tag: typed value */
        for (size_t i = text_start; i < p->pos; i++)
            if (!is_ws(p->s[i])) return xp_fail(p, "text mixed with a tag inside <value>");
        if (!starts(p, p->pos, "<!--")) typed = 1;
        else {
            if (skip_misc(p)) return -1;
            if (!starts(p, p->pos, "</")) typed = 1;
        }
    }
    if (typed) {
        char tag[64];
        if (read_tag(p, tag, sizeof tag, &kind)) return -1;
        if (kind == TAG_CLOSE) return xp_fail(p, "unexpected closing tag in <value>");
        if (parse_typed(p, v, tag, kind)) return -1;
    } else {
        /* untyped: the raw text is a string */
        v->type = XR_STRING;
        if (decode_text(p, text_start, p->pos, &v->s, &v->slen)) return -1;
    }
    if (expect_close(p, "value")) return -1;
    p->depth--;
    return 0;
}

static int expect_end(xp *p)
{
    if (skip_misc(p)) return -1;
    if (p->pos != p->len) return xp_fail(p, "trailing data after document");
    return 0;
}

int xr_parse_response(const char *xml, size_t len, xr_value *out, int *is_fault,
                      char *err, size_t errlen)
{
    xp p = { xml, len, 0, 0, 0, err, errlen };
    memset(out, 0, sizeof *out);
    *is_fault = 0;
    if (expect_tag(&p, "methodResponse", 0, NULL)) goto fail;
    char name[64];
    int kind;
    size_t at = p.pos;
    if (read_tag(&p, name, sizeof name, &kind)) goto fail;
    p.pos = at;
    if (!strcmp(name, "fault")) {
        *is_fault = 1;
        if (expect_tag(&p, "fault", 0, NULL) || parse_value(&p, out) || expect_close(&p, "fault"))
            goto fail;
    } else {
        if (expect_tag(&p, "params", 0, NULL) || expect_tag(&p, "param", 0, NULL) ||
            parse_value(&p, out) || expect_close(&p, "param") || expect_close(&p, "params"))
            goto fail;
    }
    if (expect_close(&p, "methodResponse") || expect_end(&p)) goto fail;
    return 0;
fail:
    xr_free(out);
    return -1;
}

int xr_parse_call(const char *xml, size_t len, char *method, size_t method_cap,
                  xr_value *params, char *err, size_t errlen)
{
    xp p = { xml, len, 0, 0, 0, err, errlen };
    char *name = NULL;
    memset(params, 0, sizeof *params);
    params->type = XR_ARRAY;
    if (expect_tag(&p, "methodCall", 0, NULL) || expect_tag(&p, "methodName", 0, NULL) ||
        read_text(&p, &name, NULL) || expect_close(&p, "methodName"))
        goto fail;
    trim(name);
    if (!name[0] || strlen(name) >= method_cap) { xp_fail(&p, "bad methodName"); goto fail; }
    strcpy(method, name);
    if (!next_is_close(&p, "methodCall")) {
        int kind;
        if (expect_tag(&p, "params", 1, &kind)) goto fail;
        if (kind == TAG_OPEN) {
            size_t cap = 0;
            while (!next_is_close(&p, "params")) {
                if (expect_tag(&p, "param", 0, NULL)) goto fail;
                if (push_item(&p, params, &cap)) goto fail;
                if (parse_value(&p, &params->items[params->n - 1])) goto fail;
                if (expect_close(&p, "param")) goto fail;
            }
            if (expect_close(&p, "params")) goto fail;
        }
    }
    if (expect_close(&p, "methodCall") || expect_end(&p)) goto fail;
    free(name);
    return 0;
fail:
    free(name);
    xr_free(params);
    return -1;
}
