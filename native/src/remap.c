/* Rectified patches: OpenCV's remap (INTER_LINEAR, BORDER_REPLICATE) with its fixed-point maps,
 * for one patch (edge/core/rectify.py, Rectifier.patch).
 *
 * convertMaps(CV_16SC2) stores each rectified pixel's raw position as whole pixels (map1) and a
 * 5+5-bit fraction index (map2 = fy * 32 + fx); remap weighs the four neighbours with
 * (32 - fx)(32 - fy), fx(32 - fy), (32 - fx)fy and fx fy times 32 (a 2^15 scale), adds 2^14 and
 * shifts by 15. Neighbours outside the image repeat its border pixel. */
#include "mast_core.h"

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

void mc_remap_patch(const uint8_t *image, int64_t stride, int img_w, int img_h,
                    const int16_t *map1, const uint16_t *map2, int x0, int y0, int width, int height,
                    uint8_t *out)
{
    for (int r = 0; r < height; r++) {
        int my = clampi(y0 + r, 0, img_h - 1);
        const int16_t *m1 = map1 + (int64_t)my * img_w * 2;
        const uint16_t *m2 = map2 + (int64_t)my * img_w;
        uint8_t *o = out + (int64_t)r * width;
        for (int c = 0; c < width; c++) {
            int mx = clampi(x0 + c, 0, img_w - 1);
            int sx = m1[2 * mx], sy = m1[2 * mx + 1];
            int f = m2[mx] & 1023, fx = f & 31, fy = f >> 5;
            int w00 = (32 - fx) * (32 - fy) * 32, w01 = fx * (32 - fy) * 32;
            int w10 = (32 - fx) * fy * 32, w11 = fx * fy * 32;
            int xa, xb, ya, yb;
            if ((unsigned)sx < (unsigned)(img_w - 1) && (unsigned)sy < (unsigned)(img_h - 1)) {
                xa = sx; xb = sx + 1; ya = sy; yb = sy + 1;
            } else {
                xa = clampi(sx, 0, img_w - 1); xb = clampi(sx + 1, 0, img_w - 1);
                ya = clampi(sy, 0, img_h - 1); yb = clampi(sy + 1, 0, img_h - 1);
            }
            const uint8_t *ra = image + (int64_t)ya * stride, *rb = image + (int64_t)yb * stride;
            int v = ra[xa] * w00 + ra[xb] * w01 + rb[xa] * w10 + rb[xb] * w11;
            v = (v + (1 << 14)) >> 15;
            o[c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        }
    }
}
