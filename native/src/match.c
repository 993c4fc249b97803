/* One point's stereo match along its row (edge/core/match.py, match_point with impl "int" and
 * min_disparity 0): gradient energy and predicted sigma, search range, exact integer (Z)SSD cost
 * curve, first minimum, second-best ratio, the gates of match_gate, and the sub-pixel step for
 * "none", "parabola" and the six-pass Gaussian cancellation (subpixel.py, batchsubpix.py). */
#include <math.h>
#include "mast_core.h"

#define MAX_CURVE 4096

static inline int64_t round_half_away(double v) { return (int64_t)copysign(floor(fabs(v) + 0.5), v); }
static inline int64_t max64(int64_t a, int64_t b) { return a > b ? a : b; }
static inline int64_t min64(int64_t a, int64_t b) { return a < b ? a : b; }

/* the 13 template-candidate pairs of the six passes: candidate window (of 9) and template window */
static const int CANDIDATE_OF[13] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 1, 2, 3};
static const int TEMPLATE_OF[13] = {2, 2, 2, 2, 2, 2, 2, 2, 2, 6, 6, 6, 6};
static const int CURVES[6][5] = {{4, 3, 2, 1, 0}, {17, 16, 15, 14, 13}, {8, 7, 6, 5, 26},
                                 {21, 20, 19, 18, 26}, {12, 11, 10, 9, 26}, {25, 24, 23, 22, 26}};
static const int LENGTHS[6] = {5, 5, 4, 4, 4, 4};
static const int FIRST_SIGN[6] = {1, -1, 1, -1, 1, -1};
static const int WEIGHTS[6] = {2, -2, 1, -1, 1, -1};
#define MAX_W 63

int mc_gauss6_q8(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int w, int xl,
                 int64_t d0, int64_t *value_q8)
{
    int h = w / 2, ecols = 2 * w + 8;
    int64_t xr = xl - d0;
    if (w > MAX_W)
        return 0;
    /* half sums of neighbours and doubled samples side by side, per view: [w rows][2w + 8] */
    int32_t ext[2][MAX_W][2 * MAX_W + 8];
    for (int r = 0; r < w; r++) {
        const uint8_t *a = left + r * lstride + (xl - h - 2), *b = right + r * rstride + (xr - h - 2);
        for (int c = 0; c < w + 4; c++) {
            ext[0][r][c] = a[c] + a[c + 1];
            ext[1][r][c] = b[c] + b[c + 1];
            ext[0][r][w + 4 + c] = 2 * a[c];
            ext[1][r][w + 4 + c] = 2 * b[c];
        }
    }
    int starts[9] = {0, 1, 2, 3, 4, w + 5, w + 6, w + 7, w + 8};
    int64_t s1[2][9], s2[2][9];
    for (int s = 0; s < 2; s++) {
        int64_t c1[2 * MAX_W + 8], c2[2 * MAX_W + 8];
        for (int c = 0; c < ecols; c++) {
            int64_t a = 0, b = 0;
            for (int r = 0; r < w; r++) {
                int64_t v = ext[s][r][c];
                a += v;
                b += v * v;
            }
            c1[c] = a;
            c2[c] = b;
        }
        for (int k = 0; k < 9; k++) {
            int64_t a = 0, b = 0;
            for (int j = 0; j < w; j++) {
                a += c1[starts[k] + j];
                b += c2[starts[k] + j];
            }
            s1[s][k] = a;
            s2[s][k] = b;
        }
    }
    int64_t n = (int64_t)w * w, terms[2][26];
    for (int s = 0; s < 2; s++) {
        for (int m = 0; m < 13; m++) {
            int ts = starts[TEMPLATE_OF[m]], cs = starts[CANDIDATE_OF[m]];
            int64_t cross = 0;
            for (int r = 0; r < w; r++) {
                const int32_t *t = ext[s][r] + ts, *c = ext[1 - s][r] + cs;
                int64_t acc = 0;
                for (int j = 0; j < w; j++)
                    acc += (int64_t)t[j] * c[j];
                cross += acc;
            }
            int64_t s1w = s1[1 - s][CANDIDATE_OF[m]], s2w = s2[1 - s][CANDIDATE_OF[m]];
            terms[s][m] = n * s2w - s1w * s1w;
            terms[s][13 + m] = 2 * (n * cross - s1[s][TEMPLATE_OF[m]] * s1w);
        }
    }
    for (int s = 0; s < 2; s++)
        for (int m = 0; m < 26; m++)
            if (terms[s][m] <= 0)
                return 0;
    int64_t y[27];
    for (int s = 0; s < 2; s++)
        for (int m = 0; m < 13; m++)
            y[s * 13 + m] = mc_log2_q(terms[s][m]) - 2 * mc_log2_q(terms[s][13 + m]);
    y[26] = (int64_t)1 << 40;
    int64_t total = 0;
    for (int c = 0; c < 6; c++) {
        int64_t v[5];
        for (int k = 0; k < 5; k++)
            v[k] = y[CURVES[c][k]];
        int k = 0;
        for (int j = 1; j < 5; j++)
            if (v[j] < v[k])
                k = j;
        if (!(k > 0 && k < LENGTHS[c] - 1))
            return 0;
        int64_t ym = v[k - 1], y0 = v[k], yp = v[k + 1];
        int64_t num = ym - yp, den = 2 * (ym - 2 * y0 + yp);
        if (!(den > 0) || (num < 0 ? -num : num) > den)
            return 0;
        int64_t first = d0 * FIRST_SIGN[c] - 2;
        int64_t fit = (first + k) * ((int64_t)1 << MC_FIT_BITS) + mc_div_round(num * ((int64_t)1 << MC_FIT_BITS), den);
        total += fit * WEIGHTS[c];
    }
    *value_q8 = mc_round_shift(total, MC_FIT_BITS + 3 - MC_SUBPIX_BITS);
    return 1;
}


