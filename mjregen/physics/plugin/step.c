/* The fast path of mj_step for a robot of free voxel bodies whose every force comes from the
   mjregen.voxels plugin: MuJoCo's semi-implicit Euler step without its generic multibody
   pipeline.

   For bodies whose centre of mass is at their joint, with isotropic inertia, no parent but the
   world, no joint damping, armature, actuators, tendons, constraints or fluid forces (the
   Python side checks all of this against the model and against MuJoCo's own mass matrix and
   gravity force: `mjregen.physics.stepper`), MuJoCo's equations reduce to a constant
   diagonal mass matrix and a constant generalized gravity force:

     qacc = (qfrc_passive + qfrc_applied + gravity) / M_ii   (M_ii: mass or inertia)
     qvel += dt qacc;  qpos += dt qvel (free joints: the normalized quaternion times
     exp(dt w / 2), w in the body frame)

   which this loop does in mj_step's order (forward at the start state: the plugin's forces;
   then mj_Euler's advance: velocities, positions, time, the plugin's state; a robot held at
   rest in the settle, `settle_rest`, is not stepped: time alone advances). The result
   equals mj_step's to rounding; the generic pipeline (kinematics, composite inertia,
   factorisation, RNE) is skipped, about half of a step's cost. Like mj_step it stops on a
   bad acceleration or velocity (NaN or above 1e10) and records MuJoCo's warning (the bad
   step is not taken). Every body but the world must be one of the plugin's voxels. During
   a call the state lives in the plugin's rows (voxels.h), so that the per-voxel loops
   vectorise; qpos, qvel, qacc and qfrc_passive are written at the end. Derived quantities
   (xpos, subtree_com, ...) are not updated: call mj_kinematics after stepping.
*/
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "voxels.h"

#define MAXVAL 1e10 /* mjMAXVAL: MuJoCo's bad-value bound */

static inline int bad_value(double x) {
  return isnan(x) || fabs(x) > MAXVAL;
}

static void warn(mjData* d, int warning, int info) {
  d->warning[warning].lastinfo = info;
  d->warning[warning].number++;
}

/* centre of mass of all bodies but the world: welded bodies at body_pos, free joints at
   their qpos, planar voxels (slide x, slide z, hinge y) at body_pos + (q0, 0, q1) */
static void centre_of_mass(const mjModel* m, const mjData* d, double total, double* out) {
  double c[3] = {0.0, 0.0, 0.0};
  for (int b = 1; b < m->nbody; b++) {
    const double* p0 = m->body_pos + 3 * b;
    double p[3] = {p0[0], p0[1], p0[2]};
    if (m->body_jntnum[b] > 0) {
      int j = m->body_jntadr[b];
      const double* q = d->qpos + m->jnt_qposadr[j];
      if (m->jnt_type[j] == mjJNT_FREE) {
        p[0] = q[0];
        p[1] = q[1];
        p[2] = q[2];
      } else {
        p[0] += q[0];
        p[2] += q[1];
      }
    }
    double w = m->body_mass[b] / total;
    for (int a = 0; a < 3; a++) c[a] += w * p[a];
  }
  memcpy(out, c, 3 * sizeof(double));
}

/* MuJoCo's mju_quatIntegrate for voxel n of the state rows: quat <- normalize(quat) *
   exp(scale w / 2), w in the body frame. `exact`: sin and cos at any angle; else their series,
   exact to rounding for a half turn below 0.05 rad (next terms < 1e-20), and where it is
   larger the quaternion is left as it was and `*large` set (the caller redoes the voxel
   exactly). Written for the vectoriser: selects, no branches. */
