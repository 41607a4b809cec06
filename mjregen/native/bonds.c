/* mjregen native bond forces: every bond of a robot in one tight loop.

   Either reproduces the spatial tendons of `mjregen.compile` (site-to-site springs with
   stiffness-proportional dampers, muscle-driven rest lengths, optional strain-rate drive),
   or computes one beam element per bond with the same linear stiffness (`beam_bonds`,
   `Scene.bond_element` "beam"), as forces added to qfrc_passive from MuJoCo's passive-force
   callback, on a model that has the same bodies but no sites or tendons. MuJoCo keeps
   bodies, contacts and integration.

   With the paper engine's contacts (`Scene.contact_shape` "engine") it also computes, in this
   order, the voxels' drag, their self-collision and the engine's floor (penalty spring and
   damper on the centre's penetration below the voxel's current half size, static/kinetic
   friction with a stick state per voxel kept in `d->userdata`); MuJoCo then has no contact
   or constraint at all and only integrates the bodies (or step.c does, `mjregen.stepping`).

   State is per mjData: `mjr_register(d, bonds)` before stepping, `mjr_unregister(d)` after;
   the callback does nothing for an unregistered mjData (so other models are unaffected).
   Only struct fields of mjModel/mjData are read (no MuJoCo function is called), so this file
   compiles against the installed wheel's headers and needs no link to libmujoco.
*/
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#define SW 28 /* scratch doubles per voxel */

typedef struct {
  int dim;              /* 2 or 3 */
  int nvox;
  int nten;
  int nmus;             /* driven tendons: 0 .. nmus-1 */
  int contract;         /* waveform "contract" (1) or "symmetric" (0) */
  int rate_drive;       /* add c dl0/dt along driven tendons (damp_strain_rate) */
  double voxel_size;    /* L, m */
  double start;         /* s, actuation start */
  double omega;         /* rad/s */
  double dt;            /* s, the model's time step */
  const int* qadr;      /* (nvox) first qpos address of the voxel's joint, -1 clamped */
  const int* vadr;      /* (nvox) first dof address, -1 clamped */
  const double* pos0;   /* (nvox, 3) 2D: body position at qpos 0; clamped: fixed position */
  const int* ends;      /* (nten, 2) voxels of the tendon's two sites */
  const double* off;    /* (nten, 2, 3) site offsets in the voxels' frames */
  const double* k;      /* (nten) N/m */
  const double* c;      /* (nten) N s/m */
  const double* rest;   /* (nten) m, rest length of undriven tendons */
  const double* plus;   /* (nmus) L w+ */
  const double* minus;  /* (nmus) L w- */
  const double* lat2;   /* (nmus) d^2 */
  const double* plus_c; /* (nmus) c L w+ (rate drive) */
  const double* minus_c;/* (nmus) c L w- (rate drive) */
  double* scratch;      /* (nvox, SW): pos 3, R 9, vel 3, omega 3 (world), force 3, torque 3,
                           quaternion 4 (w, x, y, z) */
  int floor;            /* 1: the paper engine's floor (needs nuserdata >= nvox) */
  int waves;            /* 1: some voxel or bond is a muscle (compute the waveform) */
  const double* fk;     /* (nvox) N/m, floor penalty stiffness */
  const double* fc;     /* (nvox) N s/m, floor damping (may pull, as in the engine) */
  const double* mu_s;   /* (nvox) static friction coefficient */
  const double* mu_k;   /* (nvox) kinetic friction coefficient */
  const double* mass;   /* (nvox) kg */
  const double* half_p; /* (nvox) L/2 w+ of the voxel's own scale (muscle +), else 0 */
  const double* half_m; /* (nvox) L/2 w- (muscle -), else 0 */
  const double* strain_in; /* NULL, or (2) strains (e+, e-) set by the caller (no waveform) */
  double drag_lin;      /* N s/m, drag on each voxel centre (0: none) */
  double drag_rot;      /* N m s, rotational drag */
  int collide;          /* 1: self-collision of surface voxels computed here */
  double coll_radius;   /* m, collision sphere radius at the voxel's nominal size */
  double coll_skin;     /* m, Verlet-list skin */
  double coll_reach;    /* m, largest contact distance (both spheres at their largest) */
  const int* grid;      /* (nvox, 3) grid indices (neighbours in the grid never collide) */
  const int* surface;   /* (nvox) 1: the voxel collides */
  double* coll_ref;     /* (nvox, 3) positions when the candidate list was built */
  int* coll_pairs;      /* (capacity, 2) candidate pairs */
  int* coll_count;      /* (2): [number of candidates, list built (0/1)] */
  int nbeam;            /* > 0: bonds are beam elements (below), nten is 0 */
  int beam_nmus;        /* driven beams: 0 .. beam_nmus-1 */
  const int* beam_ends; /* (nbeam, 2) voxels i, j (j is i's neighbour along +axis) */
  const int* beam_axis; /* (nbeam) the bond's axis in the voxels' rest frame (0, 1, 2) */
  const double* beam_k; /* (nbeam, 4) axial N/m, transverse N/m, bending N m, torsion N m */
  const double* beam_law; /* (nbeam, 3) axial law of the bond's tendons: straight k N/m,
                             diagonal k N/m, diagonals' lateral extent^2 m^2 */
  const double* beam_beta; /* (nbeam) s, damping per stiffness (C = beta K) */
  const double* beam_plus;  /* (beam_nmus) m, L w+: rest length L + plus e+ + minus e- */
  const double* beam_minus; /* (beam_nmus) m, L w- */
} mjrBonds;

