/* Rectified patches: OpenCV's remap (INTER_LINEAR, BORDER_REPLICATE) with its fixed-point maps,
 * for one patch (edge/core/rectify.py, Rectifier.patch).
 *
 * convertMaps(CV_16SC2) stores each rectified pixel's raw position as whole pixels (map1) and a
 * 5+5-bit fraction index (map2 = fy * 32 + fx); remap weighs the four neighbours with
 * (32 - fx)(32 - fy), fx(32 - fy), (32 - fx)fy and fx fy times 32 (a 2^15 scale), adds 2^14 and
 * shifts by 15. Neighbours outside the image repeat its border pixel. */
#include "mast_core.h"

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* the four weights of each fraction index, [fy * 32 + fx][k] */
static int32_t weights[1024][4];
static int weights_made = 0;

static void make_weights(void)
{
    for (int f = 0; f < 1024; f++) {
        int fx = f & 31, fy = f >> 5;
        weights[f][0] = (32 - fx) * (32 - fy) * 32;
        weights[f][1] = fx * (32 - fy) * 32;
        weights[f][2] = (32 - fx) * fy * 32;
        weights[f][3] = fx * fy * 32;
    }
    weights_made = 1;
}

static inline uint8_t sample_border(const uint8_t *image, int64_t stride, int img_w, int img_h, int sx, int sy,
                                    const int32_t *w)
{
    int xa = clampi(sx, 0, img_w - 1), xb = clampi(sx + 1, 0, img_w - 1);
    int ya = clampi(sy, 0, img_h - 1), yb = clampi(sy + 1, 0, img_h - 1);
    const uint8_t *ra = image + (int64_t)ya * stride, *rb = image + (int64_t)yb * stride;
    int v = ra[xa] * w[0] + ra[xb] * w[1] + rb[xa] * w[2] + rb[xb] * w[3];
    v = (v + (1 << 14)) >> 15;
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
}

void mc_remap_patch(const uint8_t *image, int64_t stride, int img_w, int img_h,
                    const int16_t *map1, const uint16_t *map2, int x0, int y0, int width, int height,
                    uint8_t *out)
{
    if (!weights_made)
        make_weights();
    /* the patch's columns inside the map, [c_lo, c_hi): the rest repeat its edge columns */
    int c_lo = clampi(-x0, 0, width), c_hi = clampi(img_w - x0, c_lo, width);
    unsigned wl = (unsigned)(img_w - 1), hl = (unsigned)(img_h - 1);
    for (int r = 0; r < height; r++) {
        int my = clampi(y0 + r, 0, img_h - 1);
        const int16_t *m1 = map1 + (int64_t)my * img_w * 2;
        const uint16_t *m2 = map2 + (int64_t)my * img_w;
        uint8_t *o = out + (int64_t)r * width;
        for (int c = 0; c < width; c++) {
            int mx = c < c_lo ? 0 : c >= c_hi ? img_w - 1 : x0 + c;
            if (c == c_lo && c_hi > c_lo) {   /* the columns inside the map: no clamping of mx */
                for (; c < c_hi; c++) {
                    int k = x0 + c, sx = m1[2 * k], sy = m1[2 * k + 1];
                    const int32_t *w = weights[m2[k] & 1023];
                    if ((unsigned)sx < wl && (unsigned)sy < hl) {
                        const uint8_t *ra = image + (int64_t)sy * stride + sx, *rb = ra + stride;
                        int v = ra[0] * w[0] + ra[1] * w[1] + rb[0] * w[2] + rb[1] * w[3];
                        o[c] = (uint8_t)((v + (1 << 14)) >> 15);   /* convex weights: 0..255 */
                    } else {
                        o[c] = sample_border(image, stride, img_w, img_h, sx, sy, w);
                    }
                }
                c--;
                continue;
            }
            int sx = m1[2 * mx], sy = m1[2 * mx + 1];
            o[c] = sample_border(image, stride, img_w, img_h, sx, sy, weights[m2[mx] & 1023]);
        }
    }
}