static inline __attribute__((always_inline)) void quat_integrate(
    double* restrict q, const double* restrict w, size_t N, size_t n, double scale, int exact,
    double* large) {
  double w0 = w[n], w1 = w[N + n], w2 = w[2 * N + n];
  double norm = sqrt(w0 * w0 + w1 * w1 + w2 * w2);
  int turning = norm >= mjMINVAL;
  double a0 = turning ? w0 / norm : 1.0;
  double a1 = turning ? w1 / norm : 0.0;
  double a2 = turning ? w2 / norm : 0.0;
  double half = 0.5 * scale * norm;
  double x2 = half * half;
  double sn = half * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
  double cs = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0
                                                                     * (1.0 - x2 / 90.0))));
  int keep = 0; /* a large turn in the series pass: the voxel keeps its quaternion */
  if (exact) {
    sn = sin(half);
    cs = cos(half);
  } else {
    keep = fabs(half) >= 0.05;
    *large = keep ? 1.0 : 0.0;
  }
  int moved = half != 0.0;
  double r0 = moved ? cs : 1.0, r1 = moved ? a0 * sn : 0.0, r2 = moved ? a1 * sn : 0.0,
         r3 = moved ? a2 * sn : 0.0;
  double o0 = q[n], o1 = q[N + n], o2 = q[2 * N + n], o3 = q[3 * N + n];
  double q0 = o0, q1 = o1, q2 = o2, q3 = o3;
  double len = sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3);
  int zero = len < mjMINVAL, off = fabs(len - 1.0) > mjMINVAL;
  q0 = zero ? 1.0 : (off ? q0 / len : q0);
  q1 = zero ? 0.0 : (off ? q1 / len : q1);
  q2 = zero ? 0.0 : (off ? q2 / len : q2);
  q3 = zero ? 0.0 : (off ? q3 / len : q3);
  q[n] = keep ? o0 : q0 * r0 - q1 * r1 - q2 * r2 - q3 * r3;
  q[N + n] = keep ? o1 : q0 * r1 + q1 * r0 + q2 * r3 - q3 * r2;
  q[2 * N + n] = keep ? o2 : q0 * r2 - q1 * r3 + q2 * r0 + q3 * r1;
  q[3 * N + n] = keep ? o3 : q0 * r3 + q1 * r2 - q2 * r1 + q3 * r0;
}

/* The mass matrix's diagonal (inverted) and the gravity force from the model's current
   masses, inertias, gravity and joint axes. */
void mjr_step_masses(const mjModel* m, double* inv_mass, double* gravity) {
  const double* g = m->opt.gravity;
  int on = !(m->opt.disableflags & mjDSBL_GRAVITY);
  for (int j = 0; j < m->njnt; j++) {
    int body = m->jnt_bodyid[j], dof = m->jnt_dofadr[j];
    double mass = m->body_mass[body];
    const double* inertia = m->body_inertia + 3 * body;
    const double* axis = m->jnt_axis + 3 * j;
    switch (m->jnt_type[j]) {
      case mjJNT_FREE:
        for (int a = 0; a < 3; a++) {
          inv_mass[dof + a] = 1.0 / mass;
          gravity[dof + a] = on ? mass * g[a] : 0.0;
          inv_mass[dof + 3 + a] = 1.0 / inertia[a];
          gravity[dof + 3 + a] = 0.0;
        }
        break;
      case mjJNT_BALL:
        for (int a = 0; a < 3; a++) {
          inv_mass[dof + a] = 1.0 / inertia[a];
          gravity[dof + a] = 0.0;
        }
        break;
      case mjJNT_SLIDE:
        inv_mass[dof] = 1.0 / mass;
        gravity[dof] = on ? mass * (g[0] * axis[0] + g[1] * axis[1] + g[2] * axis[2]) : 0.0;
        break;
      default: /* hinge through the centre of mass */
        inv_mass[dof] = 1.0 / (inertia[0] * axis[0] * axis[0] + inertia[1] * axis[1] * axis[1]
                               + inertia[2] * axis[2] * axis[2]);
        gravity[dof] = 0.0;
    }
  }
}

/* Every body but the world is one of the plugin's voxels, with a voxel's joints only? */
static int voxels_cover_model(const mjModel* m, const mjrVoxels* v) {
  int moving = 0, dofs = v->dim == 3 ? 6 : 3, joints = v->dim == 3 ? 1 : 3;
  for (int n = 0; n < v->nvox; n++) moving += v->vadr[n] >= 0;
  return v->nvox == m->nbody - 1 && moving * dofs == m->nv && moving * joints == m->njnt;
}