typedef struct {
  const mjData* d;
  const mjrBonds* b;
} Entry;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static Entry* table = NULL;
static int count = 0, capacity = 0;

int mjr_register(const mjData* d, const mjrBonds* b) {
  int ok = 1;
  pthread_mutex_lock(&lock);
  for (int i = 0; i < count; i++) {
    if (table[i].d == d) {
      table[i].b = b;
      pthread_mutex_unlock(&lock);
      return 1;
    }
  }
  if (count == capacity) {
    int cap = capacity ? 2 * capacity : 16;
    Entry* grown = (Entry*)realloc(table, cap * sizeof(Entry));
    if (!grown) {
      ok = 0;
    } else {
      table = grown;
      capacity = cap;
    }
  }
  if (ok) {
    table[count].d = d;
    table[count].b = b;
    count++;
  }
  pthread_mutex_unlock(&lock);
  return ok;
}

void mjr_unregister(const mjData* d) {
  pthread_mutex_lock(&lock);
  for (int i = 0; i < count; i++) {
    if (table[i].d == d) {
      table[i] = table[count - 1];
      count--;
      break;
    }
  }
  pthread_mutex_unlock(&lock);
}

int mjr_registered(void) {
  pthread_mutex_lock(&lock);
  int n = count;
  pthread_mutex_unlock(&lock);
  return n;
}

static const mjrBonds* lookup(const mjData* d) {
  const mjrBonds* b = NULL;
  pthread_mutex_lock(&lock);
  for (int i = 0; i < count; i++) {
    if (table[i].d == d) {
      b = table[i].b;
      break;
    }
  }
  pthread_mutex_unlock(&lock);
  return b;
}

/* signed strains (e+, e-) of the two muscle phases at time t */
static void strains(const mjrBonds* b, double t, double* ep, double* em) {
  if (t < b->start) {
    *ep = 0.0;
    *em = 0.0;
    return;
  }
  double wave = sin(b->omega * (t - b->start));
  if (b->contract) {
    *ep = wave < 0.0 ? wave : 0.0;
    *em = -wave < 0.0 ? -wave : 0.0;
  } else {
    *ep = wave;
    *em = -wave;
  }
}

static void strain_rates(const mjrBonds* b, double t, double* rp, double* rm) {
  if (t < b->start) {
    *rp = 0.0;
    *rm = 0.0;
    return;
  }
  double phase = b->omega * (t - b->start);
  double wave = sin(phase), rate = b->omega * cos(phase);
  if (b->contract) {
    *rp = wave < 0.0 ? rate : 0.0;
    *rm = wave > 0.0 ? -rate : 0.0;
  } else {
    *rp = rate;
    *rm = -rate;
  }
}

