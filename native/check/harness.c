/* Runs the mast_core kernels on inputs from a fixed pseudo-random sequence and prints a hash of every
 * output, integer and float bits alike: the same hash from two builds (x86-64 and aarch64, different
 * compilers or flags) means the kernels give the same bits there (native/check/cross.sh). */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "../src/mast_core.h"
#include "log2_table.h"

static uint64_t state = 0x9E3779B97F4A7C15ull;
static uint32_t next(void)
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return (uint32_t)(state >> 11);
}
static double uniform(double lo, double hi) { return lo + (hi - lo) * ((double)next() / 2147483648.0); }

static uint64_t hash = 1469598103934665603ull;
static uint64_t part[4] = {1469598103934665603ull, 1469598103934665603ull, 1469598103934665603ull, 1469598103934665603ull};
static int counts[3];
static void mixp(int k, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++)
        part[k] = (part[k] ^ b[i]) * 1099511628211ull;
}
static void mix(const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++)
        hash = (hash ^ b[i]) * 1099511628211ull;
}

#define H 48
#define W 160
static uint8_t left[H][W], right[H][W];

static void scene(int shift)
{
    /* integer texture (random values box-blurred twice, so it is smooth at the window's scale) with
     * noise; right = left moved by `shift` px. Integers only: the inputs are the same bits anywhere */
    static int raw[H][W + 64], blur[H][W + 64];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W + 64; x++)
            raw[y][x] = (int)(next() % 256);
    for (int pass = 0; pass < 2; pass++) {
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W + 64; x++) {
                int s = 0, n = 0;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -2; dx <= 2; dx++)
                        if (y + dy >= 0 && y + dy < H && x + dx >= 0 && x + dx < W + 64) {
                            s += raw[y + dy][x + dx];
                            n++;
                        }
                blur[y][x] = s / n;
            }
        memcpy(raw, blur, sizeof raw);
    }
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int l = 2 * (raw[y][x + 32] - 128) + 128 + (int)(next() % 5) - 2;
            int r = 2 * (raw[y][x + 32 + shift] - 128) + 128 + (int)(next() % 5) - 2;
            left[y][x] = (uint8_t)(l < 0 ? 0 : l > 255 ? 255 : l);
            right[y][x] = (uint8_t)(r < 0 ? 0 : r > 255 ? 255 : r);
        }
}

int main(void)
{
    mc_set_log2_table(LOG2_TABLE);
    uint64_t ints = 0, floats = 0;
    for (int trial = 0; trial < 400; trial++) {
        scene(10 + (int)(next() % 20));
        mc_match_params p = {15, 1, MC_SUB_GAUSS6, 2.0, 1.1, 0.5};
        if (trial % 7 == 0)
            p.window = 11;
        mc_match_result m;
        memset(&m, 0, sizeof m);
        int has_pred = trial % 3 != 0;
        /* arguments drawn one statement at a time: C leaves their evaluation order to the compiler */
        double mx = uniform(50, 150), my = uniform(8, 40), mp = uniform(8, 32);
        mc_match_point(&left[0][0], W, &right[0][0], W, H, W, mx, my, 64, has_pred, mp, 4, &p, &m);
        counts[0] += m.status == MC_MATCH_VALID;
        mixp(0, &m.status, sizeof m.status); mixp(0, &m.value_q8, 8); mixp(0, &m.ratio, 8); mixp(0, &m.sigma_px, 8);
        mix(&m.status, sizeof m.status);
        mix(&m.value_q8, sizeof m.value_q8);
        mix(&m.d_int, sizeof m.d_int);
        mix(&m.best_cost, sizeof m.best_cost);
        mix(&m.ratio, sizeof m.ratio);
        mix(&m.sigma_px, sizeof m.sigma_px);
        int64_t v;
        int st = mc_cancel6_q8(&left[8][0], W, &right[8][0], W, 15, 80, (int64_t)(10 + next() % 20), &v);
        counts[1] += st == MC_MATCH_VALID;
        mixp(1, &st, sizeof st); if (st == MC_MATCH_VALID) mixp(1, &v, 8);
        mix(&st, sizeof st);
        if (st == MC_MATCH_VALID)
            mix(&v, sizeof v);
        mc_follow_result f;
        memset(&f, 0, sizeof f);
        double fx = uniform(40, 120), fy = uniform(16, 32), fdx = uniform(-25, -5), fdy = uniform(-1, 1);
        mc_follow_point(&left[0][0], W, &right[0][0], W, H, W, fx, fy, fdx, fdy, 15, 4, 2.0, 1.1, 1.0, &f);
        counts[2] += f.status == MC_FOLLOW_VALID;
        mixp(2, &f, sizeof f);
        mix(&f, sizeof f);
        int16_t map1[H][W][2];
        uint16_t map2[H][W];
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                map1[y][x][0] = (int16_t)(x + (int)(next() % 5) - 2);
                map1[y][x][1] = (int16_t)(y + (int)(next() % 5) - 2);
                map2[y][x] = (uint16_t)(next() % 1024);
            }
        uint8_t patch[20][40];
        int px = (int)(next() % 140) - 10, py = (int)(next() % 40) - 5;
        mc_remap_patch(&left[0][0], W, W, H, &map1[0][0][0], &map2[0][0], px, py, 40, 20, &patch[0][0]);
        mixp(3, patch, sizeof patch);
        mix(patch, sizeof patch);
    }
    ints = hash;
    hash = 1469598103934665603ull;
    double x[8] = {0}, pm[32] = {0}, mu[2] = {0.5, 0.5}, q[2] = {2e-4, 0.1}, xs[4], ps[16];
    for (int k = 0; k < 4; k++)
        pm[5 * k] = pm[16 + 5 * k] = k < 2 ? 100.0 : 100.0;
    double e = 100.0, n = 2000.0;
    for (int step = 0; step < 2000; step++) {
        mc_imm_predict(x, pm, mu, 0.1, q, 1200.0, 10.0);
        e += 0.3;
        n -= 0.2;
        double ze = e + uniform(-5, 5), zn = n + uniform(-5, 5);
        double z[2] = {ze, zn}, r[4] = {25.0, 3.0, 3.0, 16.0};
        mc_imm_correct(x, pm, mu, z, r);
        mc_imm_state(x, pm, mu, xs, ps);
        mix(xs, sizeof xs);
        mix(ps, sizeof ps);
    }
    floats = hash;
    printf("match %016llx (%d valid)  cancel6 %016llx (%d valid)  follow %016llx (%d valid)  remap %016llx\n",
           (unsigned long long)part[0], counts[0], (unsigned long long)part[1], counts[1],
           (unsigned long long)part[2], counts[2], (unsigned long long)part[3]);
    printf("integer kernels %016llx\nground filter   %016llx\n", (unsigned long long)ints, (unsigned long long)floats);
    return 0;
}
