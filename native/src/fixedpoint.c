/* Fixed-point helpers of edge/core/fixedpoint.py: rounding shifts and divisions, integer log2. */
#include "mast_core.h"

static int64_t log2_table[(1 << MC_LOG_TABLE_BITS) + 1];

void mc_set_log2_table(const int64_t *table)
{
    for (int i = 0; i <= (1 << MC_LOG_TABLE_BITS); i++)
        log2_table[i] = table[i];
}

int64_t mc_log2_q(int64_t value)
{
    /* exponent by count-leading-zeros, the mantissa normalised to 62 fraction bits, its top
     * 10 bits index the table and the next 30 interpolate (floor), as fixedpoint.log2_q */
    uint64_t v = (uint64_t)value;
    int e = 63 - __builtin_clzll(v);
    uint64_t frac = (v << (62 - e)) - ((uint64_t)1 << 62);
    int low_bits = 62 - MC_LOG_TABLE_BITS;
    uint64_t idx = frac >> low_bits;
    int64_t base = log2_table[idx], step = log2_table[idx + 1] - log2_table[idx];
    int64_t rest = (int64_t)((frac >> (low_bits - 30)) & (((uint64_t)1 << 30) - 1));
    return (int64_t)e * ((int64_t)1 << MC_LOG_BITS) + base + ((step * rest) >> 30);
}

int64_t mc_div_round(int64_t num, int64_t den)
{
    int64_t a = num < 0 ? -num : num;
    int64_t q = (2 * a + den) / (2 * den);
    return num >= 0 ? q : -q;
}

int64_t mc_round_shift(int64_t value, int bits)
{
    int64_t half = (int64_t)1 << (bits - 1);
    if (value >= 0)
        return (value + half) >> bits;
    return -((-value + half) >> bits);
}