static inline void cross(const double* a, const double* b, double* out) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/* frames and velocities of all voxels from qpos/qvel (no MuJoCo kinematics needed) */
static void voxel_states(const mjrBonds* b, const mjData* d) {
  for (int v = 0; v < b->nvox; v++) {
    double* s = b->scratch + SW * v;
    double *p = s, *R = s + 3, *vel = s + 12, *w = s + 15;
    memset(s + 12, 0, 12 * sizeof(double));
    int qa = b->qadr[v], va = b->vadr[v];
    if (qa < 0) {
      memcpy(p, b->pos0 + 3 * v, 3 * sizeof(double));
      memset(R, 0, 9 * sizeof(double));
      R[0] = R[4] = R[8] = 1.0;
      memset(vel, 0, 6 * sizeof(double));
      s[24] = 1.0;
      s[25] = s[26] = s[27] = 0.0;
      continue;
    }
    const double* q = d->qpos + qa;
    const double* qv = d->qvel + va;
    if (b->dim == 3) {
      p[0] = q[0];
      p[1] = q[1];
      p[2] = q[2];
      double qw = q[3], qx = q[4], qy = q[5], qz = q[6];
      double norm = sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
      if (norm < 1e-15) {  /* MuJoCo's mju_normalize4: degenerate -> identity */
        qw = 1.0;
        qx = qy = qz = 0.0;
      } else {
        qw /= norm;
        qx /= norm;
        qy /= norm;
        qz /= norm;
      }
      s[24] = qw;
      s[25] = qx;
      s[26] = qy;
      s[27] = qz;
      /* mju_quat2Mat */
      double q00 = qw * qw, q01 = qw * qx, q02 = qw * qy, q03 = qw * qz;
      double q11 = qx * qx, q12 = qx * qy, q13 = qx * qz;
      double q22 = qy * qy, q23 = qy * qz, q33 = qz * qz;
      R[0] = q00 + q11 - q22 - q33;
      R[4] = q00 - q11 + q22 - q33;
      R[8] = q00 - q11 - q22 + q33;
      R[1] = 2 * (q12 - q03);
      R[2] = 2 * (q13 + q02);
      R[3] = 2 * (q12 + q03);
      R[5] = 2 * (q23 - q01);
      R[6] = 2 * (q13 - q02);
      R[7] = 2 * (q23 + q01);
      vel[0] = qv[0];
      vel[1] = qv[1];
      vel[2] = qv[2];
      /* free joint: angular velocity in the body frame */
      w[0] = R[0] * qv[3] + R[1] * qv[4] + R[2] * qv[5];
      w[1] = R[3] * qv[3] + R[4] * qv[4] + R[5] * qv[5];
      w[2] = R[6] * qv[3] + R[7] * qv[4] + R[8] * qv[5];
    } else {
      /* slide x, slide z, hinge y at the body origin */
      const double* p0 = b->pos0 + 3 * v;
      p[0] = p0[0] + q[0];
      p[1] = p0[1];
      p[2] = p0[2] + q[1];
      double half = 0.5 * q[2];
      double qw = cos(half), qy = sin(half);
      s[24] = qw;
      s[25] = 0.0;
      s[26] = qy;
      s[27] = 0.0;
      double q00 = qw * qw, q02 = qw * qy, q22 = qy * qy;
      memset(R, 0, 9 * sizeof(double));
      R[0] = q00 - q22;
      R[4] = q00 + q22;
      R[8] = q00 - q22;
      R[2] = 2 * q02;
      R[6] = -2 * q02;
      vel[0] = qv[0];
      vel[1] = 0.0;
      vel[2] = qv[1];
      w[0] = 0.0;
      w[1] = qv[2];
      w[2] = 0.0;
    }
  }
}

