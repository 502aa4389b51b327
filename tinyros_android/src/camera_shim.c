/* NV21/JPEG conversion and the camera-service preview source. */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tinyros/camera_shim.h"
#include "tr_internal.h"

#ifdef TR_HAVE_JPEG
#include <jpeglib.h>
#include <setjmp.h>
#endif

enum { PF_RGB, PF_BGR, PF_RGBA, PF_BGRA, PF_MONO, PF_MONO16, PF_UYVY, PF_YUYV };

static int pixel_format(const tr_image *img, int *pf, int *bpp, char *err, size_t errlen)
{
    static const struct { const char *name; int pf, bpp; } t[] = {
        { "rgb8", PF_RGB, 3 }, { "bgr8", PF_BGR, 3 }, { "8UC3", PF_BGR, 3 },
        { "rgba8", PF_RGBA, 4 }, { "bgra8", PF_BGRA, 4 }, { "8UC4", PF_BGRA, 4 },
        { "mono8", PF_MONO, 1 }, { "8UC1", PF_MONO, 1 }, { "mono16", PF_MONO16, 2 },
        { "16UC1", PF_MONO16, 2 }, { "yuv422", PF_UYVY, 2 }, { "uyvy", PF_UYVY, 2 },
        { "yuv422_yuy2", PF_YUYV, 2 }, { "yuyv", PF_YUYV, 2 },
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        if (!strcmp(img->encoding, t[i].name)) {
            *pf = t[i].pf;
            *bpp = t[i].bpp;
            if (img->width == 0 || img->height == 0)
                return tr_seterr(err, errlen, "image is %ux%u", img->width, img->height);
            if ((uint64_t)img->width * (uint64_t)t[i].bpp > img->step)
                return tr_seterr(err, errlen, "step %u is less than width %u * %d bytes for %s",
                                 img->step, img->width, t[i].bpp, img->encoding);
            /* 4:2:2 stores pixel pairs (Y U Y V): an odd width still needs the whole last pair,
             * which get_rgb() reads for the chroma of the last pixel */
            if ((t[i].pf == PF_UYVY || t[i].pf == PF_YUYV) &&
                ((uint64_t)img->width + 1) / 2 * 4 > img->step)
                return tr_seterr(err, errlen, "step %u is less than the %u pixel pairs of a %u wide %s row",
                                 img->step, (img->width + 1) / 2, img->width, img->encoding);
            if ((uint64_t)img->step * img->height > img->data_len)
                return tr_seterr(err, errlen, "data is %u bytes, step*height needs %llu", img->data_len,
                                 (unsigned long long)img->step * img->height);
            return 0;
        }
    }
    return tr_seterr(err, errlen, "unsupported encoding \"%.60s\" (rgb8, bgr8, rgba8, bgra8, mono8, mono16, yuv422, yuv422_yuy2)",
                     img->encoding);
}

static uint8_t clamp8(int v) { return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); }

/* RGB of source pixel (x, y) */
static void get_rgb(const tr_image *img, int pf, int bpp, uint32_t x, uint32_t y, int *r, int *g, int *b)
{
    const uint8_t *row = img->data + (size_t)y * img->step;
    const uint8_t *p = row + (size_t)x * (size_t)bpp;
    switch (pf) {
    case PF_RGB: case PF_RGBA: *r = p[0]; *g = p[1]; *b = p[2]; return;
    case PF_BGR: case PF_BGRA: *r = p[2]; *g = p[1]; *b = p[0]; return;
    case PF_MONO: *r = *g = *b = p[0]; return;
    case PF_MONO16: *r = *g = *b = img->is_bigendian ? p[0] : p[1]; return;
    default: break;
    }
    /* 4:2:2 packed: a pair of pixels shares U and V */
    const uint8_t *q = row + (size_t)(x & ~1u) * 2u;
    int Y, U, V;
    if (pf == PF_UYVY) { U = q[0]; V = q[2]; Y = (x & 1) ? q[3] : q[1]; }
    else { U = q[1]; V = q[3]; Y = (x & 1) ? q[2] : q[0]; }
    /* BT.601 studio range to RGB, 8-bit fixed point */
    int c = Y - 16, d = U - 128, e = V - 128;
    *r = clamp8((298 * c + 409 * e + 128) >> 8);
    *g = clamp8((298 * c - 100 * d - 208 * e + 128) >> 8);
    *b = clamp8((298 * c + 516 * d + 128) >> 8);
}

static int check_out(int w, int h, int even, char *err, size_t errlen)
{
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384)
        return tr_seterr(err, errlen, "output size %dx%d out of range", w, h);
    if (even && ((w | h) & 1)) return tr_seterr(err, errlen, "NV21 needs an even size, not %dx%d", w, h);
    return 0;
}

