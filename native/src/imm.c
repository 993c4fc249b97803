/* The ground-plane filter's arithmetic (edge/measure/groundtrack.py, GroundTrack): the IMM's
 * mixing and each constant-velocity model's prediction, each model's Kalman correction (Joseph
 * form) with its likelihood, and the models' combined state. State per track: x[2][4] (east,
 * north, ve, vn per model), p[2][4][4], mu[2].
 *
 * Float, not integer: the same formulas as the NumPy reference in the same order of operations,
 * but NumPy's small matrix products go through the BLAS, whose summation order (and use of fused
 * multiply-adds) is its own, so results agree to a few units in the last place, not bit for bit
 * (tests/native/test_imm.py bounds the difference; docs/decisions.md). */
#include <math.h>
#include "mast_core.h"

#define PI 3.141592653589793   /* math.pi */

void mc_imm_state(const double *x, const double *p, const double *mu, double *xs, double *ps)
{
    for (int k = 0; k < 4; k++)
        xs[k] = mu[0] * x[k] + mu[1] * x[4 + k];
    for (int a = 0; a < 16; a++)
        ps[a] = 0.0;
    for (int j = 0; j < 2; j++) {
        double d[4];
        for (int k = 0; k < 4; k++)
            d[k] = x[4 * j + k] - xs[k];
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++)
                ps[4 * a + b] += mu[j] * (p[16 * j + 4 * a + b] + d[a] * d[b]);
    }
}

void mc_imm_predict(double *x, double *p, double *mu, double dt, const double q[2], double quiet_stay_s,
                    double manoeuvre_stay_s)
{
    double p01 = 1.0 - exp(-dt / quiet_stay_s), p10 = 1.0 - exp(-dt / manoeuvre_stay_s);
    double trans[2][2] = {{1.0 - p01, p01}, {p10, 1.0 - p10}};
    double c[2], w[2][2], x0[2][4], p0[2][16];
    for (int j = 0; j < 2; j++)
        c[j] = mu[0] * trans[0][j] + mu[1] * trans[1][j];
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++)
            w[i][j] = (trans[i][j] * mu[i]) / (c[j] > 1e-300 ? c[j] : 1e-300);
    for (int j = 0; j < 2; j++)
        for (int k = 0; k < 4; k++)
            x0[j][k] = w[0][j] * x[k] + w[1][j] * x[4 + k];
    for (int j = 0; j < 2; j++)
        for (int a = 0; a < 16; a++) {
            double s = 0.0, t = 0.0;
            for (int i = 0; i < 2; i++) {
                double da = x[4 * i + a / 4] - x0[j][a / 4], db = x[4 * i + a % 4] - x0[j][a % 4];
                s += w[i][j] * p[16 * i + a];
                t += w[i][j] * da * db;
            }
            p0[j][a] = s + t;
        }
    for (int j = 0; j < 2; j++) {
        /* x = F x0, F = [[I, dt I], [0, I]] */
        x[4 * j + 0] = x0[j][0] + dt * x0[j][2];
        x[4 * j + 1] = x0[j][1] + dt * x0[j][3];
        x[4 * j + 2] = x0[j][2];
        x[4 * j + 3] = x0[j][3];
        /* P = F P0 F^T + Q */
        double fp[16], *pj = p + 16 * j, *a0 = p0[j];
        for (int b = 0; b < 4; b++) {
            fp[0 * 4 + b] = a0[0 * 4 + b] + dt * a0[2 * 4 + b];
            fp[1 * 4 + b] = a0[1 * 4 + b] + dt * a0[3 * 4 + b];
            fp[2 * 4 + b] = a0[2 * 4 + b];
            fp[3 * 4 + b] = a0[3 * 4 + b];
        }
        double qa = q[j] * (dt * dt * dt) / 3.0, qb = q[j] * (dt * dt) / 2.0, qc = q[j] * dt;
        double qm[16] = {qa, 0, qb, 0, 0, qa, 0, qb, qb, 0, qc, 0, 0, qb, 0, qc};
        for (int a = 0; a < 4; a++) {
            pj[4 * a + 0] = fp[4 * a + 0] + dt * fp[4 * a + 2] + qm[4 * a + 0];
            pj[4 * a + 1] = fp[4 * a + 1] + dt * fp[4 * a + 3] + qm[4 * a + 1];
            pj[4 * a + 2] = fp[4 * a + 2] + qm[4 * a + 2];
            pj[4 * a + 3] = fp[4 * a + 3] + qm[4 * a + 3];
        }
    }
    mu[0] = c[0];
    mu[1] = c[1];
}

void mc_imm_correct(double *x, double *p, double *mu, const double z[2], const double r[4])
{
    double likelihood[2];
    for (int j = 0; j < 2; j++) {
        double *xj = x + 4 * j, *pj = p + 16 * j;
        double y[2] = {z[0] - xj[0], z[1] - xj[1]};
        double s00 = pj[0] + r[0], s01 = pj[1] + r[1], s10 = pj[4] + r[2], s11 = pj[5] + r[3];
        double det = s00 * s11 - s01 * s10;
        double si[4] = {s11 / det, -s01 / det, -s10 / det, s00 / det};
        double k[4][2];
        for (int a = 0; a < 4; a++) {
            k[a][0] = pj[4 * a + 0] * si[0] + pj[4 * a + 1] * si[2];
            k[a][1] = pj[4 * a + 0] * si[1] + pj[4 * a + 1] * si[3];
        }
        for (int a = 0; a < 4; a++)
            xj[a] = xj[a] + (k[a][0] * y[0] + k[a][1] * y[1]);
        /* Joseph form: (I - K H) P (I - K H)^T + K R K^T */
        double ikh[16], tmp[16], krk[16];
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++)
                ikh[4 * a + b] = (a == b ? 1.0 : 0.0) - (b < 2 ? k[a][b] : 0.0);
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++) {
                double s = 0.0;
                for (int c = 0; c < 4; c++)
                    s += ikh[4 * a + c] * pj[4 * c + b];
                tmp[4 * a + b] = s;
            }
        for (int a = 0; a < 4; a++) {
            double kr0 = k[a][0] * r[0] + k[a][1] * r[2], kr1 = k[a][0] * r[1] + k[a][1] * r[3];
            for (int b = 0; b < 4; b++)
                krk[4 * a + b] = kr0 * k[b][0] + kr1 * k[b][1];
        }
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++) {
                double s = 0.0;
                for (int c = 0; c < 4; c++)
                    s += tmp[4 * a + c] * ikh[4 * b + c];
                pj[4 * a + b] = s + krk[4 * a + b];
            }
        double t0 = y[0] * si[0] + y[1] * si[2], t1 = y[0] * si[1] + y[1] * si[3];
        double nj = t0 * y[0] + t1 * y[1];
        likelihood[j] = exp(-0.5 * nj) / (2.0 * PI * sqrt(det > 1e-300 ? det : 1e-300));
    }
    double post[2] = {likelihood[0] * mu[0], likelihood[1] * mu[1]};
    double sum = post[0] + post[1];
    if (sum > 0 && isfinite(post[0]) && isfinite(post[1])) {
        mu[0] = post[0] / sum;
        mu[1] = post[1] / sum;
    }
}