/* Drag on every voxel: MuJoCo's Stokes drag of the inertia box, -drag_lin v on the centre
   and -drag_rot w (the paper engine's "slow" damping), computed here instead of by MuJoCo. */
static void voxel_drag(const mjrBonds* b) {
  for (int v = 0; v < b->nvox; v++) {
    if (b->vadr[v] < 0) continue;
    double* s = b->scratch + SW * v;
    for (int a = 0; a < 3; a++) {
      s[18 + a] -= b->drag_lin * s[12 + a];
      s[21 + a] -= b->drag_rot * s[15 + a];
    }
  }
}

static inline int grid_neighbours(const int* gi, const int* gj) {
  for (int a = 0; a < 3; a++) {
    int d = gi[a] - gj[a];
    if (d > 1 || d < -1) return 0;
  }
  return 1;
}

/* Self-collision as the paper engine: surface voxels that are not grid neighbours repel as
   spheres of radius coll_radius times their current linear scale (muscle strain), with a
   penalty spring and damper along the centre line, each the harmonic mean of the two
   voxels' floor constants; repulsion only, no friction, no moment. Candidates come from a
   Verlet list rebuilt whenever a voxel has moved more than half the skin since the last
   build, so no touching pair is ever missed. */
static void self_collision(const mjrBonds* b, double ep, double em) {
  int n = b->nvox;
  int* count = b->coll_count;
  double half_skin2 = 0.25 * b->coll_skin * b->coll_skin;
  int rebuild = count[1] == 0;
  for (int v = 0; v < n && !rebuild; v++) {
    if (!b->surface[v]) continue;
    const double* p = b->scratch + SW * v;
    const double* r = b->coll_ref + 3 * v;
    double dx = p[0] - r[0], dy = p[1] - r[1], dz = p[2] - r[2];
    if (dx * dx + dy * dy + dz * dz > half_skin2) rebuild = 1;
  }
  if (rebuild) {
    double cut = b->coll_reach + b->coll_skin, cut2 = cut * cut;
    int found = 0;
    for (int i = 0; i < n; i++) {
      if (!b->surface[i]) continue;
      const double* pi = b->scratch + SW * i;
      for (int j = i + 1; j < n; j++) {
        if (!b->surface[j] || grid_neighbours(b->grid + 3 * i, b->grid + 3 * j)) continue;
        const double* pj = b->scratch + SW * j;
        double dx = pj[0] - pi[0], dy = pj[1] - pi[1], dz = pj[2] - pi[2];
        if (dx * dx + dy * dy + dz * dz < cut2) {
          b->coll_pairs[2 * found] = i;
          b->coll_pairs[2 * found + 1] = j;
          found++;
        }
      }
    }
    for (int v = 0; v < n; v++) memcpy(b->coll_ref + 3 * v, b->scratch + SW * v, 3 * sizeof(double));
    count[0] = found;
    count[1] = 1;
  }
  double two_over_l = 2.0 / b->voxel_size;
  for (int k = 0; k < count[0]; k++) {
    int i = b->coll_pairs[2 * k], j = b->coll_pairs[2 * k + 1];
    double *si = b->scratch + SW * i, *sj = b->scratch + SW * j;
    double d[3] = {sj[0] - si[0], sj[1] - si[1], sj[2] - si[2]};
    double dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double scale_i = 1.0 + two_over_l * (b->half_p[i] * ep + b->half_m[i] * em);
    double scale_j = 1.0 + two_over_l * (b->half_p[j] * ep + b->half_m[j] * em);
    double contact = b->coll_radius * (scale_i + scale_j);
    if (dist2 >= contact * contact || dist2 <= 0.0) continue;
    double dist = sqrt(dist2);
    double u[3] = {d[0] / dist, d[1] / dist, d[2] / dist};
    double closing = 0.0;
    for (int a = 0; a < 3; a++) closing += u[a] * (sj[12 + a] - si[12 + a]);
    double k = 2.0 / (1.0 / b->fk[i] + 1.0 / b->fk[j]);
    double c = 2.0 / (1.0 / b->fc[i] + 1.0 / b->fc[j]);
    double f = k * (contact - dist) - c * closing;
    if (f <= 0.0) continue;
    for (int a = 0; a < 3; a++) {
      sj[18 + a] += f * u[a];
      si[18 + a] -= f * u[a];
    }
  }
}