int tr_image_to_nv21(const tr_image *img, uint8_t *out, int out_w, int out_h, char *err, size_t errlen)
{
    int pf, bpp;
    if (check_out(out_w, out_h, 1, err, errlen) || pixel_format(img, &pf, &bpp, err, errlen)) return -1;
    uint8_t *yp = out, *vu = out + (size_t)out_w * out_h;
    for (int y = 0; y < out_h; y += 2) {
        uint32_t sy0 = (uint32_t)((uint64_t)y * img->height / (uint32_t)out_h);
        uint32_t sy1 = (uint32_t)((uint64_t)(y + 1) * img->height / (uint32_t)out_h);
        for (int x = 0; x < out_w; x += 2) {
            uint32_t sx0 = (uint32_t)((uint64_t)x * img->width / (uint32_t)out_w);
            uint32_t sx1 = (uint32_t)((uint64_t)(x + 1) * img->width / (uint32_t)out_w);
            int r[4], g[4], b[4];
            get_rgb(img, pf, bpp, sx0, sy0, &r[0], &g[0], &b[0]);
            get_rgb(img, pf, bpp, sx1, sy0, &r[1], &g[1], &b[1]);
            get_rgb(img, pf, bpp, sx0, sy1, &r[2], &g[2], &b[2]);
            get_rgb(img, pf, bpp, sx1, sy1, &r[3], &g[3], &b[3]);
            int sr = 0, sg = 0, sb = 0;
            for (int k = 0; k < 4; k++) {
                uint8_t Y = (uint8_t)(((66 * r[k] + 129 * g[k] + 25 * b[k] + 128) >> 8) + 16);
                yp[(size_t)(y + (k >> 1)) * out_w + x + (k & 1)] = Y;
                sr += r[k]; sg += g[k]; sb += b[k];
            }
            /* mean of the block, rounded; +32768 (= 128 << 8) adds the chroma offset and keeps
             * the shifted value non-negative */
            int R = (sr + 2) >> 2, G = (sg + 2) >> 2, B = (sb + 2) >> 2;
            int U = (-38 * R - 74 * G + 112 * B + 128 + 32768) >> 8;
            int V = (112 * R - 94 * G - 18 * B + 128 + 32768) >> 8;
            uint8_t *c = vu + (size_t)(y / 2) * out_w + x;
            c[0] = clamp8(V);
            c[1] = clamp8(U);
        }
    }
    return 0;
}

int tr_image_to_rgb(const tr_image *img, uint8_t *out, int out_w, int out_h, char *err, size_t errlen)
{
    int pf, bpp;
    if (check_out(out_w, out_h, 0, err, errlen) || pixel_format(img, &pf, &bpp, err, errlen)) return -1;
    for (int y = 0; y < out_h; y++) {
        uint32_t sy = (uint32_t)((uint64_t)y * img->height / (uint32_t)out_h);
        for (int x = 0; x < out_w; x++) {
            uint32_t sx = (uint32_t)((uint64_t)x * img->width / (uint32_t)out_w);
            int r, g, b;
            get_rgb(img, pf, bpp, sx, sy, &r, &g, &b);
            uint8_t *o = out + ((size_t)y * out_w + x) * 3;
            o[0] = (uint8_t)r; o[1] = (uint8_t)g; o[2] = (uint8_t)b;
        }
    }
    return 0;
}

#ifdef TR_HAVE_JPEG
struct jerr { struct jpeg_error_mgr pub; jmp_buf jb; char msg[JMSG_LENGTH_MAX]; };
static void jerr_exit(j_common_ptr ci)
{
    struct jerr *e = (struct jerr *)ci->err;
    (*ci->err->format_message)(ci, e->msg);
    longjmp(e->jb, 1);
}

int tr_have_jpeg(void) { return 1; }

/* compresses packed RGB; nothing that setjmp could clobber is modified after it */
static int encode_jpeg(const uint8_t *rgb, const JDIMENSION w, const JDIMENSION h, const int quality,
                       uint8_t **jpeg, size_t *len, char *err, size_t errlen)
{
    struct jpeg_compress_struct ci;
    struct jerr je;
    unsigned char *volatile mem = NULL;
    unsigned long mlen = 0;
    ci.err = jpeg_std_error(&je.pub);
    je.pub.error_exit = jerr_exit;
    if (setjmp(je.jb)) {
        jpeg_destroy_compress(&ci);
        free(mem);
        return tr_seterr(err, errlen, "JPEG: %s", je.msg);
    }
    jpeg_create_compress(&ci);
    jpeg_mem_dest(&ci, (unsigned char **)&mem, &mlen);
    ci.image_width = w;
    ci.image_height = h;
    ci.input_components = 3;
    ci.in_color_space = JCS_RGB;
    jpeg_set_defaults(&ci);
    jpeg_set_quality(&ci, quality < 1 ? 1 : quality > 100 ? 100 : quality, TRUE);
    jpeg_start_compress(&ci, TRUE);
    while (ci.next_scanline < ci.image_height) {
        JSAMPROW row = (JSAMPROW)(rgb + (size_t)ci.next_scanline * w * 3);
        jpeg_write_scanlines(&ci, &row, 1);
    }
    jpeg_finish_compress(&ci);
    jpeg_destroy_compress(&ci);
    *jpeg = (uint8_t *)mem;
    *len = mlen;
    return 0;
}