/* One step's velocities from the forces in the scratch rows: acc = (0 + qfrc + applied +
   gravity) (1 / M_ii), vel' = vel + dt acc, per voxel dof as in mj_step's order of operations;
   into the rows `acc` and `vel` (nd rows each). Returns the first dof (in the model's
   order) whose acceleration or new velocity is bad, with *which the warning, or -1. */
static int velocities(const mjrVoxels* v, const double* restrict per_dof, double dt,
                      double* restrict generalized, double* restrict acc, double* restrict vel,
                      int* which) {
  const size_t N = (size_t)v->nvox;
  const int three = v->dim == 3, nd = three ? 6 : 3;
  const double* restrict s = v->scratch;
  const double* restrict old = v->state + MJR_QVEL * N;
  /* generalized forces, added to mj_step's zeroed qfrc_passive (0 + g, as there); one loop
     per dimension, so that each vectorises */
  if (three) {
#pragma GCC ivdep
    for (size_t n = 0; n < N; n++) {
      double g[6];
      mjr_generalized(s, N, n, 1, g);
      for (int k = 0; k < 6; k++) generalized[k * N + n] = 0.0 + g[k];
    }
  } else {
#pragma GCC ivdep
    for (size_t n = 0; n < N; n++) {
      double g[6];
      mjr_generalized(s, N, n, 0, g);
      for (int k = 0; k < 3; k++) generalized[k * N + n] = 0.0 + g[k];
    }
  }
  /* per_dof rows: applied (nd), gravity (nd), 1 / M_ii (nd) */
  double bad = 0.0;
  for (int k = 0; k < nd; k++) {
    const double* applied = per_dof + k * N;
    const double* gravity = per_dof + (nd + k) * N;
    const double* inverse = per_dof + (2 * nd + k) * N;
#pragma GCC ivdep
    for (size_t n = 0; n < N; n++) {
      double a = (generalized[k * N + n] + applied[n] + gravity[n]) * inverse[n];
      double u = old[k * N + n] + dt * a;
      acc[k * N + n] = a;
      vel[k * N + n] = u;
      bad += (isnan(a) || fabs(a) > MAXVAL || isnan(u) || fabs(u) > MAXVAL) ? 1.0 : 0.0;
    }
  }
  if (bad == 0.0) return -1;
  int first = -1;
  for (int n = 0; n < v->nvox; n++) {
    if (v->vadr[n] < 0) continue;
    for (int k = 0; k < nd; k++) {
      int dof = v->vadr[n] + k;
      int bad_acc = bad_value(acc[k * N + n]), bad_vel = bad_value(vel[k * N + n]);
      if ((bad_acc || bad_vel) && (first < 0 || dof < first)) {
        first = dof;
        *which = bad_acc ? mjWARN_BADQACC : mjWARN_BADQVEL;
      }
    }
  }
  return first;
}

/* Advance nstep steps of the model whose plugin `instance` is mjregen.voxels; com (nstep, 3)
   or NULL receives the centre of mass at the start of each step. The state lives in the
   plugin's rows during the call (d's qpos, qvel, qacc and qfrc_passive are written at the
   end). Returns the number of steps completed (< nstep after a bad value: that step is not
   taken), -1 if `instance` is not the voxel plugin, -2 if the model has bodies or joints
   other than the plugin's voxels. */