/* m/s: a sticking voxel's horizontal speed is zeroed every step (to ~1e-20); faster means an
   outside impulse (someone wrote qvel), which releases it */
#define KICKED 1e-9

/* The paper engine's floor (Voxelyze CVX_Voxel::floorForce and the friction part of
   timeStep), added to the voxels' forces in scratch. Per voxel touching the floor (centre
   below its current half size, which shrinks with the voxel's own muscle strain):
   normal force k*pen - c*vz on the centre (no moment; the damper may pull); friction from
   the spring part N = k*pen: a sticking voxel stays put (its horizontal velocity is
   cancelled within the step) until the other horizontal forces exceed mu_s*N; a sliding
   one feels mu_k*N against its horizontal velocity and sticks when that would stop it
   within the step (work-energy test of the engine). The other horizontal forces are all
   known here: bonds, drag and self-collision (already in scratch), qfrc_passive and
   qfrc_applied, and gravity (voxel bodies have their centre of mass at the joint, so no
   other bias force acts on their translation). Stick flags: d->userdata[0 .. nvox-1]. */
static void engine_floor(const mjrBonds* b, const mjModel* mdl, mjData* d, double ep,
                         double em) {
  int planar = b->dim == 3;
  const double* gravity = mdl->opt.gravity;
  for (int v = 0; v < b->nvox; v++) {
    int va = b->vadr[v];
    if (va < 0) continue;
    double* s = b->scratch + SW * v;
    double* stick = d->userdata + v;
    double half = 0.5 * b->voxel_size + b->half_p[v] * ep + b->half_m[v] * em;
    double pen = half - s[2];
    if (pen < 0.0) {
      *stick = 0.0;
      continue;
    }
    const double *vel = s + 12;
    double *F = s + 18;
    double normal = b->fk[v] * pen;
    F[2] += normal - b->fc[v] * vel[2];
    double m = b->mass[v], dt = b->dt;
    /* bonds + passive (drag) + applied + gravity: the horizontal forces besides friction */
    double other[2] = {F[0] + d->qfrc_passive[va] + d->qfrc_applied[va] + m * gravity[0],
                       planar ? F[1] + d->qfrc_passive[va + 1] + d->qfrc_applied[va + 1]
                                + m * gravity[1] : 0.0};
    double vh[2] = {vel[0], planar ? vel[1] : 0.0};
    double stop[2] = {-other[0] - m * vh[0] / dt, -other[1] - m * vh[1] / dt};
    if (*stick != 0.0 && vh[0] * vh[0] + vh[1] * vh[1] > KICKED * KICKED) {
      *stick = 0.0;  /* a sticking voxel only moves if pushed from outside (qvel written) */
    }
    if (*stick != 0.0) {
      double limit = b->mu_s[v] * normal;
      if (other[0] * other[0] + other[1] * other[1] > limit * limit) {
        *stick = 0.0;  /* breaks loose: this step's forces start the motion, no friction */
      } else {
        F[0] += stop[0];
        F[1] += stop[1];
      }
      continue;
    }
    double speed = sqrt(vh[0] * vh[0] + vh[1] * vh[1]);
    double fric[2] = {0.0, 0.0};
    if (speed > 0.0) {
      fric[0] = -b->mu_k[v] * normal * vh[0] / speed;
      fric[1] = -b->mu_k[v] * normal * vh[1] / speed;
    }
    /* momentum after this step, the step's displacement, and the engine's stop test */
    double p0 = m * vh[0] + dt * (other[0] + fric[0]);
    double p1 = m * vh[1] + dt * (other[1] + fric[1]);
    double work = (fric[0] * p0 + fric[1] * p1) * dt / m;
    double kinetic = 0.5 * (p0 * p0 + p1 * p1) / m;
    if (kinetic + work <= 0.0) {
      *stick = 1.0;
      F[0] += stop[0];
      F[1] += stop[1];
    } else {
      F[0] += fric[0];
      F[1] += fric[1];
    }
  }
}

