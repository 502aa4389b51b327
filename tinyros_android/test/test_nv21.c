/* NV21 (YUV420SP) conversion against a floating-point BT.601 reference, known
 * colours, scaling, every supported encoding, and the JPEG path. */
#include <math.h>
#include <stdlib.h>
#include "tinyros/camera_shim.h"
#include "tr_internal.h"
#include "tr_test.h"

static tr_image make(const char *enc, uint32_t w, uint32_t h, uint32_t step, const uint8_t *data)
{
    tr_image img;
    memset(&img, 0, sizeof img);
    snprintf(img.encoding, sizeof img.encoding, "%s", enc);
    img.width = w;
    img.height = h;
    img.step = step;
    img.data = data;
    img.data_len = step * h;
    return img;
}

/* BT.601 studio range, floating point */
static double ref_y(double r, double g, double b) { return 16 + (65.738 * r + 129.057 * g + 25.064 * b) / 256; }
static double ref_u(double r, double g, double b) { return 128 + (-37.945 * r - 74.494 * g + 112.439 * b) / 256; }
static double ref_v(double r, double g, double b) { return 128 + (112.439 * r - 94.154 * g - 18.285 * b) / 256; }

static void test_reference(void)
{
    const int W = 64, H = 48;
    uint8_t *rgb = (uint8_t *)malloc(W * H * 3);
    srand(1234);
    for (int i = 0; i < W * H * 3; i++) rgb[i] = (uint8_t)(rand() & 0xFF);
    tr_image img = make("rgb8", W, H, W * 3, rgb);
    uint8_t *nv = (uint8_t *)malloc(tr_nv21_size(W, H));
    char err[256];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, W, H, err, sizeof err), 0);
    double worst = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *p = rgb + (y * W + x) * 3;
            double d = fabs(nv[y * W + x] - ref_y(p[0], p[1], p[2]));
            if (d > worst) worst = d;
        }
    CHECK(worst <= 1.0);
    double worst_c = 0;
    for (int y = 0; y < H; y += 2)
        for (int x = 0; x < W; x += 2) {
            double r = 0, g = 0, b = 0;
            for (int k = 0; k < 4; k++) {
                const uint8_t *p = rgb + ((y + k / 2) * W + x + k % 2) * 3;
                r += p[0]; g += p[1]; b += p[2];
            }
            r /= 4; g /= 4; b /= 4;
            const uint8_t *c = nv + W * H + (y / 2) * W + x;
            double dv = fabs(c[0] - ref_v(r, g, b)), du = fabs(c[1] - ref_u(r, g, b));
            if (dv > worst_c) worst_c = dv;
            if (du > worst_c) worst_c = du;
        }
    CHECK(worst_c <= 1.5);   /* block mean is rounded before the conversion */
    printf("NV21 vs reference: max |dY| %.2f, max |dUV| %.2f\n", worst, worst_c);

    /* bgr8 / rgba8 / bgra8 of the same picture give the same NV21 */
    uint8_t *bgr = (uint8_t *)malloc(W * H * 3), *rgba = (uint8_t *)malloc(W * H * 4), *bgra = (uint8_t *)malloc(W * H * 4);
    for (int i = 0; i < W * H; i++) {
        bgr[i * 3] = rgb[i * 3 + 2]; bgr[i * 3 + 1] = rgb[i * 3 + 1]; bgr[i * 3 + 2] = rgb[i * 3];
        memcpy(rgba + i * 4, rgb + i * 3, 3); rgba[i * 4 + 3] = 255;
        memcpy(bgra + i * 4, bgr + i * 3, 3); bgra[i * 4 + 3] = 7;
    }
    uint8_t *nv2 = (uint8_t *)malloc(tr_nv21_size(W, H));
    img = make("bgr8", W, H, W * 3, bgr);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv2, W, H, err, sizeof err), 0);
    CHECK(!memcmp(nv, nv2, tr_nv21_size(W, H)));
    img = make("rgba8", W, H, W * 4, rgba);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv2, W, H, err, sizeof err), 0);
    CHECK(!memcmp(nv, nv2, tr_nv21_size(W, H)));
    img = make("bgra8", W, H, W * 4, bgra);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv2, W, H, err, sizeof err), 0);
    CHECK(!memcmp(nv, nv2, tr_nv21_size(W, H)));
    free(rgb); free(bgr); free(rgba); free(bgra); free(nv); free(nv2);
}