/* subpixel.fit_curve_q: Q10 vertex of the parabola through the first minimum of an integer curve
 * and its neighbours (eq. 5.2), entry k at disparity first + k; 0 where it has none */
static int fit_curve_q(const int64_t *c, int n, int64_t first, int64_t *fit)
{
    int k = 0;
    for (int j = 1; j < n; j++)
        if (c[j] < c[k])
            k = j;
    if (!(k > 0 && k < n - 1))
        return 0;
    int64_t num = c[k - 1] - c[k + 1], den = 2 * (c[k - 1] - 2 * c[k] + c[k + 1]);
    if (den <= 0 || 2 * (num < 0 ? -num : num) > den)
        return 0;
    *fit = (first + k) * ((int64_t)1 << MC_FIT_BITS) + mc_div_round(num * ((int64_t)1 << MC_FIT_BITS), den);
    return 1;
}

static uint64_t isqrt64(uint64_t q)
{
    uint64_t r = (uint64_t)sqrt((double)q);
    while (r > 0 && r * r > q)
        r--;
    while ((r + 1) * (r + 1) <= q)
        r++;
    return r;
}

/* refine(..., "cancel6") on the integer path with ZSSD (subpixel.cancellation_costs with six=True and
 * the contrast equalisation, then symmetric6_q8, or symmetric_q8 without the mirrored passes' fits):
 * MC_MATCH_VALID and *value_q8, or the status of its failure. Windows up to 15 px (every sum below
 * 2^62); larger ones: MC_MATCH_REFINE (the caller's reference). */