/* v^T R (= R^T v): a world vector into the frame of rotation R (row-major) */
static inline void to_frame(const double* R, const double* v, double* out) {
  out[0] = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
  out[1] = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
  out[2] = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
}

/* Beam bonds: one co-rotated beam element per face bond, with the linear stiffness of the
   bond's 8 calibrated tendons (axial k_a, transverse k_s, bending k_b, torsion k_t) and
   stiffness-proportional damping C = beta K: 8x less work than the tendon loop. It works in
   the bond's mid frame M = R_i exp(Delta/2) (symmetric in i and j), with Delta the rotation
   vector of q_i^-1 q_j (j relative to i); there the nodes' rotations are -Delta/2 and
   +Delta/2, so the symmetric (shear) rotation vanishes. With e the bond's rest axis and
   d = M^T (p_j - p_i):
     transverse (Hookean, like the paper engine's beam):  F_j,perp = -k_s d_perp
     axial (the tendons' own law, stiffening in tension): F_j.e = -k0 (l - l0)
        - kd (s - s0) l / s,  l = d.e, s = sqrt(l^2 + D^2), s0 = sqrt(l0^2 + D^2)
     B = k_b Delta_perp + k_t (Delta.e) e
     F_i = -F_j,  T_i = -(d x F_j)/2 + B,  T_j = -(d x F_j)/2 - B,
   each displacement plus beta times its rate (rates in the frame turning with the mean
   angular velocity; the axial damping linear, beta k_a). Linearised this is the
   Euler-Bernoulli (k_s = E L) or Timoshenko (k_s = G L) beam of the tendons; momentum and
   angular momentum are conserved exactly (T_i + T_j + d x F_j = 0). */
