/* mjregen native stepper: MuJoCo's semi-implicit Euler step for a robot of free voxel bodies,
   without MuJoCo's generic multibody pipeline.

   With native bonds and the engine's contacts (bonds.c) every force on a voxel is computed
   in `mjr_passive`; MuJoCo's step then only integrates independent rigid bodies. For bodies
   whose centre of mass is at their joint, with isotropic inertia, no parent but the world,
   no joint damping, armature, actuators, constraints or fluid forces (the Python side checks
   all of this: `mjregen.stepping`), MuJoCo's equations reduce to a constant diagonal mass
   matrix and a constant generalized gravity force:

     qacc = (qfrc_passive + qfrc_applied + gravity) / M_ii   (M_ii: mass or inertia)
     qvel += dt qacc;  qpos += dt qvel (free/ball joints: the normalized quaternion times
     exp(dt w / 2), w in the body frame)

   which is what this loop does, in MuJoCo's order (mj_step: forward at the start state,
   then mj_Euler). The result equals mj_step's to rounding (tests/test_stepping.py); the
   generic pipeline (kinematics, composite inertia, factorisation, RNE) is skipped, about
   half of a step's cost. Like mj_step it stops on a bad acceleration or velocity (NaN or
   above 1e10) and records MuJoCo's warning in d->warning. Derived quantities (xpos,
   subtree_com, ...) are not updated: call mj_kinematics after stepping (not mj_forward: it
   would run the passive callback, whose floor keeps a stick state that only steps advance).
*/
#include <math.h>
#include <string.h>

#include <mujoco/mujoco.h>

void mjr_passive(const mjModel* m, mjData* d); /* bonds.c */

typedef struct {
  int nv;
  double* inv_mass;         /* (nv) 1 / M_ii, 1/kg or 1/(kg m^2) (mjr_step_refresh) */
  double* gravity;          /* (nv) generalized gravity force, N or N m (mjr_step_refresh) */
  int ncom;                 /* bodies in the centre of mass */
  const int* com_kind;      /* (ncom) 0 fixed at com_pos0, 1 free joint (position at
                               qpos[com_qadr]), 2 planar (com_pos0 + (q0, 0, q1)) */
  const int* com_qadr;      /* (ncom) */
  const double* com_pos0;   /* (ncom, 3) m */
  const double* com_mass;   /* (ncom) kg / total mass */
} mjrStepper;

#define MAXVAL 1e10 /* mjMAXVAL: MuJoCo's bad-value bound */

static inline int bad(double x) {
  return isnan(x) || fabs(x) > MAXVAL;
}

static void warn(mjData* d, int warning, int info) {
  d->warning[warning].lastinfo = info;
  d->warning[warning].number++;
}

static void centre_of_mass(const mjrStepper* s, const mjData* d, double* out) {
  double c[3] = {0.0, 0.0, 0.0};
  for (int b = 0; b < s->ncom; b++) {
    const double* p0 = s->com_pos0 + 3 * b;
    const double* q = d->qpos + s->com_qadr[b];
    double p[3] = {p0[0], p0[1], p0[2]};
    if (s->com_kind[b] == 1) {
      p[0] = q[0];
      p[1] = q[1];
      p[2] = q[2];
    } else if (s->com_kind[b] == 2) {
      p[0] += q[0];
      p[2] += q[1];
    }
    for (int a = 0; a < 3; a++) c[a] += s->com_mass[b] * p[a];
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

/* The mass matrix's diagonal and the gravity force from the model's current masses,
   inertias, gravity and joint axes (bodies in their rest orientation: `mjregen.stepping`
   checks that these equal MuJoCo's own M and qfrc_bias). */
void mjr_step_refresh(const mjModel* m, const mjrStepper* s) {
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
          s->inv_mass[dof + a] = 1.0 / mass;
          s->gravity[dof + a] = on ? mass * g[a] : 0.0;
          s->inv_mass[dof + 3 + a] = 1.0 / inertia[a];
          s->gravity[dof + 3 + a] = 0.0;
        }
        break;
      case mjJNT_BALL:
        for (int a = 0; a < 3; a++) {
          s->inv_mass[dof + a] = 1.0 / inertia[a];
          s->gravity[dof + a] = 0.0;
        }
        break;
      case mjJNT_SLIDE:
        s->inv_mass[dof] = 1.0 / mass;
        s->gravity[dof] = on ? mass * (g[0] * axis[0] + g[1] * axis[1] + g[2] * axis[2]) : 0.0;
        break;
      default: /* hinge through the centre of mass */
        s->inv_mass[dof] = 1.0 / (inertia[0] * axis[0] * axis[0] + inertia[1] * axis[1] * axis[1]
                                  + inertia[2] * axis[2] * axis[2]);
        s->gravity[dof] = 0.0;
    }
  }
}

/* Advance nstep steps; com (nstep, 3) or NULL receives the centre of mass at the start of
   each step. Returns the number of steps completed (< nstep after a bad value). */
int mjr_step(const mjModel* m, mjData* d, const mjrStepper* s, int nstep, double* com) {
  const int nv = s->nv;
  const double dt = m->opt.timestep;
  mjr_step_refresh(m, s); /* the caller may have changed gravity, masses or the step */
  for (int k = 0; k < nstep; k++) {
    if (com) centre_of_mass(s, d, com + 3 * k);
    memset(d->qfrc_passive, 0, nv * sizeof(double));
    mjr_passive(m, d);
    for (int i = 0; i < nv; i++) {
      double acc = (d->qfrc_passive[i] + d->qfrc_applied[i] + s->gravity[i]) * s->inv_mass[i];
      if (bad(acc)) {
        warn(d, mjWARN_BADQACC, i);
        return k;
      }
      d->qacc[i] = acc;
      d->qvel[i] += dt * acc;
      if (bad(d->qvel[i])) {
        warn(d, mjWARN_BADQVEL, i);
        return k;
      }
    }
    for (int j = 0; j < m->njnt; j++) {
      double* q = d->qpos + m->jnt_qposadr[j];
      const double* v = d->qvel + m->jnt_dofadr[j];
      switch (m->jnt_type[j]) {
        case mjJNT_FREE:
          q[0] += dt * v[0];
          q[1] += dt * v[1];
          q[2] += dt * v[2];
          quat_integrate(q + 3, v + 3, dt);
          break;
        case mjJNT_BALL:
          quat_integrate(q, v, dt);
          break;
        default:
          q[0] += dt * v[0];
      }
    }
    d->time += dt;
  }
  return nstep;
}