int mc_cancel6_q8(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int w, int xl,
                  int64_t d0, int64_t *value_q8)
{
    if (w > 15)
        return MC_MATCH_REFINE;
    int h = w / 2, wc = w + 5, ecols = 2 * w + 8;
    int64_t xr = xl - d0, n = (int64_t)w * w;
    int64_t regs[2][15][20];
    for (int r = 0; r < w; r++) {
        const uint8_t *a = left + r * lstride + (xl - h - 2), *b = right + r * rstride + (xr - h - 2);
        for (int c = 0; c < wc; c++) {
            regs[0][r][c] = a[c];
            regs[1][r][c] = b[c];
        }
    }
    /* contrast: the right region scaled so its centre window has the left one's zero-mean energy */
    int64_t energy[2];
    for (int s = 0; s < 2; s++) {
        int64_t s1 = 0, s2 = 0;
        for (int r = 0; r < w; r++)
            for (int c = 2; c < 2 + w; c++) {
                s1 += regs[s][r][c];
                s2 += regs[s][r][c] * regs[s][r][c];
            }
        energy[s] = n * s2 - s1 * s1;
    }
    int64_t gain = 1 << MC_SUBPIX_BITS;
    if (energy[0] > 0 && energy[1] > 0) {
        uint64_t q = (((uint64_t)energy[0] << (4 * MC_SUBPIX_BITS)) + (uint64_t)(energy[1] / 2)) / (uint64_t)energy[1];
        int64_t g = mc_round_shift((int64_t)isqrt64(q), MC_SUBPIX_BITS);
        gain = g < (1 << (MC_SUBPIX_BITS - 1)) ? (1 << (MC_SUBPIX_BITS - 1)) : g > (2 << MC_SUBPIX_BITS) ? (2 << MC_SUBPIX_BITS) : g;
    }
    int64_t ext[2][15][38];
    for (int r = 0; r < w; r++)
        for (int c = 0; c < wc - 1; c++)
            for (int s = 0; s < 2; s++) {
                int64_t scale = s == 0 ? (1 << MC_SUBPIX_BITS) : gain;
                int64_t v0 = regs[s][r][c] * scale, v1 = regs[s][r][c + 1] * scale;
                ext[s][r][c] = v0 + v1;
                ext[s][r][w + 4 + c] = 2 * v0;
            }
    (void)ecols;
    int starts[9] = {0, 1, 2, 3, 4, w + 5, w + 6, w + 7, w + 8};
    int64_t costs[2][13];
    for (int s = 0; s < 2; s++)
        for (int m = 0; m < 13; m++) {
            int ts = m < 9 ? 2 : w + 6, cs = starts[m < 9 ? m : m - 9];
            int64_t sd = 0, sd2 = 0;
            for (int r = 0; r < w; r++)
                for (int j = 0; j < w; j++) {
                    int64_t d = ext[s][r][ts + j] - ext[1 - s][r][cs + j];
                    sd += d;
                    sd2 += d * d;
                }
            costs[s][m] = n * sd2 - sd * sd;
        }
    /* the pass curves in ascending disparity (subpixel._split) */
    int64_t curve[6][5];
    for (int s = 0; s < 2; s++) {
        for (int k = 0; k < 5; k++)
            curve[s == 0 ? 0 : 2][k] = costs[s][4 - k];        /* LR-A, RL-A */
        for (int k = 0; k < 4; k++) {
            curve[s == 0 ? 1 : 3][k] = costs[s][8 - k];        /* LR-B, RL-B */
            curve[s == 0 ? 4 : 5][k] = costs[s][12 - k];       /* LR-B', RL-B' */
        }
    }
    int64_t fa, fb, fra, frb, fm, frm;
    if (!fit_curve_q(curve[0], 5, d0 - 2, &fa) || !fit_curve_q(curve[1], 4, d0 - 2, &fb))
        return MC_MATCH_CANCEL_LR;
    if (!fit_curve_q(curve[2], 5, -d0 - 2, &fra) || !fit_curve_q(curve[3], 4, -d0 - 2, &frb))
        return MC_MATCH_CANCEL_RL;
    int ok_m = fit_curve_q(curve[4], 4, d0 - 2, &fm), ok_rm = fit_curve_q(curve[5], 4, -d0 - 2, &frm);
    if (ok_m && ok_rm)
        *value_q8 = mc_round_shift(2 * (fa - fra) + fb + fm - frb - frm, MC_FIT_BITS + 3 - MC_SUBPIX_BITS);
    else
        *value_q8 = mc_round_shift(fa + fb - fra - frb, MC_FIT_BITS + 2 - MC_SUBPIX_BITS);
    return MC_MATCH_VALID;
}