static void beam_bonds(const mjrBonds* b, double ep, double em, double rp, double rm) {
  double L = b->voxel_size;
  for (int n = 0; n < b->nbeam; n++) {
    int i = b->beam_ends[2 * n], j = b->beam_ends[2 * n + 1], axis = b->beam_axis[n];
    double *si = b->scratch + SW * i, *sj = b->scratch + SW * j;
    const double *qi = si + 24, *qj = sj + 24;
    const double* k = b->beam_k + 4 * n;
    double beta = b->beam_beta[n];
    /* r = q_i^-1 q_j on the short way round, its rotation vector Delta, its half h */
    double rw = qi[0] * qj[0] + qi[1] * qj[1] + qi[2] * qj[2] + qi[3] * qj[3];
    double rv[3] = {qi[0] * qj[1] - qj[0] * qi[1] - (qi[2] * qj[3] - qi[3] * qj[2]),
                    qi[0] * qj[2] - qj[0] * qi[2] - (qi[3] * qj[1] - qi[1] * qj[3]),
                    qi[0] * qj[3] - qj[0] * qi[3] - (qi[1] * qj[2] - qi[2] * qj[1])};
    if (rw < 0.0) {
      rw = -rw;
      rv[0] = -rv[0];
      rv[1] = -rv[1];
      rv[2] = -rv[2];
    }
    double s2 = rv[0] * rv[0] + rv[1] * rv[1] + rv[2] * rv[2];
    /* angle = 2 asin(|v|): 2 asin(s)/s to 1e-7 for s < 0.3 (35-degree bends), exact above */
    double gain;
    if (s2 < 0.09) {
      gain = 2.0 + s2 * (1.0 / 3.0 + s2 * (0.15 + s2 * (5.0 / 56.0 + s2 * 35.0 / 576.0)));
    } else {
      double sn = sqrt(s2);
      gain = 2.0 * asin(sn < 1.0 ? sn : 1.0) / sn;
    }
    double hn = 1.0 / sqrt((1.0 + rw) * (1.0 + rw) + s2);
    double hw = (1.0 + rw) * hn, hv[3] = {rv[0] * hn, rv[1] * hn, rv[2] * hn};
    /* mid frame q_m = q_i h as a rotation matrix (mju_quat2Mat) */
    double mw = qi[0] * hw - qi[1] * hv[0] - qi[2] * hv[1] - qi[3] * hv[2];
    double mx = qi[0] * hv[0] + qi[1] * hw + qi[2] * hv[2] - qi[3] * hv[1];
    double my = qi[0] * hv[1] + qi[2] * hw + qi[3] * hv[0] - qi[1] * hv[2];
    double mz = qi[0] * hv[2] + qi[3] * hw + qi[1] * hv[1] - qi[2] * hv[0];
    double M[9];
    M[0] = mw * mw + mx * mx - my * my - mz * mz;
    M[4] = mw * mw - mx * mx + my * my - mz * mz;
    M[8] = mw * mw - mx * mx - my * my + mz * mz;
    M[1] = 2 * (mx * my - mw * mz);
    M[2] = 2 * (mx * mz + mw * my);
    M[3] = 2 * (mx * my + mw * mz);
    M[5] = 2 * (my * mz - mw * mx);
    M[6] = 2 * (mx * mz - mw * my);
    M[7] = 2 * (my * mz + mw * mx);
    double dw[3], uw[3], ww[3], wm[3];
    for (int a = 0; a < 3; a++) {
      dw[a] = sj[a] - si[a];
      ww[a] = sj[15 + a] - si[15 + a];
      wm[a] = 0.5 * (sj[15 + a] + si[15 + a]);
    }
    /* velocity of j relative to i as seen in the mid frame: v_j - v_i - w_m x d */
    cross(wm, dw, uw);
    for (int a = 0; a < 3; a++) uw[a] = sj[12 + a] - si[12 + a] - uw[a];
    double d[3], dd[3], dD[3];
    to_frame(M, dw, d);
    to_frame(M, uw, dd);
    to_frame(M, ww, dD);
    double rest = L;
    if (n < b->beam_nmus) {
      rest += b->beam_plus[n] * ep + b->beam_minus[n] * em;
      if (b->rate_drive) dd[axis] -= b->beam_plus[n] * rp + b->beam_minus[n] * rm;
    }
    double F[3], B[3], Ti[3], Tj[3], dF[3];
    for (int a = 0; a < 3; a++) {
      double rot = gain * rv[a] + beta * dD[a];
      F[a] = a == axis ? 0.0 : -k[1] * (d[a] + beta * dd[a]);
      B[a] = (a == axis ? k[3] : k[2]) * rot;
    }
    /* axial: the tendons' own law along the axis, l = d[axis]; damping linear */
    const double* law = b->beam_law + 3 * n;
    double l = d[axis], lat2 = law[2];
    double s_now = sqrt(l * l + lat2), s_rest = sqrt(rest * rest + lat2);
    F[axis] = -law[0] * (l - rest) - beta * k[0] * dd[axis];
    if (s_now > 0.0) F[axis] -= law[1] * (s_now - s_rest) * l / s_now;
    cross(d, F, dF);
    for (int a = 0; a < 3; a++) {
      Ti[a] = -0.5 * dF[a] + B[a];
      Tj[a] = -0.5 * dF[a] - B[a];
    }
    /* back to world: M x */
    for (int a = 0; a < 3; a++) {
      double f = M[3 * a] * F[0] + M[3 * a + 1] * F[1] + M[3 * a + 2] * F[2];
      sj[18 + a] += f;
      si[18 + a] -= f;
      si[21 + a] += M[3 * a] * Ti[0] + M[3 * a + 1] * Ti[1] + M[3 * a + 2] * Ti[2];
      sj[21 + a] += M[3 * a] * Tj[0] + M[3 * a + 1] * Tj[1] + M[3 * a + 2] * Tj[2];
    }
  }
}