int tr_image_to_jpeg(const tr_image *img, int out_w, int out_h, int quality, uint8_t **jpeg, size_t *len,
                     char *err, size_t errlen)
{
    *jpeg = NULL;
    *len = 0;
    if (out_w == 0 && out_h == 0) { out_w = (int)img->width; out_h = (int)img->height; }
    if (check_out(out_w, out_h, 0, err, errlen)) return -1;
    uint8_t *rgb = (uint8_t *)malloc((size_t)out_w * out_h * 3);
    if (!rgb) return tr_seterr(err, errlen, "out of memory");
    int rc = tr_image_to_rgb(img, rgb, out_w, out_h, err, errlen);
    if (rc == 0) rc = encode_jpeg(rgb, (JDIMENSION)out_w, (JDIMENSION)out_h, quality, jpeg, len, err, errlen);
    free(rgb);
    return rc;
}
#else
int tr_have_jpeg(void) { return 0; }
int tr_image_to_jpeg(const tr_image *img, int out_w, int out_h, int quality, uint8_t **jpeg, size_t *len,
                     char *err, size_t errlen)
{
    (void)img; (void)out_w; (void)out_h; (void)quality;
    *jpeg = NULL;
    *len = 0;
    return tr_seterr(err, errlen, "built without JPEG support (define TR_HAVE_JPEG and link libjpeg)");
}
#endif

/* ---- the preview source -------------------------------------------------------------- */
struct tr_camera {
    tr_sub *sub;
    int w, h;
    pthread_mutex_t mu;
    uint8_t *last;        /* last preview (NV21) */
    tr_image img;         /* newest frame; valid until the next tr_wait (called under mu) */
    int have_img;
    char err[256];
};

tr_camera *tr_camera_open(const tr_options *o, int preview_w, int preview_h, char *err, size_t errlen)
{
    if (check_out(preview_w, preview_h, 1, err, errlen)) return NULL;
    tr_camera *c = (tr_camera *)calloc(1, sizeof *c);
    if (!c) { tr_seterr(err, errlen, "out of memory"); return NULL; }
    c->w = preview_w;
    c->h = preview_h;
    size_t n = tr_nv21_size(preview_w, preview_h);
    c->last = (uint8_t *)malloc(n);
    if (!c->last) { free(c); tr_seterr(err, errlen, "out of memory"); return NULL; }
    memset(c->last, 16, (size_t)preview_w * preview_h);              /* black Y */
    memset(c->last + (size_t)preview_w * preview_h, 128, n - (size_t)preview_w * preview_h);
    c->sub = tr_open(o, err, errlen);
    if (!c->sub) { free(c->last); free(c); return NULL; }
    pthread_mutex_init(&c->mu, NULL);
    return c;
}

int tr_camera_preview(tr_camera *c, uint8_t *nv21, int timeout_ms, tr_image *frame)
{
    pthread_mutex_lock(&c->mu);
    tr_image img;
    int rc = tr_wait(c->sub, &img, timeout_ms);
    if (rc == 1) {
        c->img = img;
        c->have_img = 1;
        char e[256];
        if (tr_image_to_nv21(&img, c->last, c->w, c->h, e, sizeof e)) {
            /* report a bad frame once per distinct reason, keep the last good preview */
            if (strcmp(e, c->err) != 0) fprintf(stderr, "[tinyros] ERROR: camera preview: %s\n", e);
            snprintf(c->err, sizeof c->err, "%s", e);
            rc = 0;
        } else if (frame) {
            *frame = img;
        }
    }
    memcpy(nv21, c->last, tr_nv21_size(c->w, c->h));
    pthread_mutex_unlock(&c->mu);
    return rc;
}

int tr_camera_take_picture(tr_camera *c, int w, int h, int quality, uint8_t **jpeg, size_t *len)
{
    pthread_mutex_lock(&c->mu);
    int rc;
    tr_image img;
    if (tr_wait(c->sub, &img, 0) == 1) { c->img = img; c->have_img = 1; }
    if (!c->have_img) rc = tr_seterr(c->err, sizeof c->err, "takePicture: no frame received yet");
    else rc = tr_image_to_jpeg(&c->img, w, h, quality, jpeg, len, c->err, sizeof c->err);
    pthread_mutex_unlock(&c->mu);
    return rc;
}

void tr_camera_error(tr_camera *c, char *buf, size_t len)
{
    pthread_mutex_lock(&c->mu);
    if (c->err[0]) snprintf(buf, len, "%s", c->err);
    else tr_last_error(c->sub, buf, len);
    pthread_mutex_unlock(&c->mu);
}

tr_sub *tr_camera_subscriber(tr_camera *c) { return c->sub; }

void tr_camera_close(tr_camera *c)
{
    if (!c) return;
    tr_close(c->sub);
    pthread_mutex_destroy(&c->mu);
    free(c->last);
    free(c);
}