void mc_match_point(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int rows,
                    int cols, double x, double y, int max_disparity, int has_pred, double pred, int radius,
                    const mc_match_params *p, mc_match_result *out)
{
    int w = p->window, h = w / 2;
    out->status = MC_MATCH_REFERENCE;
    if (w < 3 || w % 2 == 0 || w > MAX_W || !isfinite(x) || !isfinite(y) || fabs(x) > 1e9 || fabs(y) > 1e9)
        return;
    if (has_pred && !(isfinite(pred) && fabs(pred) < 1e9))
        return;
    int64_t xi = round_half_away(x), yi = round_half_away(y);
    if (yi - h < 0 || yi + h >= rows || xi - h - 1 < 0 || xi + h + 1 >= cols)
        return;
    const uint8_t *a_band = left + (yi - h) * lstride, *b_band = right + (yi - h) * rstride;
    int64_t g2 = 0;
    for (int r = 0; r < w; r++) {
        const uint8_t *row = a_band + r * lstride;
        for (int64_t c = xi - h; c <= xi + h; c++) {
            int g = (int)row[c + 1] - (int)row[c - 1];
            g2 += g * g;
        }
    }
    double sigma = g2 > 0 ? p->noise_dn * sqrt(8.0 / (double)g2) : INFINITY;
    out->sigma_px = sigma;
    out->texture = (double)g2 / 4.0;
    if (!(sigma <= p->max_sigma_px))
        return;
    int64_t lo = 0, hi = max_disparity;
    if (has_pred) {
        int64_t centre = round_half_away(pred), rad = radius < 0 ? 4 : radius;
        lo = max64(lo, centre - rad);
        hi = min64(hi, centre + rad);
    }
    lo = max64(lo - 1, xi + h + 2 - cols);
    hi = min64(hi + 1, xi - h);
    if (hi - lo < 2 || hi - lo + 1 > MAX_CURVE)
        return;
    int n = (int)(hi - lo + 1);
    int64_t costs[MAX_CURVE], nn = (int64_t)w * w;
    for (int k = 0; k < n; k++) {
        /* 32-bit sums: |sum D| <= w^2 255, sum D^2 <= w^2 255^2 < 2^31 for windows up to 63 px */
        int64_t d = lo + k;
        int32_t sd = 0, sd2 = 0;
        for (int r = 0; r < w; r++) {
            const uint8_t *t = a_band + r * lstride + (xi - h), *c = b_band + r * rstride + (xi - d - h);
            for (int j = 0; j < w; j++) {
                int32_t diff = (int32_t)t[j] - (int32_t)c[j];
                sd += diff;
                sd2 += diff * diff;
            }
        }
        costs[k] = p->cost_zssd ? nn * sd2 - (int64_t)sd * sd : sd2;
    }
    int k0 = 0;
    for (int k = 1; k < n; k++)
        if (costs[k] < costs[k0])
            k0 = k;
    /* best other local minimum (ends count) beyond k0's neighbours, over the best */
    int any = 0;
    int64_t second = 0;
    for (int k = 0; k < n; k++) {
        if (k >= k0 - 1 && k <= k0 + 1)
            continue;
        if ((k == n - 1 || costs[k] <= costs[k + 1]) && (k == 0 || costs[k] <= costs[k - 1])) {
            if (!any || costs[k] < second)
                second = costs[k];
            any = 1;
        }
    }
    int64_t best = costs[k0];
    double ratio;
    if (!any)
        ratio = INFINITY;
    else if (best <= 0)
        ratio = second > 0 ? INFINITY : 1.0;
    else
        ratio = (double)second / (double)best;
    int64_t d0 = lo + k0;
    out->ratio = ratio;
    out->best_cost = best;
    out->d_int = d0;
    out->lo = lo;
    out->hi = hi;
    if (!(k0 > 0 && k0 < n - 1)) {
        out->status = MC_MATCH_EDGE;
        return;
    }
    if (ratio < p->min_ratio) {
        out->status = MC_MATCH_AMBIGUOUS;
        return;
    }
    if (p->subpixel != MC_SUB_NONE && p->subpixel != MC_SUB_PARABOLA
        && (xi - h - 2 < 0 || xi + h + 3 >= cols || d0 + 2 > xi - h || d0 - 2 < xi + h + 4 - cols)) {
        out->status = MC_MATCH_BORDER;
        return;
    }
    if (p->subpixel == MC_SUB_NONE) {
        out->value_q8 = d0 * ((int64_t)1 << MC_SUBPIX_BITS);
        out->status = MC_MATCH_VALID;
        return;
    }
    if (p->subpixel == MC_SUB_PARABOLA) {
        int64_t cm = costs[k0 - 1], c0 = costs[k0], cp = costs[k0 + 1];
        int64_t num = cm - cp, den = 2 * (cm - 2 * c0 + cp);
        if (!(c0 < cm && c0 <= cp) || den <= 0 || 2 * (num < 0 ? -num : num) > den) {
            out->status = MC_MATCH_NO_BRACKET;
            return;
        }
        int64_t fit = d0 * ((int64_t)1 << MC_FIT_BITS) + mc_div_round(num * ((int64_t)1 << MC_FIT_BITS), den);
        out->value_q8 = mc_round_shift(fit, MC_FIT_BITS - MC_SUBPIX_BITS);
        out->status = MC_MATCH_VALID;
        return;
    }
    if (p->subpixel == MC_SUB_GAUSS6 && p->cost_zssd) {
        if (mc_gauss6_q8(a_band, lstride, b_band, rstride, w, (int)xi, d0, &out->value_q8))
            out->status = MC_MATCH_VALID;
        else   /* no Gaussian through this window: the six passes' parabola fits, as refine falls back */
            out->status = mc_cancel6_q8(a_band, lstride, b_band, rstride, w, (int)xi, d0, &out->value_q8);
        return;
    }
    out->status = MC_MATCH_REFINE;
}