int mjr_step(const mjModel* m, mjData* d, int instance, int nstep, double* com) {
  mjrVoxels* v = mjr_instance(m, d, instance);
  if (!v) return -1;
  if (!voxels_cover_model(m, v)) return -2;
  if (nstep <= 0) return 0;
  const size_t N = (size_t)v->nvox;
  const int nv = m->nv, three = v->dim == 3, nd = three ? 6 : 3;
  const double dt = m->opt.timestep;
  double* inv_mass = (double*)malloc((nv + 1) * sizeof(double));
  double* gravity = (double*)malloc((nv + 1) * sizeof(double));
  /* rows: applied, gravity, 1 / M_ii (nd each), generalized force, acc, vel (nd each), large */
  double* work = (double*)calloc((size_t)(6 * nd + 1) * N, sizeof(double));
  double *per_dof = work, *generalized = work + 3 * nd * N, *acc = work + 4 * nd * N,
         *vel = work + 5 * nd * N, *large = work + 6 * nd * N;
  mjr_step_masses(m, inv_mass, gravity); /* the caller may have changed them between calls */
  for (size_t n = 0; n < N; n++) {
    int va = v->vadr[n];
    for (int k = 0; k < nd; k++) { /* welded voxels: no force, no mass: stay */
      per_dof[k * N + n] = va < 0 ? 0.0 : d->qfrc_applied[va + k];
      per_dof[(nd + k) * N + n] = va < 0 ? 0.0 : gravity[va + k];
      per_dof[(2 * nd + k) * N + n] = va < 0 ? 0.0 : inv_mass[va + k];
    }
  }
  double total = 0.0;
  for (int b = 1; b < m->nbody; b++) total += m->body_mass[b];
  if (total <= 0.0) total = 1e-300;
  mjtNum* stick = d->plugin_state + m->plugin_stateadr[instance];
  double* q = v->state + MJR_QPOS * N;
  double* w = v->state + MJR_QVEL * N;
  mjr_load_state(v, d);
  memset(d->qfrc_passive, 0, nv * sizeof(double)); /* MuJoCo's own passive forces: none */
  int done = 0, held = 0;
  for (; done < nstep; done++) {
    if (com) {
      mjr_store_state(v, d);
      centre_of_mass(m, d, total, com + 3 * done);
    }
    held = mjr_holding(m, d, v, stick);
    if (held) { /* at rest until the muscles start: mj_step's step undone (voxels.c) */
      d->time += dt;
      continue;
    }
    mjr_voxel_forces(m, d, v, stick, 0);
    int which = 0;
    int failed = velocities(v, per_dof, dt, generalized, acc, vel, &which);
    if (failed >= 0) {
      warn(d, which, failed);
      break;
    }
    for (size_t n = 0; n < N; n++) { /* welded voxels keep their zero velocity */
      if (v->vadr[n] < 0) continue;
      for (int k = 0; k < nd; k++) w[k * N + n] = vel[k * N + n];
    }
    if (three) {
#pragma GCC ivdep
      for (size_t n = 0; n < N; n++) {
        for (int a = 0; a < 3; a++) q[a * N + n] += dt * w[a * N + n];
        quat_integrate(q + 3 * N, w + 3 * N, N, n, dt, 0, large + n);
      }
      for (size_t n = 0; n < N; n++) {
        if (large[n] != 0.0) { /* turned too far for the series: sin and cos */
          quat_integrate(q + 3 * N, w + 3 * N, N, n, dt, 1, NULL);
        }
      }
    } else {
      for (int k = 0; k < 3; k++) {
#pragma GCC ivdep
        for (size_t n = 0; n < N; n++) q[k * N + n] += dt * w[k * N + n];
      }
    }
    d->time += dt;
    memcpy(stick, v->stick_next, N * sizeof(mjtNum)); /* the plugin's advance */
    mjr_settle_rest(m, d, v, stick);
  }
  mjr_store_state(v, d);
  { /* the last (or the failed) step's forces and accelerations; a held step's: no force,
       gravity's (and the applied forces') acceleration, as mj_step computes it */
    for (size_t n = 0; n < N; n++) {
      int va = v->vadr[n];
      if (va < 0) continue;
      for (int k = 0; k < nd; k++) {
        double applied = per_dof[k * N + n], weight = per_dof[(nd + k) * N + n];
        d->qfrc_passive[va + k] = held ? 0.0 : generalized[k * N + n];
        d->qacc[va + k] = held ? (0.0 + applied + weight) * per_dof[(2 * nd + k) * N + n]
                               : acc[k * N + n];
      }
    }
  }
  free(inv_mass);
  free(gravity);
  free(work);
  return done;
}
