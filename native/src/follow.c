/* One point's follow from the previous left image to the current one (edge/core/refpoint.py,
 * follow_point with impl "int" and subpixel "parabola", as edge/core/batchmatch.track_points):
 * texture in x and y, the exact integer ZSSD cost square around the predicted motion, its first
 * minimum and second-best ratio, and the separable 3-point parabola fits at the integer offsets
 * and one row/column further, interpolated (note 1.6). */
#include <math.h>
#include "mast_core.h"

#define MAX_SIDE 65

static inline int64_t round_half_away(double v) { return (int64_t)copysign(floor(fabs(v) + 0.5), v); }

/* refine(..., "parabola") of the 3-point curve c[0..2] for d = d0 - 1 .. d0 + 1, from_q'd: 1 and
 * the value in px, or 0 (NO_BRACKET) */
static int parabola_px(int64_t cm, int64_t c0, int64_t cp, int64_t d0, double *px)
{
    int64_t num = cm - cp, den = 2 * (cm - 2 * c0 + cp);
    if (!(c0 < cm && c0 <= cp) || den <= 0 || 2 * (num < 0 ? -num : num) > den)
        return 0;
    int64_t fit = d0 * ((int64_t)1 << MC_FIT_BITS) + mc_div_round(num * ((int64_t)1 << MC_FIT_BITS), den);
    *px = (double)mc_round_shift(fit, MC_FIT_BITS - MC_SUBPIX_BITS) / (double)(1 << MC_SUBPIX_BITS);
    return 1;
}

void mc_follow_point(const uint8_t *prev, int64_t pstride, const uint8_t *cur, int64_t cstride, int rows,
                     int cols, double x, double y, double predicted_dx, double predicted_dy, int window,
                     int radius, double noise_dn, double min_ratio, double max_sigma_px,
                     mc_follow_result *out)
{
    int h = window / 2, r = radius, s = 2 * r + 1;
    out->status = MC_FOLLOW_REFERENCE;
    if (window < 3 || window % 2 == 0 || window > 63 || radius < 1 || s > MAX_SIDE)
        return;
    if (!isfinite(x) || !isfinite(y) || !isfinite(predicted_dx) || !isfinite(predicted_dy)
        || fabs(x) > 1e9 || fabs(y) > 1e9 || fabs(predicted_dx) > 1e9 || fabs(predicted_dy) > 1e9)
        return;
    int64_t pu = round_half_away(predicted_dx), pv = round_half_away(predicted_dy);
    int64_t xi = round_half_away(x), yi = round_half_away(y), m = h + 4;
    if ((xi < xi + pu ? xi : xi + pu) - r - m < 0 || (xi > xi + pu ? xi : xi + pu) + r + m >= cols
        || (yi < yi + pv ? yi : yi + pv) - r - m < 0 || (yi > yi + pv ? yi : yi + pv) + r + m >= rows)
        return;
    int64_t gx = 0, gy = 0;
    for (int64_t yy = yi - h; yy <= yi + h; yy++) {
        const uint8_t *row = prev + yy * pstride, *up = row - pstride, *down = row + pstride;
        for (int64_t xx = xi - h; xx <= xi + h; xx++) {
            int a = (int)row[xx + 1] - (int)row[xx - 1], b = (int)down[xx] - (int)up[xx];
            gx += a * a;
            gy += b * b;
        }
    }
    double sx = gx ? noise_dn * sqrt(8.0 / (double)gx) : INFINITY;
    double sy = gy ? noise_dn * sqrt(8.0 / (double)gy) : INFINITY;
    out->sigma_x_px = sx;
    out->sigma_y_px = sy;
    if (!(sx <= max_sigma_px && sy <= max_sigma_px))
        return;
    int64_t costs[MAX_SIDE][MAX_SIDE], nn = (int64_t)window * window;
    int64_t x0 = xi + pu - r - h, y0 = yi + pv - r - h;
    for (int v = 0; v < s; v++)
        for (int u = 0; u < s; u++) {
            int32_t sd = 0, sd2 = 0;   /* exact while window^2 255^2 < 2^31 (windows up to 63 px) */
            for (int i = 0; i < window; i++) {
                const uint8_t *t = prev + (yi - h + i) * pstride + (xi - h);
                const uint8_t *c = cur + (y0 + v + i) * cstride + (x0 + u);
                for (int j = 0; j < window; j++) {
                    int32_t d = (int32_t)t[j] - (int32_t)c[j];
                    sd += d;
                    sd2 += d * d;
                }
            }
            costs[v][u] = nn * sd2 - (int64_t)sd * sd;
        }
    int iy = 0, ix = 0;
    for (int v = 0; v < s; v++)
        for (int u = 0; u < s; u++)
            if (costs[v][u] < costs[iy][ix])
                iy = v, ix = u;
    /* best 4-neighbour local minimum outside the 3x3 around the best, over the best */
    int any = 0;
    int64_t second = 0;
    for (int v = 0; v < s; v++)
        for (int u = 0; u < s; u++) {
            if (v >= iy - 1 && v <= iy + 1 && u >= ix - 1 && u <= ix + 1)
                continue;
            int64_t c = costs[v][u];
            if ((v > 0 && c > costs[v - 1][u]) || (v < s - 1 && c > costs[v + 1][u])
                || (u > 0 && c > costs[v][u - 1]) || (u < s - 1 && c > costs[v][u + 1]))
                continue;
            if (!any || c < second)
                second = c;
            any = 1;
        }
    int64_t best = costs[iy][ix];
    double ratio = !any ? INFINITY : best <= 0 ? (second > 0 ? INFINITY : 1.0) : (double)second / (double)best;
    out->ratio = ratio;
    out->cost = (double)best;
    if (!(0 < iy && iy < 2 * r && 0 < ix && ix < 2 * r)) {
        out->status = MC_FOLLOW_EDGE;
        return;
    }
    if (ratio < min_ratio) {
        out->status = MC_FOLLOW_AMBIGUOUS;
        return;
    }
    int64_t u0 = pu - r + ix, v0 = pv - r + iy;
    /* along x on row iy + dv (motion u = -d, d ascending: u0 + 1, u0, u0 - 1); along y alike */
#define ALONG_X(dv, outp) parabola_px(costs[iy + (dv)][ix + 1], costs[iy + (dv)][ix], costs[iy + (dv)][ix - 1], -u0, outp)
#define ALONG_Y(du, outp) parabola_px(costs[iy + 1][ix + (du)], costs[iy][ix + (du)], costs[iy - 1][ix + (du)], -v0, outp)
    double ua, va, ub, vb;
    if (!ALONG_X(0, &ua) || !ALONG_Y(0, &va)) {
        out->status = MC_FOLLOW_NO_BRACKET;
        return;
    }
    ua = -ua;
    va = -va;
    double ty = va - (double)v0, tx = ua - (double)u0;
    if (!ALONG_X(ty >= 0 ? 1 : -1, &ub) || !ALONG_Y(tx >= 0 ? 1 : -1, &vb)) {
        out->status = MC_FOLLOW_NO_BRACKET;
        return;
    }
    ub = -ub;
    vb = -vb;
    double u = ua + fabs(ty) * (ub - ua);
    double v = va + fabs(tx) * (vb - va);
    out->x_px = x + u;
    out->y_px = y + v;
    out->dx_px = u;
    out->dy_px = v;
    out->status = MC_FOLLOW_VALID;
}
