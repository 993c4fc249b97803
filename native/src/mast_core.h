/* mast_core: the per-track integer kernels of the mast-stereo pipeline in plain C99.
 *
 * No Python, no allocation, no globals beyond the log2 table: each routine reads its inputs and
 * writes its outputs, so a DSP or FPGA port starts from these files (native/README.md). Every
 * routine is bit-identical to its NumPy reference in edge/core (tests/native prove it): integers
 * are exact, the few float operations are the reference's own, one IEEE operation at a time (the
 * build turns off contraction into fused multiply-adds, -ffp-contract=off).
 */
#ifndef MAST_CORE_H
#define MAST_CORE_H

#include <stdint.h>

/* ---- fixed point (edge/core/fixedpoint.py) ---- */
#define MC_SUBPIX_BITS 8
#define MC_FIT_BITS 10
#define MC_LOG_BITS 24
#define MC_LOG_TABLE_BITS 10

/* the 1025-entry Q24 table of log2(1 + i/1024) (fixedpoint.LOG2_TABLE), set once from Python */
void mc_set_log2_table(const int64_t *table);
int64_t mc_log2_q(int64_t value);                 /* fixedpoint.log2_q of one value > 0 */
int64_t mc_div_round(int64_t num, int64_t den);   /* fixedpoint.div_round, den > 0 */
int64_t mc_round_shift(int64_t value, int bits);  /* fixedpoint.round_shift, bits > 0 */

/* ---- rectified patches (edge/core/rectify.py: cv2.remap, INTER_LINEAR, BORDER_REPLICATE) ---- */
/* out[r][c] for the rectified pixel (x0 + c, y0 + r): the fixed-point maps of OpenCV's
 * convertMaps (map1 int16 x/y pairs, map2 the 5+5-bit fraction index), both img_h x img_w,
 * indexed with clamped coordinates as Rectifier.patch does; the image img_h x img_w uint8 with
 * row stride `stride` bytes. */
void mc_remap_patch(const uint8_t *image, int64_t stride, int img_w, int img_h,
                    const int16_t *map1, const uint16_t *map2, int x0, int y0, int width, int height,
                    uint8_t *out);

/* ---- stereo match (edge/core/match.py, batchmatch.py, batchsubpix.py) ---- */
enum mc_match_status {
    MC_MATCH_VALID = 0,
    MC_MATCH_EDGE = 1,        /* "minimum at the edge of the search range" */
    MC_MATCH_AMBIGUOUS = 2,   /* "ambiguous: second-best cost only ...x the best" */
    MC_MATCH_BORDER = 3,      /* "half-pixel passes run off the image ..." */
    MC_MATCH_REFERENCE = 4,   /* not on the fast path: the caller runs the NumPy reference */
    MC_MATCH_REFINE = 5,      /* gates passed, the six-pass Gaussian has no fit: refine in Python */
    MC_MATCH_NO_BRACKET = 6,  /* parabola: "cost curve does not bracket the minimum (den <= 0)" */
    MC_MATCH_CANCEL_LR = 7,   /* "half-pixel cancellation pass has no interior minimum" */
    MC_MATCH_CANCEL_RL = 8    /* "right-to-left cancellation pass has no interior minimum" */
};
#define MC_SUB_NONE 0
#define MC_SUB_PARABOLA 1
#define MC_SUB_GAUSS6 2
#define MC_SUB_OTHER 3        /* cancel, cancel6, refit, ...: gates here, refine in Python */

typedef struct {
    int window, cost_zssd, subpixel;
    double noise_dn, min_ratio, max_sigma_px;
} mc_match_params;

typedef struct {
    int status;
    int64_t value_q8;       /* sub-pixel disparity, Q8 (valid only) */
    int64_t d_int, lo, hi;  /* the integer minimum and the searched range */
    int64_t best_cost;
    double ratio, sigma_px, texture;
} mc_match_result;

/* One point's match_point (impl "int", min_disparity 0) on rectified left/right patches of one
 * shape (rows x cols, row strides in bytes). has_pred/pred/radius as match_point's
 * predicted_disparity/search_radius (radius < 0: its default). */
void mc_match_point(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int rows,
                    int cols, double x, double y, int max_disparity, int has_pred, double pred, int radius,
                    const mc_match_params *p, mc_match_result *out);

/* match._gauss6 (integer) for the window at column xl of w-row bands, around d0: 1 and the Q8
 * disparity in *value_q8, or 0 where the per-point routine gives None. */
int mc_gauss6_q8(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int w, int xl,
                 int64_t d0, int64_t *value_q8);

/* refine(..., "cancel6") (integer, ZSSD): an mc_match_status, and the Q8 disparity if valid */
int mc_cancel6_q8(const uint8_t *left, int64_t lstride, const uint8_t *right, int64_t rstride, int w, int xl,
                  int64_t d0, int64_t *value_q8);

/* ---- left-image follow (edge/core/refpoint.py, subpixel "parabola") ---- */
enum mc_follow_status {
    MC_FOLLOW_VALID = 0,
    MC_FOLLOW_EDGE = 1,       /* "minimum on the edge of the search square" */
    MC_FOLLOW_AMBIGUOUS = 2,  /* "ambiguous: ..." */
    MC_FOLLOW_NO_BRACKET = 3, /* a parabola fit has no bracketed minimum */
    MC_FOLLOW_REFERENCE = 4   /* not on the fast path: the caller runs the NumPy reference */
};

typedef struct {
    int status;
    double x_px, y_px, dx_px, dy_px, cost, sigma_x_px, sigma_y_px, ratio;
} mc_follow_result;

void mc_follow_point(const uint8_t *prev, int64_t pstride, const uint8_t *cur, int64_t cstride, int rows,
                     int cols, double x, double y, double predicted_dx, double predicted_dy, int window,
                     int radius, double noise_dn, double min_ratio, double max_sigma_px,
                     mc_follow_result *out);

/* ---- the ground-plane filter's IMM (edge/measure/groundtrack.py; float, module doc of imm.c) ---- */
/* x[2][4], p[2][4][4], mu[2] per track, row-major */
void mc_imm_state(const double *x, const double *p, const double *mu, double *xs, double *ps);
void mc_imm_predict(double *x, double *p, double *mu, double dt, const double q[2], double quiet_stay_s,
                    double manoeuvre_stay_s);
void mc_imm_correct(double *x, double *p, double *mu, const double z[2], const double r[4]);

#endif
