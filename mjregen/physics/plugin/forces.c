/* The forces of a soft voxel robot, after the paper's engine (Voxelyze): bonds (one beam
   element per face bond, or 8 spring tendons), phase-actuated muscles, the engine's floor
   (penalty spring and damper with static/kinetic friction and a stick state),
   self-collision and drag. Everything is added to qfrc_passive; MuJoCo (or step.c)
   integrates. Only the state (qpos, qvel, time, the stick flags) and the instance's
   configuration are read.

   Per-voxel data are rows of nvox doubles (structure of arrays: voxels.h), so that the
   per-voxel and per-bond arithmetic runs as loops the compiler vectorises. */
#include <math.h>
#include <string.h>

#include "voxels.h"

/* row k of the voxels' scratch: nvox doubles */
#define ROW(v, k) ((v)->scratch + (size_t)(k) * (size_t)(v)->nvox)

/* signed strains (e+, e-) of the two muscle phases at time t */
static void strains(const mjrVoxels* v, double t, double* ep, double* em) {
  if (t < v->start) {
    *ep = 0.0;
    *em = 0.0;
    return;
  }
  double wave = sin(v->omega * (t - v->start));
  if (v->contract) {
    *ep = wave < 0.0 ? wave : 0.0;
    *em = -wave < 0.0 ? -wave : 0.0;
  } else {
    *ep = wave;
    *em = -wave;
  }
}