static void solid(uint8_t r, uint8_t g, uint8_t b, int ey, int eu, int ev)
{
    uint8_t px[4 * 4 * 3];
    for (int i = 0; i < 16; i++) { px[i * 3] = r; px[i * 3 + 1] = g; px[i * 3 + 2] = b; }
    tr_image img = make("rgb8", 4, 4, 12, px);
    uint8_t nv[24];
    char err[128];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 4, 4, err, sizeof err), 0);
    /* expected values are the rounded float BT.601 ones; integer maths may be 1 off */
    CHECK(abs(nv[0] - ey) <= 1);
    CHECK(nv[15] == nv[0]);
    CHECK(abs(nv[16] - ev) <= 1);   /* NV21: V first */
    CHECK(abs(nv[17] - eu) <= 1);
    CHECK(nv[23] == nv[17]);
}

static void test_known_colours(void)
{
    solid(255, 255, 255, 235, 128, 128);
    solid(0, 0, 0, 16, 128, 128);
    solid(128, 128, 128, 126, 128, 128);
    solid(255, 0, 0, 82, 90, 240);
    solid(0, 255, 0, 145, 54, 34);
    solid(0, 0, 255, 41, 240, 110);
}

static void test_scaling(void)
{
    /* 4x4 mono8 ramp scaled to 2x2 picks pixels (0,0) (2,0) (0,2) (2,2) */
    uint8_t px[16];
    for (int i = 0; i < 16; i++) px[i] = (uint8_t)(i * 16);
    tr_image img = make("mono8", 4, 4, 4, px);
    uint8_t nv[6];
    char err[128];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 2, 2, err, sizeof err), 0);
    int g[4] = { px[0], px[2], px[8], px[10] };
    for (int k = 0; k < 4; k++) CHECK_EQ_INT(nv[k], ((66 * g[k] + 129 * g[k] + 25 * g[k] + 128) >> 8) + 16);
    CHECK_EQ_INT(nv[4], 128);
    CHECK_EQ_INT(nv[5], 128);
    /* upscaling 2x2 -> 4x4 replicates */
    uint8_t small[4] = { 0, 255, 255, 0 };
    img = make("mono8", 2, 2, 2, small);
    uint8_t nv4[24];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv4, 4, 4, err, sizeof err), 0);
    CHECK_EQ_INT(nv4[0], 16); CHECK_EQ_INT(nv4[1], 16); CHECK_EQ_INT(nv4[2], 235); CHECK_EQ_INT(nv4[3], 235);
    CHECK_EQ_INT(nv4[15], 16);
    /* row padding (step > width*bpp) is skipped */
    uint8_t padded[2 * 8] = { 10, 20, 99, 99, 99, 99, 99, 99, 30, 40, 99, 99, 99, 99, 99, 99 };
    img = make("mono8", 2, 2, 8, padded);
    uint8_t nvp[6];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nvp, 2, 2, err, sizeof err), 0);
    CHECK_EQ_INT(nvp[3], ((220 * 40 + 128) >> 8) + 16);
}