void mjr_passive(const mjModel* m, mjData* d) {
  const mjrBonds* b = lookup(d);
  if (!b) return;
  voxel_states(b, d);

  double t = 0.0, ep = 0.0, em = 0.0, rp = 0.0, rm = 0.0;
  if (b->strain_in) {
    ep = b->strain_in[0];
    em = b->strain_in[1];
  } else if (b->waves) {
    double step = floor(d->time / b->dt + 0.5);
    t = step * b->dt;
    strains(b, t, &ep, &em);
    if (b->rate_drive) strain_rates(b, (step + 0.5) * b->dt, &rp, &rm);
  }

  /* the tendons of one bond are consecutive: load the two voxels' states once per bond and
     write their summed force and torques once */
  int n = 0;
  while (n < b->nten) {
    int i = b->ends[2 * n], j = b->ends[2 * n + 1];
    double* si = b->scratch + SW * i;
    double* sj = b->scratch + SW * j;
    double pi[3], pj[3], Ri[9], Rj[9], ui[3], uj[3], wi[3], wj[3];
    memcpy(pi, si, 3 * sizeof(double));
    memcpy(pj, sj, 3 * sizeof(double));
    memcpy(Ri, si + 3, 9 * sizeof(double));
    memcpy(Rj, sj + 3, 9 * sizeof(double));
    memcpy(ui, si + 12, 3 * sizeof(double));
    memcpy(uj, sj + 12, 3 * sizeof(double));
    memcpy(wi, si + 15, 3 * sizeof(double));
    memcpy(wj, sj + 15, 3 * sizeof(double));
    double Fsum[3] = {0.0, 0.0, 0.0}, Ti[3] = {0.0, 0.0, 0.0}, Tj[3] = {0.0, 0.0, 0.0};
    for (; n < b->nten && b->ends[2 * n] == i && b->ends[2 * n + 1] == j; n++) {
      const double* oi = b->off + 6 * n;
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
      double rest = b->rest[n], drive = 0.0;
      if (n < b->nmus) {
        double axial = b->voxel_size + b->plus[n] * ep + b->minus[n] * em;
        rest = sqrt(axial * axial + b->lat2[n]);
        if (b->rate_drive) drive = (axial / rest) * (b->plus_c[n] * rp + b->minus_c[n] * rm);
      }
      double f = -b->k[n] * (len - rest) - b->c[n] * rate + drive;
      double F[3] = {f * u[0], f * u[1], f * u[2]};
      for (int a = 0; a < 3; a++) Fsum[a] += F[a];
      cross(rj, F, tmp);
      for (int a = 0; a < 3; a++) Tj[a] += tmp[a];
      cross(ri, F, tmp);
      for (int a = 0; a < 3; a++) Ti[a] -= tmp[a];
    }
    for (int a = 0; a < 3; a++) {
      sj[18 + a] += Fsum[a];
      si[18 + a] -= Fsum[a];
      sj[21 + a] += Tj[a];
      si[21 + a] += Ti[a];
    }
  }

  if (b->nbeam > 0) beam_bonds(b, ep, em, rp, rm);

  if (b->drag_lin > 0.0 || b->drag_rot > 0.0) voxel_drag(b);
  if (b->collide) self_collision(b, ep, em);
  if (b->floor && m->nuserdata >= b->nvox) engine_floor(b, m, d, ep, em);

  double* qfrc = d->qfrc_passive;
  for (int v = 0; v < b->nvox; v++) {
    int va = b->vadr[v];
    if (va < 0) continue;
    const double* s = b->scratch + SW * v;
    const double *R = s + 3, *F = s + 18, *T = s + 21;
    if (b->dim == 3) {
      qfrc[va] += F[0];
      qfrc[va + 1] += F[1];
      qfrc[va + 2] += F[2];
      /* torque into the body frame: R^T T */
      for (int a = 0; a < 3; a++) qfrc[va + 3 + a] += R[a] * T[0] + R[3 + a] * T[1] + R[6 + a] * T[2];
    } else {
      qfrc[va] += F[0];
      qfrc[va + 1] += F[2];
      qfrc[va + 2] += T[1];
    }
  }
}