static inline void cross(const double* a, const double* b, double* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

void mjr_load_state(mjrVoxels* v, const mjData* d) {
  const size_t N = (size_t)v->nvox;
  int nq = v->dim == 3 ? 7 : 3, nv = v->dim == 3 ? 6 : 3;
  double* q = v->state + MJR_QPOS * N;
  double* w = v->state + MJR_QVEL * N;
  for (size_t n = 0; n < N; n++) {
    int qa = v->qadr[n], va = v->vadr[n];
    for (int k = 0; k < nq; k++) q[k * N + n] = qa < 0 ? 0.0 : d->qpos[qa + k];
    for (int k = 0; k < nv; k++) w[k * N + n] = va < 0 ? 0.0 : d->qvel[va + k];
    if (qa < 0 && v->dim == 3) { /* welded: at its body position, unturned */
      for (int a = 0; a < 3; a++) q[a * N + n] = v->pos0[3 * n + a];
      q[3 * N + n] = 1.0;
    }
  }
}

void mjr_store_state(const mjrVoxels* v, mjData* d) {
  const size_t N = (size_t)v->nvox;
  int nq = v->dim == 3 ? 7 : 3, nv = v->dim == 3 ? 6 : 3;
  const double* q = v->state + MJR_QPOS * N;
  const double* w = v->state + MJR_QVEL * N;
  for (size_t n = 0; n < N; n++) {
    int qa = v->qadr[n], va = v->vadr[n];
    if (qa < 0) continue;
    for (int k = 0; k < nq; k++) d->qpos[qa + k] = q[k * N + n];
    for (int k = 0; k < nv; k++) d->qvel[va + k] = w[k * N + n];
  }
}

/* frames and velocities of all voxels from the joint state rows; forces and torques zeroed.
   A welded voxel's rows hold its body position at rest (mjr_load_state). */
static void voxel_states(mjrVoxels* v) {
  const size_t N = (size_t)v->nvox;
  const double* restrict q = v->state + MJR_QPOS * N;
  const double* restrict qv = v->state + MJR_QVEL * N;
  double* restrict s = v->scratch;
  memset(s + MJR_FORCE * N, 0, 6 * N * sizeof(double)); /* force and torque rows */
  if (v->dim == 3) {
#pragma GCC ivdep /* rows never overlap */
    for (size_t n = 0; n < N; n++) {
      for (int a = 0; a < 3; a++) s[(MJR_P + a) * N + n] = q[a * N + n];
      double qw = q[3 * N + n], qx = q[4 * N + n], qy = q[5 * N + n], qz = q[6 * N + n];
      double norm = sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
      int degenerate = norm < 1e-15; /* MuJoCo's mju_normalize4: degenerate -> identity */
      qw = degenerate ? 1.0 : qw / norm;
      qx = degenerate ? 0.0 : qx / norm;
      qy = degenerate ? 0.0 : qy / norm;
      qz = degenerate ? 0.0 : qz / norm;
      s[(MJR_QUAT + 0) * N + n] = qw;
      s[(MJR_QUAT + 1) * N + n] = qx;
      s[(MJR_QUAT + 2) * N + n] = qy;
      s[(MJR_QUAT + 3) * N + n] = qz;
      /* mju_quat2Mat */
      double q00 = qw * qw, q01 = qw * qx, q02 = qw * qy, q03 = qw * qz;
      double q11 = qx * qx, q12 = qx * qy, q13 = qx * qz;
      double q22 = qy * qy, q23 = qy * qz, q33 = qz * qz;
      double R[9];
      R[0] = q00 + q11 - q22 - q33;
      R[4] = q00 - q11 + q22 - q33;
      R[8] = q00 - q11 - q22 + q33;
      R[1] = 2 * (q12 - q03);
      R[2] = 2 * (q13 + q02);
      R[3] = 2 * (q12 + q03);
      R[5] = 2 * (q23 - q01);
      R[6] = 2 * (q13 - q02);
      R[7] = 2 * (q23 + q01);
      for (int k = 0; k < 9; k++) s[(MJR_R + k) * N + n] = R[k];
      for (int a = 0; a < 3; a++) s[(MJR_VEL + a) * N + n] = qv[a * N + n];
      /* free joint: angular velocity in the body frame, to world */
      double o0 = qv[3 * N + n], o1 = qv[4 * N + n], o2 = qv[5 * N + n];
      s[(MJR_W + 0) * N + n] = R[0] * o0 + R[1] * o1 + R[2] * o2;
      s[(MJR_W + 1) * N + n] = R[3] * o0 + R[4] * o1 + R[5] * o2;
      s[(MJR_W + 2) * N + n] = R[6] * o0 + R[7] * o1 + R[8] * o2;
    }
    return;
  }
  for (size_t n = 0; n < N; n++) {
    /* slide x, slide z, hinge y at the body origin */
    const double* p0 = v->pos0 + 3 * n;
    s[(MJR_P + 0) * N + n] = p0[0] + q[n];
    s[(MJR_P + 1) * N + n] = p0[1];
    s[(MJR_P + 2) * N + n] = p0[2] + q[N + n];
    double half = 0.5 * q[2 * N + n];
    double qw = cos(half), qy = sin(half);
    s[(MJR_QUAT + 0) * N + n] = qw;
    s[(MJR_QUAT + 1) * N + n] = 0.0;
    s[(MJR_QUAT + 2) * N + n] = qy;
    s[(MJR_QUAT + 3) * N + n] = 0.0;
    double q00 = qw * qw, q02 = qw * qy, q22 = qy * qy;
    double R[9] = {q00 - q22, 0.0, 2 * q02, 0.0, q00 + q22, 0.0, -2 * q02, 0.0, q00 - q22};
    for (int k = 0; k < 9; k++) s[(MJR_R + k) * N + n] = R[k];
    s[(MJR_VEL + 0) * N + n] = qv[n];
    s[(MJR_VEL + 1) * N + n] = 0.0;
    s[(MJR_VEL + 2) * N + n] = qv[N + n];
    s[(MJR_W + 0) * N + n] = 0.0;
    s[(MJR_W + 1) * N + n] = qv[2 * N + n];
    s[(MJR_W + 2) * N + n] = 0.0;
  }
}

/* x = rows k, k+1, k+2 of voxel n */
static inline void get3(const mjrVoxels* v, int k, int n, double* x) {
  const double* row = ROW(v, k) + n;
  size_t N = (size_t)v->nvox;
  x[0] = row[0];
  x[1] = row[N];
  x[2] = row[2 * N];
}

/* rows k, k+1, k+2 of voxel n += sign x */
static inline void add3(mjrVoxels* v, int k, int n, double sign, const double* x) {
  double* row = ROW(v, k) + n;
  size_t N = (size_t)v->nvox;
  if (sign > 0) {
    row[0] += x[0];
    row[N] += x[1];
    row[2 * N] += x[2];
  } else {
    row[0] -= x[0];
    row[N] -= x[1];
    row[2 * N] -= x[2];
  }
}

/* The bond's 8 (3D) or 4 (2D) spring tendons between sites fixed in the two voxels, with
   stiffness-proportional dampers; a driven bond's tendons have the rest length
   sqrt(l0^2 + d^2), l0 its actuated axial rest length, d the tendon's lateral extent. */
static void tendon_bonds(mjrVoxels* v, double ep, double em) {
  int t = 0;
  while (t < v->ntendon) {
    int bond = v->tendon_bond[t];
    int i = v->bonds[2 * bond], j = v->bonds[2 * bond + 1];
    double pi[3], pj[3], Ri[9], Rj[9], ui[3], uj[3], wi[3], wj[3];
    get3(v, MJR_P, i, pi);
    get3(v, MJR_P, j, pj);
    for (int k = 0; k < 9; k += 3) {
      get3(v, MJR_R + k, i, Ri + k);
      get3(v, MJR_R + k, j, Rj + k);
    }
    get3(v, MJR_VEL, i, ui);
    get3(v, MJR_VEL, j, uj);
    get3(v, MJR_W, i, wi);
    get3(v, MJR_W, j, wj);
    double axial = 0.0;
    int driven = bond < v->ndriven;
    if (driven) axial = v->voxel_size + v->muscle[2 * bond] * ep + v->muscle[2 * bond + 1] * em;
    double Fsum[3] = {0.0, 0.0, 0.0}, Ti[3] = {0.0, 0.0, 0.0}, Tj[3] = {0.0, 0.0, 0.0};
    for (; t < v->ntendon && v->tendon_bond[t] == bond; t++) {
      const double* oi = v->sites + 6 * t;
      const double* oj = oi + 3;
      double ri[3], rj[3], dv[3], vi[3], vj[3], tmp[3];
      for (int a = 0; a < 3; a++) {
        ri[a] = Ri[3 * a] * oi[0] + Ri[3 * a + 1] * oi[1] + Ri[3 * a + 2] * oi[2];
        rj[a] = Rj[3 * a] * oj[0] + Rj[3 * a + 1] * oj[1] + Rj[3 * a + 2] * oj[2];
      }
      for (int a = 0; a < 3; a++) dv[a] = (pj[a] + rj[a]) - (pi[a] + ri[a]);
      double len = sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
      if (len < 1e-15) continue;
      double inv = 1.0 / len;
      double u[3] = {dv[0] * inv, dv[1] * inv, dv[2] * inv};
      cross(wi, ri, vi);
      cross(wj, rj, vj);
      double rate = 0.0;
      for (int a = 0; a < 3; a++) rate += u[a] * ((uj[a] + vj[a]) - (ui[a] + vi[a]));
      double rest = driven ? sqrt(axial * axial + v->tlat2[t]) : v->trest[t];
      double f = -v->tk[t] * (len - rest) - v->tc[t] * rate;
      double F[3] = {f * u[0], f * u[1], f * u[2]};
      for (int a = 0; a < 3; a++) Fsum[a] += F[a];
      cross(rj, F, tmp);
      for (int a = 0; a < 3; a++) Tj[a] += tmp[a];
      cross(ri, F, tmp);
      for (int a = 0; a < 3; a++) Ti[a] -= tmp[a];
    }
    add3(v, MJR_FORCE, j, 1, Fsum);
    add3(v, MJR_FORCE, i, -1, Fsum);
    add3(v, MJR_TORQUE, j, 1, Tj);
    add3(v, MJR_TORQUE, i, 1, Ti);
  }
}

/* gain = 2 asin(s) / s, s^2 = s2: the series (to 1e-7 for s < 0.3, 35-degree bends) or,
   `exact`, asin above it. The vectorised loop takes the series; beam_bonds redoes the
   bonds past it. */
static inline double rotation_gain(double s2, int exact) {
  double series = 2.0 + s2 * (1.0 / 3.0 + s2 * (0.15 + s2 * (5.0 / 56.0 + s2 * 35.0 / 576.0)));
  if (!exact || s2 < 0.09) return series;
  double sn = sqrt(s2);
  return 2.0 * asin(sn < 1.0 ? sn : 1.0) / sn;
}

/* One beam bond n: its voxels i, j from the scratch rows `vox` (nvox each), its constants
   `c` and outputs `out` (mjrBeams rows of `stride`); `exact` as in rotation_gain. Written
   for the vectoriser: no calls, no branches but selects (the voxels' rows are gathered). */
static inline __attribute__((always_inline)) void beam_bond(
    const double* restrict c, double* restrict out, size_t stride, const double* restrict vox,
    size_t nvox, const int* restrict bonds, size_t n, double L, double ep, double em,
    size_t ndriven, int exact) {
  size_t i = (size_t)bonds[2 * n], j = (size_t)bonds[2 * n + 1];
#define C(row) c[(row) * stride + n]
#define OUT(row) out[(row) * stride + n]
#define VI(row) vox[(size_t)(row) * nvox + i]
#define VJ(row) vox[(size_t)(row) * nvox + j]
  double qi0 = VI(MJR_QUAT), qi1 = VI(MJR_QUAT + 1), qi2 = VI(MJR_QUAT + 2),
         qi3 = VI(MJR_QUAT + 3);
  double qj0 = VJ(MJR_QUAT), qj1 = VJ(MJR_QUAT + 1), qj2 = VJ(MJR_QUAT + 2),
         qj3 = VJ(MJR_QUAT + 3);
  /* r = q_i^-1 q_j on the short way round, its rotation vector Delta = gain rv, its half h */
  double rw = qi0 * qj0 + qi1 * qj1 + qi2 * qj2 + qi3 * qj3;
  double rv0 = qi0 * qj1 - qj0 * qi1 - (qi2 * qj3 - qi3 * qj2);
  double rv1 = qi0 * qj2 - qj0 * qi2 - (qi3 * qj1 - qi1 * qj3);
  double rv2 = qi0 * qj3 - qj0 * qi3 - (qi1 * qj2 - qi2 * qj1);
  int flip = rw < 0.0;
  rw = flip ? -rw : rw;
  rv0 = flip ? -rv0 : rv0;
  rv1 = flip ? -rv1 : rv1;
  rv2 = flip ? -rv2 : rv2;
  double s2 = rv0 * rv0 + rv1 * rv1 + rv2 * rv2;
  OUT(MJR_S2) = s2;
  double gain = rotation_gain(s2, exact);
  double hn = 1.0 / sqrt((1.0 + rw) * (1.0 + rw) + s2);
  double hw = (1.0 + rw) * hn, hv0 = rv0 * hn, hv1 = rv1 * hn, hv2 = rv2 * hn;
  /* mid frame q_m = q_i h as a rotation matrix (mju_quat2Mat) */
  double mw = qi0 * hw - qi1 * hv0 - qi2 * hv1 - qi3 * hv2;
  double mx = qi0 * hv0 + qi1 * hw + qi2 * hv2 - qi3 * hv1;
  double my = qi0 * hv1 + qi2 * hw + qi3 * hv0 - qi1 * hv2;
  double mz = qi0 * hv2 + qi3 * hw + qi1 * hv1 - qi2 * hv0;
  double M0 = mw * mw + mx * mx - my * my - mz * mz;
  double M4 = mw * mw - mx * mx + my * my - mz * mz;
  double M8 = mw * mw - mx * mx - my * my + mz * mz;
  double M1 = 2 * (mx * my - mw * mz);
  double M2 = 2 * (mx * mz + mw * my);
  double M3 = 2 * (mx * my + mw * mz);
  double M5 = 2 * (my * mz - mw * mx);
  double M6 = 2 * (mx * mz - mw * my);
  double M7 = 2 * (my * mz + mw * mx);
  /* p_j - p_i and the mean angular velocity (world) */
  double dw0 = VJ(MJR_P) - VI(MJR_P), dw1 = VJ(MJR_P + 1) - VI(MJR_P + 1),
         dw2 = VJ(MJR_P + 2) - VI(MJR_P + 2);
  double wm0 = 0.5 * (VJ(MJR_W) + VI(MJR_W)), wm1 = 0.5 * (VJ(MJR_W + 1) + VI(MJR_W + 1)),
         wm2 = 0.5 * (VJ(MJR_W + 2) + VI(MJR_W + 2));
  /* velocity of j relative to i as seen in the mid frame: v_j - v_i - w_m x d */
  double uw0 = (VJ(MJR_VEL) - VI(MJR_VEL)) - (wm1 * dw2 - wm2 * dw1);
  double uw1 = (VJ(MJR_VEL + 1) - VI(MJR_VEL + 1)) - (wm2 * dw0 - wm0 * dw2);
  double uw2 = (VJ(MJR_VEL + 2) - VI(MJR_VEL + 2)) - (wm0 * dw1 - wm1 * dw0);
  double ww0 = VJ(MJR_W) - VI(MJR_W), ww1 = VJ(MJR_W + 1) - VI(MJR_W + 1),
         ww2 = VJ(MJR_W + 2) - VI(MJR_W + 2);
  /* into the mid frame: M^T x */
  double d0 = M0 * dw0 + M3 * dw1 + M6 * dw2;
  double d1 = M1 * dw0 + M4 * dw1 + M7 * dw2;
  double d2 = M2 * dw0 + M5 * dw1 + M8 * dw2;
  double dd0 = M0 * uw0 + M3 * uw1 + M6 * uw2;
  double dd1 = M1 * uw0 + M4 * uw1 + M7 * uw2;
  double dd2 = M2 * uw0 + M5 * uw1 + M8 * uw2;
  double dD0 = M0 * ww0 + M3 * ww1 + M6 * ww2;
  double dD1 = M1 * ww0 + M4 * ww1 + M7 * ww2;
  double dD2 = M2 * ww0 + M5 * ww1 + M8 * ww2;
  double axis = C(MJR_AXIS), beta = C(MJR_BETA), bend = C(MJR_BETA_BEND);
  double twist = C(MJR_BETA_TWIST);
  double act = C(MJR_MUSCLE_P) * ep + C(MJR_MUSCLE_M) * em;
  double rest = n < ndriven ? L + act : L;
  int x = axis == 0.0, y = axis == 1.0, z = axis == 2.0;
  double ks = C(MJR_K_SHEAR), kb = C(MJR_K_BEND), kt = C(MJR_K_TWIST);
  double B0 = x ? kt * (gain * rv0 + twist * dD0) : kb * (gain * rv0 + bend * dD0);
  double B1 = y ? kt * (gain * rv1 + twist * dD1) : kb * (gain * rv1 + bend * dD1);
  double B2 = z ? kt * (gain * rv2 + twist * dD2) : kb * (gain * rv2 + bend * dD2);
  /* axial: the law along the axis (kd = 0: linear), l = d[axis]; damping linear */
  double l = x ? d0 : (y ? d1 : d2), dl = x ? dd0 : (y ? dd1 : dd2);
  double lat2 = C(MJR_LAW_LAT2);
  double s_now = sqrt(l * l + lat2), s_rest = sqrt(rest * rest + lat2);
  double axial = -C(MJR_LAW_K0) * (l - rest) - beta * C(MJR_K_AXIAL) * dl;
  double stiffening = C(MJR_LAW_KD) * (s_now - s_rest) * l / s_now;
  axial = s_now > 0.0 ? axial - stiffening : axial;
  double F0 = x ? axial : -ks * (d0 + beta * dd0);
  double F1 = y ? axial : -ks * (d1 + beta * dd1);
  double F2 = z ? axial : -ks * (d2 + beta * dd2);
  /* the transverse force of the moments, damped as the bending */
  double G0 = x ? axial : -ks * (d0 + bend * dd0);
  double G1 = y ? axial : -ks * (d1 + bend * dd1);
  double G2 = z ? axial : -ks * (d2 + bend * dd2);
  /* T_i = -(d x G)/2 + B, T_j = -(d x G)/2 - B */
  double c0 = -0.5 * (d1 * G2 - d2 * G1);
  double c1 = -0.5 * (d2 * G0 - d0 * G2);
  double c2 = -0.5 * (d0 * G1 - d1 * G0);
  double Ti0 = c0 + B0, Ti1 = c1 + B1, Ti2 = c2 + B2;
  double Tj0 = c0 - B0, Tj1 = c1 - B1, Tj2 = c2 - B2;
  /* back to world: M x */
  OUT(MJR_F + 0) = M0 * F0 + M1 * F1 + M2 * F2;
  OUT(MJR_F + 1) = M3 * F0 + M4 * F1 + M5 * F2;
  OUT(MJR_F + 2) = M6 * F0 + M7 * F1 + M8 * F2;
  OUT(MJR_TI + 0) = M0 * Ti0 + M1 * Ti1 + M2 * Ti2;
  OUT(MJR_TI + 1) = M3 * Ti0 + M4 * Ti1 + M5 * Ti2;
  OUT(MJR_TI + 2) = M6 * Ti0 + M7 * Ti1 + M8 * Ti2;
  OUT(MJR_TJ + 0) = M0 * Tj0 + M1 * Tj1 + M2 * Tj2;
  OUT(MJR_TJ + 1) = M3 * Tj0 + M4 * Tj1 + M5 * Tj2;
  OUT(MJR_TJ + 2) = M6 * Tj0 + M7 * Tj1 + M8 * Tj2;
#undef C
#undef OUT
#undef VI
#undef VJ
}

/* Beam bonds: one co-rotated beam element per face bond, with axial k_a, transverse k_s,
   bending k_b and torsion k_t stiffness and dampers beta (force rows), beta_b (bending and
   the transverse force's moment), beta_t (torsion) per stiffness. It works in the bond's mid
   frame M = R_i exp(Delta/2) (symmetric in i and j), with Delta the rotation vector of
   q_i^-1 q_j; there the nodes' rotations are -Delta/2 and +Delta/2, so the symmetric (shear)
   rotation vanishes. With e the bond's rest axis and d = M^T (p_j - p_i):
     transverse (Hookean, like the paper engine's beam):  F_j,perp = -k_s d_perp
     axial: F_j.e = -k0 (l - l0) - kd (s - s0) l / s,  l = d.e, s = sqrt(l^2 + D^2),
        s0 = sqrt(l0^2 + D^2) (kd = 0: the engine's linear spring)
     B = k_b Delta_perp + k_t (Delta.e) e
     F_i = -F_j,  T_i = -(d x G)/2 + B,  T_j = -(d x G)/2 - B,
   G the transverse force F_j,perp damped with beta_b instead of beta; each displacement plus
   its damper times its rate (rates in the frame turning with the mean angular velocity; the
   axial damping linear, beta k_a). Linearised this is the Euler-Bernoulli (k_s = E L) or
   Timoshenko (k_s = G L) beam; with beta_b = beta momentum and angular momentum are
   conserved exactly (T_i + T_j + d x F_j = 0); the paper engine damps its moments with
   half its forces' ratio (beta_b = beta / 2), which does not conserve them.
   Two passes: the arithmetic of all bonds as one vectorised loop (beam_bond), then the
   forces added to the voxels in bond order. */
static void beam_bonds(mjrVoxels* v, double ep, double em) {
  const mjrBeams* b = &v->beam;
  const size_t nb = (size_t)v->nbond, ndriven = (size_t)v->ndriven, stride = b->stride;
  const double L = v->voxel_size;
  const double* restrict c = b->constants;
  double* restrict out = b->outputs;
  const size_t N = (size_t)v->nvox;
  const double* restrict s = v->scratch;
#pragma GCC ivdep /* rows of one block never overlap: no dependence between bonds */
  for (size_t n = 0; n < nb; n++)
    beam_bond(c, out, stride, s, N, v->bonds, n, L, ep, em, ndriven, 0);
  for (size_t n = 0; n < nb; n++) { /* large bends: asin */
    if (out[MJR_S2 * stride + n] >= 0.09)
      beam_bond(c, out, stride, s, N, v->bonds, n, L, ep, em, ndriven, 1);
  }
  /* in bond order; a run of bonds with the same voxel i (its bonds along x, y, z) keeps
     i's sums in registers: the same additions in the same order, fewer memory round trips
     (a bond's j is never its i) */
  double* force = v->scratch + MJR_FORCE * N;
  double* torque = v->scratch + MJR_TORQUE * N;
  const int* bonds = v->bonds;
  size_t n = 0;
  while (n < nb) {
    size_t i = (size_t)bonds[2 * n];
    double fi[3], ti[3];
    for (int a = 0; a < 3; a++) {
      fi[a] = force[a * N + i];
      ti[a] = torque[a * N + i];
    }
    for (; n < nb && (size_t)bonds[2 * n] == i; n++) {
      size_t j = (size_t)bonds[2 * n + 1];
      for (int a = 0; a < 3; a++) {
        force[a * N + j] += out[(MJR_F + a) * stride + n];
        fi[a] -= out[(MJR_F + a) * stride + n];
        ti[a] += out[(MJR_TI + a) * stride + n];
        torque[a * N + j] += out[(MJR_TJ + a) * stride + n];
      }
    }
    for (int a = 0; a < 3; a++) {
      force[a * N + i] = fi[a];
      torque[a * N + i] = ti[a];
    }
  }
}

/* Drag on every voxel (the paper engine's "slow" damping): -drag_lin v on the centre and
   -drag_rot w on the rotation, each voxel its own coefficients. A welded voxel's velocities
   are 0. */
static void voxel_drag(mjrVoxels* v) {
  const size_t N = (size_t)v->nvox;
  double* restrict s = v->scratch;
  const double* restrict lin = v->drag_lin;
  const double* restrict rot = v->drag_rot;
  for (int a = 0; a < 3; a++) {
#pragma GCC ivdep /* rows never overlap */
    for (size_t n = 0; n < N; n++) {
      s[(MJR_FORCE + a) * N + n] -= lin[n] * s[(MJR_VEL + a) * N + n];
      s[(MJR_TORQUE + a) * N + n] -= rot[n] * s[(MJR_W + a) * N + n];
    }
  }
}

static inline int never_collide(const mjrVoxels* v, size_t i, size_t j) {
  size_t k = i * (size_t)v->nvox + j;
  return (v->coll_near[k >> 3] >> (k & 7)) & 1;
}

/* Self-collision as the paper engine: colliding (surface) voxels that are not near each other
   (`never_colliding`) repel as spheres of radius coll_radius times their current linear
   scale (muscle strain), with a penalty spring and damper along the centre line, each the
   harmonic mean of the two voxels' collision constants; repulsion only, no friction, no
   moment. Candidates come from a
   Verlet list rebuilt whenever a voxel has moved more than half the skin since the last
   build, so no touching pair is ever missed (a cache: the forces do not depend on it). */
static void self_collision(mjrVoxels* v, double ep, double em) {
  int n = v->nvox;
  double half_skin2 = 0.25 * v->coll_skin * v->coll_skin;
  int rebuild = !v->coll_built;
  for (int i = 0; i < n && !rebuild; i++) {
    if (!v->collides[i]) continue;
    double p[3];
    get3(v, MJR_P, i, p);
    const double* r = v->coll_ref + 3 * i;
    double dx = p[0] - r[0], dy = p[1] - r[1], dz = p[2] - r[2];
    if (dx * dx + dy * dy + dz * dz > half_skin2) rebuild = 1;
  }
  if (rebuild) {
    double cut = v->coll_reach + v->coll_skin, cut2 = cut * cut;
    int found = 0;
    for (int i = 0; i < n; i++) {
      if (!v->collides[i]) continue;
      double pi[3], pj[3];
      get3(v, MJR_P, i, pi);
      for (int j = i + 1; j < n; j++) {
        if (!v->collides[j] || never_collide(v, (size_t)i, (size_t)j)) continue;
        get3(v, MJR_P, j, pj);
        double dx = pj[0] - pi[0], dy = pj[1] - pi[1], dz = pj[2] - pi[2];
        if (dx * dx + dy * dy + dz * dz < cut2) {
          v->coll_pairs[2 * found] = i;
          v->coll_pairs[2 * found + 1] = j;
          found++;
        }
      }
    }
    for (int i = 0; i < n; i++) get3(v, MJR_P, i, v->coll_ref + 3 * i);
    v->coll_count = found;
    v->coll_built = 1;
  }
  double two_over_l = 2.0 / v->voxel_size;
  for (int k = 0; k < v->coll_count; k++) {
    int i = v->coll_pairs[2 * k], j = v->coll_pairs[2 * k + 1];
    double pi[3], pj[3], vi[3], vj[3];
    get3(v, MJR_P, i, pi);
    get3(v, MJR_P, j, pj);
    double d[3] = {pj[0] - pi[0], pj[1] - pi[1], pj[2] - pi[2]};
    double dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double scale_i = 1.0 + two_over_l * (v->half_p[i] * ep + v->half_m[i] * em);
    double scale_j = 1.0 + two_over_l * (v->half_p[j] * ep + v->half_m[j] * em);
    double contact = v->coll_radius * (scale_i + scale_j);
    if (dist2 >= contact * contact || dist2 <= 0.0) continue;
    double dist = sqrt(dist2);
    double u[3] = {d[0] / dist, d[1] / dist, d[2] / dist};
    double closing = 0.0;
    get3(v, MJR_VEL, i, vi);
    get3(v, MJR_VEL, j, vj);
    for (int a = 0; a < 3; a++) closing += u[a] * (vj[a] - vi[a]);
    double k_pair = 2.0 / (1.0 / v->ck[i] + 1.0 / v->ck[j]);
    double c_pair = v->cc[i] > 0.0 && v->cc[j] > 0.0
                        ? 2.0 / (1.0 / v->cc[i] + 1.0 / v->cc[j]) : 0.0;
    double f = k_pair * (contact - dist) - c_pair * closing;
    if (f <= 0.0) continue;
    double push[3] = {f * u[0], f * u[1], f * u[2]};
    add3(v, MJR_FORCE, j, 1, push);
    add3(v, MJR_FORCE, i, -1, push);
  }
}

/* m/s: a sticking voxel's horizontal speed is zeroed every step (to ~1e-20); faster means an
   outside impulse (someone wrote qvel), which releases it */
#define KICKED 1e-9

/* The paper engine's floor (evosoro's Voxelyze, CVXS_Voxel::CalcFloorEffect). Per voxel
   touching the floor (centre below its current half size, which shrinks with the voxel's
   own muscle strain): normal force k pen - c vz on the centre (no moment; the damper may
   pull); friction from the spring part N = k pen. A voxel at rest (stuck at the last step,
   or, with the momentum rule, with no horizontal velocity at all) stays put (its horizontal
   velocity is cancelled within the step) until the other horizontal forces exceed mu_s N,
   and then moves without friction for that step; a sliding one feels mu_k N against its
   horizontal velocity, and sticks when the step would stop it: friction_momentum, the
   engine's test, when the friction impulse mu_k N t reaches its momentum m |v| (t the step,
   or stop_time: then the rule does not depend on the step); else when the step's friction
   work would exceed its kinetic energy. The other horizontal forces:
   bonds, drag and self-collision (in scratch), MuJoCo's own passive forces, qfrc_applied,
   xfrc_applied and gravity (a voxel's centre of mass is at its joint, so no other bias
   force acts on its translation). */
static void engine_floor(const mjModel* m, const mjData* d, mjrVoxels* v, const double* stick,
                         double ep, double em) {
  int planar = v->dim == 3;
  const double* gravity = m->opt.gravity;
  double dt = m->opt.timestep;
  const size_t N = (size_t)v->nvox;
  for (int n = 0; n < v->nvox; n++) {
    int va = v->vadr[n];
    if (va < 0) continue;
    double* next = v->stick_next + n;
    double half = 0.5 * v->voxel_size + v->half_p[n] * ep + v->half_m[n] * em;
    double pen = half - ROW(v, MJR_P + 2)[n];
    if (pen < 0.0) {
      *next = 0.0;
      continue;
    }
    const double* vel = ROW(v, MJR_VEL) + n; /* rows: vel[a * N] */
    double* F = ROW(v, MJR_FORCE) + n;
    const double* xfrc = d->xfrc_applied + 6 * v->body[n];
    double normal = v->fk[n] * pen;
    F[2 * N] += normal - v->fc[n] * vel[2 * N];
    double mass = m->body_mass[v->body[n]];
    double other[2] = {F[0] + d->qfrc_passive[va] + d->qfrc_applied[va] + xfrc[0]
                         + mass * gravity[0],
                       planar ? F[N] + d->qfrc_passive[va + 1] + d->qfrc_applied[va + 1]
                                  + xfrc[1] + mass * gravity[1] : 0.0};
    double vh[2] = {vel[0], planar ? vel[N] : 0.0};
    double stop[2] = {-other[0] - mass * vh[0] / dt, -other[1] - mass * vh[1] / dt};
    double speed2 = vh[0] * vh[0] + vh[1] * vh[1];
    int sticking = (stick[n] != 0.0 && speed2 <= KICKED * KICKED)
                   || (v->friction_momentum && speed2 == 0.0);
    if (sticking) {
      double limit = v->mu_s[n] * normal;
      if (other[0] * other[0] + other[1] * other[1] > limit * limit) {
        *next = 0.0; /* breaks loose: this step's forces start the motion, no friction */
      } else {
        *next = 1.0;
        F[0] += stop[0];
        F[N] += stop[1];
      }
      continue;
    }
    double speed = sqrt(speed2);
    double fric[2] = {0.0, 0.0};
    if (speed > 0.0) {
      fric[0] = -v->mu_k[n] * normal * vh[0] / speed;
      fric[1] = -v->mu_k[n] * normal * vh[1] / speed;
    }
    int stops;
    if (v->friction_momentum) { /* the friction impulse over t would take all its momentum */
      stops = v->mu_k[n] * normal * (v->stop_time > 0.0 ? v->stop_time : dt) >= mass * speed;
    } else { /* momentum after this step; its friction work would take all the energy */
      double p0 = mass * vh[0] + dt * (other[0] + fric[0]);
      double p1 = mass * vh[1] + dt * (other[1] + fric[1]);
      double work = (fric[0] * p0 + fric[1] * p1) * dt / mass;
      stops = 0.5 * (p0 * p0 + p1 * p1) / mass + work <= 0.0;
    }
    if (stops) {
      *next = 1.0;
      F[0] += stop[0];
      F[N] += stop[1];
    } else {
      *next = 0.0;
      F[0] += fric[0];
      F[N] += fric[1];
    }
  }
}

void mjr_voxel_forces(const mjModel* m, mjData* d, mjrVoxels* v, const mjtNum* stick,
                      int network) {
  voxel_states(v);
  double ep = 0.0, em = 0.0;
  if (v->waves && !network) {
    if (v->ctrl_plus >= 0) {
      ep = d->ctrl[v->ctrl_plus];
      em = d->ctrl[v->ctrl_minus];
    } else {
      double dt = m->opt.timestep;
      strains(v, floor(d->time / dt + 0.5) * dt, &ep, &em);
    }
  }
  memcpy(v->stick_next, stick, v->nvox * sizeof(double));
  if (v->beams) {
    beam_bonds(v, ep, em);
  } else {
    tendon_bonds(v, ep, em);
  }
  if (!network) {
    if (v->drag) voxel_drag(v);
    if (v->collide) self_collision(v, ep, em);
    if (v->floor) engine_floor(m, d, v, stick, ep, em);
  }
}

void mjr_forces(const mjModel* m, mjData* d, mjrVoxels* v, const mjtNum* stick, int network) {
  mjr_load_state(v, d);
  mjr_voxel_forces(m, d, v, stick, network);
  double* qfrc = d->qfrc_passive;
  for (int n = 0; n < v->nvox; n++) {
    int va = v->vadr[n];
    if (va < 0) continue;
    double g[6];
    int dofs = mjr_generalized(v->scratch, (size_t)v->nvox, (size_t)n, v->dim == 3, g);
    for (int k = 0; k < dofs; k++) qfrc[va + k] += g[k];
  }
}
