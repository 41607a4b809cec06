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
   then mj_Euler's advance: velocities, positions, time, the plugin's state). The result
   equals mj_step's to rounding; the generic pipeline (kinematics, composite inertia,
   factorisation, RNE) is skipped, about half of a step's cost. Like mj_step it stops on a
   bad acceleration or velocity (NaN or above 1e10) and records MuJoCo's warning. Derived
   quantities (xpos, subtree_com, ...) are not updated: call mj_kinematics after stepping.
*/
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "voxels.h"

#define MAXVAL 1e10 /* mjMAXVAL: MuJoCo's bad-value bound */

static inline int bad(double x) {
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

/* MuJoCo's mju_quatIntegrate: quat <- normalize(quat) * exp(scale w / 2), w in the body frame */
static void quat_integrate(double* q, const double* w, double scale) {
  double norm = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  double axis[3] = {1.0, 0.0, 0.0};
  if (norm >= mjMINVAL) {
    axis[0] = w[0] / norm;
    axis[1] = w[1] / norm;
    axis[2] = w[2] / norm;
  }
  double half = 0.5 * scale * norm, r[4] = {1.0, 0.0, 0.0, 0.0};
  if (half != 0.0) {
    double sn, cs;
    if (fabs(half) < 0.05) {
      /* a step's turn is tiny: Taylor series, exact to rounding here (next terms < 1e-20) */
      double x2 = half * half;
      sn = half * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
      cs = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0
                                                                   * (1.0 - x2 / 90.0))));
    } else {
      sn = sin(half);
      cs = cos(half);
    }
    r[0] = cs;
    r[1] = axis[0] * sn;
    r[2] = axis[1] * sn;
    r[3] = axis[2] * sn;
  }
  double len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (len < mjMINVAL) {
    q[0] = 1.0;
    q[1] = q[2] = q[3] = 0.0;
  } else if (fabs(len - 1.0) > mjMINVAL) {
    for (int a = 0; a < 4; a++) q[a] /= len;
  }
  double p[4] = {
    q[0] * r[0] - q[1] * r[1] - q[2] * r[2] - q[3] * r[3],
    q[0] * r[1] + q[1] * r[0] + q[2] * r[3] - q[3] * r[2],
    q[0] * r[2] - q[1] * r[3] + q[2] * r[0] + q[3] * r[1],
    q[0] * r[3] + q[1] * r[2] - q[2] * r[1] + q[3] * r[0],
  };
  memcpy(q, p, 4 * sizeof(double));
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

/* Advance nstep steps of the model whose plugin `instance` is mjregen.voxels; com (nstep, 3)
   or NULL receives the centre of mass at the start of each step. Returns the number of steps
   completed (< nstep after a bad value), or -1 if `instance` is not the voxel plugin. */
int mjr_step(const mjModel* m, mjData* d, int instance, int nstep, double* com) {
  mjrVoxels* v = mjr_instance(m, d, instance);
  if (!v) return -1;
  const int nv = m->nv;
  const double dt = m->opt.timestep;
  double* inv_mass = (double*)malloc((nv + 1) * sizeof(double));
  double* gravity = (double*)malloc((nv + 1) * sizeof(double));
  mjr_step_masses(m, inv_mass, gravity); /* the caller may have changed them between calls */
  double total = 0.0;
  for (int b = 1; b < m->nbody; b++) total += m->body_mass[b];
  if (total <= 0.0) total = 1e-300;
  mjtNum* stick = d->plugin_state + m->plugin_stateadr[instance];
  int done = 0;
  for (; done < nstep; done++) {
    if (com) centre_of_mass(m, d, total, com + 3 * done);
    memset(d->qfrc_passive, 0, nv * sizeof(double));
    mjr_forces(m, d, v, stick, 0);
    int failed = 0;
    for (int i = 0; i < nv; i++) {
      double acc = (d->qfrc_passive[i] + d->qfrc_applied[i] + gravity[i]) * inv_mass[i];
      if (bad(acc)) {
        warn(d, mjWARN_BADQACC, i);
        failed = 1;
        break;
      }
      d->qacc[i] = acc;
      d->qvel[i] += dt * acc;
      if (bad(d->qvel[i])) {
        warn(d, mjWARN_BADQVEL, i);
        failed = 1;
        break;
      }
    }
    if (failed) break;
    for (int j = 0; j < m->njnt; j++) {
      double* q = d->qpos + m->jnt_qposadr[j];
      const double* w = d->qvel + m->jnt_dofadr[j];
      switch (m->jnt_type[j]) {
        case mjJNT_FREE:
          q[0] += dt * w[0];
          q[1] += dt * w[1];
          q[2] += dt * w[2];
          quat_integrate(q + 3, w + 3, dt);
          break;
        case mjJNT_BALL:
          quat_integrate(q, w, dt);
          break;
        default:
          q[0] += dt * w[0];
      }
    }
    d->time += dt;
    mjr_advance(m, d, instance);
  }
  free(inv_mass);
  free(gravity);
  return done;
}