static void test_yuv_and_mono16(void)
{
    /* UYVY grey (Y=126,U=V=128) -> rgb ~ (128) -> Y back ~126 */
    uint8_t uyvy[4 * 2 * 2];
    for (int i = 0; i < 8; i++) { uyvy[i * 2] = 128; uyvy[i * 2 + 1] = 126; }
    tr_image img = make("yuv422", 4, 2, 8, uyvy);
    uint8_t nv[12];
    char err[128];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 4, 2, err, sizeof err), 0);
    CHECK(abs(nv[0] - 126) <= 1);
    CHECK(abs(nv[8] - 128) <= 1 && abs(nv[9] - 128) <= 1);
    /* YUYV with different Y per pixel of a pair */
    uint8_t yuyv[8] = { 16, 128, 235, 128, 16, 128, 235, 128 };
    img = make("yuv422_yuy2", 4, 1, 8, yuyv);
    uint8_t rgb[12];
    CHECK_EQ_INT(tr_image_to_rgb(&img, rgb, 4, 1, err, sizeof err), 0);
    CHECK_EQ_INT(rgb[0], 0);
    CHECK_EQ_INT(rgb[3], 255);
    /* an odd-width 4:2:2 row must hold its whole last pixel pair (found by libFuzzer:
     * get_rgb read the pair's chroma 2 bytes past a 3*2-byte row) */
    uint8_t odd[3 * 2] = { 128, 126, 128, 126, 128, 126 };
    img = make("yuv422", 3, 1, 6, odd);
    CHECK(tr_image_to_rgb(&img, rgb, 3, 1, err, sizeof err) != 0);
    CHECK_CONTAINS(err, "pixel pairs");
    uint8_t odd_padded[8] = { 128, 126, 128, 126, 128, 126, 128, 126 };
    img = make("yuv422_yuy2", 3, 1, 8, odd_padded);
    CHECK_EQ_INT(tr_image_to_rgb(&img, rgb, 3, 1, err, sizeof err), 0);
    /* mono16 little and big endian use the high byte */
    uint8_t m16[8] = { 0x34, 0xFF, 0x34, 0xFF, 0x34, 0xFF, 0x34, 0xFF };
    img = make("mono16", 2, 2, 4, m16);
    uint8_t nv16[6];
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv16, 2, 2, err, sizeof err), 0);
    CHECK_EQ_INT(nv16[0], 235);
    img.is_bigendian = 1;
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv16, 2, 2, err, sizeof err), 0);
    CHECK_EQ_INT(nv16[0], ((220 * 0x34 + 128) >> 8) + 16);
}

static void test_errors(void)
{
    uint8_t px[64] = { 0 };
    uint8_t nv[64];
    char err[256];
    tr_image img = make("rgb8", 4, 4, 12, px);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 3, 4, err, sizeof err), -1);
    CHECK_CONTAINS(err, "even");
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 0, 0, err, sizeof err), -1);
    img = make("32FC1", 2, 2, 8, px);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 2, 2, err, sizeof err), -1);
    CHECK_CONTAINS(err, "unsupported encoding \"32FC1\"");
    img = make("rgb8", 4, 2, 8, px);    /* step < 4*3 */
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 2, 2, err, sizeof err), -1);
    CHECK_CONTAINS(err, "step 8 is less than width 4");
    img = make("rgb8", 0, 0, 0, px);
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 2, 2, err, sizeof err), -1);
    img = make("rgb8", 2, 2, 6, px);
    img.data_len = 5;
    CHECK_EQ_INT(tr_image_to_nv21(&img, nv, 2, 2, err, sizeof err), -1);
}

static void test_jpeg(void)
{
    const int W = 64, H = 48;
    uint8_t *rgb = (uint8_t *)malloc(W * H * 3);
    for (int i = 0; i < W * H * 3; i++) rgb[i] = (uint8_t)(i % 251);
    tr_image img = make("rgb8", W, H, W * 3, rgb);
    uint8_t *j = NULL;
    size_t jl = 0;
    char err[256];
    int rc = tr_image_to_jpeg(&img, 0, 0, 85, &j, &jl, err, sizeof err);
    if (tr_have_jpeg()) {
        CHECK_EQ_INT(rc, 0);
        CHECK(jl > 100);
        CHECK(j && j[0] == 0xFF && j[1] == 0xD8 && j[jl - 2] == 0xFF && j[jl - 1] == 0xD9);
        printf("JPEG %dx%d: %zu bytes\n", W, H, jl);
    } else {
        CHECK_EQ_INT(rc, -1);
        printf("JPEG support not built in\n");
    }
    free(j);
    img = make("bogus", W, H, W * 3, rgb);
    CHECK_EQ_INT(tr_image_to_jpeg(&img, 32, 24, 85, &j, &jl, err, sizeof err), -1);
    CHECK(j == NULL);
    free(rgb);
}

int main(void)
{
    test_reference();
    test_known_colours();
    test_scaling();
    test_yuv_and_mono16();
    test_errors();
    test_jpeg();
    TEST_DONE();
}
