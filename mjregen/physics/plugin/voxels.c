/* The "mjregen.voxels" engine plugin: registration, configuration and lifecycle.

   Like MuJoCo's own plugins (plugin/elasticity), configuration attributes are read once per
   mjData in `init`, the state (each voxel's floor stick flag; with `settle_rest` the
   settle's rest) lives in plugin_state, and the forces are added to qfrc_passive in
   `compute` (forces.c). `compute` decides the stick flags for the end of the step without
   touching the state; `advance` (called by mj_step after the integration) makes them the
   state, so mj_forward has no side effect. A robot at rest in the settle is held still:
   `compute` adds no force and `advance` puts back the positions and zero velocities that
   the step's gravity changed, so mj_step holds it exactly as the native stepper, which
   skips those steps.
*/
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "voxels.h"

#define MJR_NAME_STRING(name) #name,
static const char* attributes[] = {MJR_ATTRIBUTES(MJR_NAME_STRING)};

static int plugin_slot = -1;

/* name of configuration attribute i, or NULL past the last (Python checks its keys) */
const char* mjr_attribute(int i) {
  return i >= 0 && i < MJR_NATTRIBUTE ? attributes[i] : NULL;
}

/* One parse of an instance's configuration: where its attributes are, and its first error
   (every reader does nothing once `ok` is 0, so a parse reports the first problem). */
typedef struct {
  const mjModel* m;
  int instance;
  char* error;
  int error_sz;
  int ok;
} mjrParse;

static const char* config(const mjModel* m, int instance, const char* key) {
  const char* value = mj_getPluginConfig(m, instance, key);
  return value ? value : "";
}

/* Record the parse's first error: "mjregen.voxels: " and the formatted message. */
static void fail(mjrParse* p, const char* format, ...) {
  if (!p->ok) return;
  int used = snprintf(p->error, p->error_sz, "mjregen.voxels: ");
  va_list args;
  va_start(args, format);
  if (used >= 0 && used < p->error_sz) vsnprintf(p->error + used, p->error_sz - used, format, args);
  va_end(args);
  p->ok = 0;
}

static int count_tokens(const char* s) {
  int n = 0, in = 0;
  for (; *s; s++) {
    int space = *s == ' ' || *s == '\t' || *s == '\n' || *s == '\r';
    if (!space && !in) n++;
    in = !space;
  }
  return n;
}

/* Exactly `n` numbers of attribute `key` as a new array (n = 0: a non-NULL empty one), or
   NULL after an error. */
static double* doubles(mjrParse* p, const char* key, int n) {
  if (!p->ok) return NULL;
  const char* s = config(p->m, p->instance, key);
  int found = count_tokens(s);
  if (found != n) {
    fail(p, "attribute '%s' has %d numbers, needs %d", key, found, n);
    return NULL;
  }
  double* out = (double*)calloc(n > 0 ? n : 1, sizeof(double));
  char* end = NULL;
  for (int i = 0; i < n; i++) {
    errno = 0;
    out[i] = strtod(s, &end);
    if (end == s || errno == ERANGE || !isfinite(out[i])) {
      fail(p, "attribute '%s': entry %d is not a finite number", key, i);
      free(out);
      return NULL;
    }
    s = end;
  }
  return out;
}

/* Exactly `n` integers in [low, high] of attribute `key`, or NULL after an error. */
static int* ints(mjrParse* p, const char* key, int n, int low, int high) {
  double* values = doubles(p, key, n);
  if (!values) return NULL;
  int* out = (int*)calloc(n > 0 ? n : 1, sizeof(int));
  for (int i = 0; i < n; i++) {
    if (values[i] != floor(values[i]) || values[i] < low || values[i] > high) {
      fail(p, "attribute '%s': entry %d is %g, needs an integer in [%d, %d]", key, i,
           values[i], low, high);
      free(values);
      free(out);
      return NULL;
    }
    out[i] = (int)values[i];
  }
  free(values);
  return out;
}

/* The one number of attribute `key` (0 after an error). */
static double scalar(mjrParse* p, const char* key) {
  double* value = doubles(p, key, 1);
  if (!value) return 0.0;
  double out = *value;
  free(value);
  return out;
}

/* 1 if attribute `key` is `yes`, 0 if it is `no` (or after an error). */
static int either(mjrParse* p, const char* key, const char* yes, const char* no) {
  if (!p->ok) return 0;
  const char* value = config(p->m, p->instance, key);
  if (!strcmp(value, yes)) return 1;
  if (strcmp(value, no)) fail(p, "%s must be '%s' or '%s', got '%s'", key, yes, no, value);
  return 0;
}

static void release(mjrVoxels* v) {
  if (!v) return;
  void* arrays[] = {v->qadr, v->vadr, v->body, v->pos0, v->half_p, v->half_m, v->bonds,
                    v->axis, v->muscle, v->stiffness, v->law, v->beta, v->tendon_bond,
                    v->sites, v->tk, v->tc, v->trest, v->tlat2, v->fk, v->fc, v->mu_s,
                    v->mu_k, v->ck, v->cc, v->grid, v->collides, v->coll_near, v->drag_lin,
                    v->drag_rot, v->state, v->scratch, v->stick_next, v->coll_ref,
                    v->coll_pairs};
  for (size_t i = 0; i < sizeof(arrays) / sizeof(arrays[0]); i++) free(arrays[i]);
  free(v->beam.constants);
  free(v->beam.outputs);
  free(v);
}

static inline void set_bit(unsigned char* bits, size_t k) { bits[k >> 3] |= 1u << (k & 7); }

/* The pairs that never collide, as nvox * nvox bits (row i, column j): with coll_hops > 0
   the voxels within that many bond hops of each other (the paper engine's "nearby" voxels,
   a breadth-first search over the bonds), with 0 the face, edge and corner grid neighbours. */
static unsigned char* never_colliding(const mjrVoxels* v) {
  size_t n = (size_t)v->nvox;
  unsigned char* near = (unsigned char*)calloc((n * n + 7) / 8, 1);
  if (v->coll_hops == 0) {
    for (size_t i = 0; i < n; i++) {
      for (size_t j = 0; j < n; j++) {
        int close = 1;
        for (int a = 0; a < 3; a++) {
          int d = v->grid[3 * i + a] - v->grid[3 * j + a];
          if (d > 1 || d < -1) close = 0;
        }
        if (close) set_bit(near, i * n + j);
      }
    }
    return near;
  }
  /* the bond graph as adjacency lists (CSR) */
  size_t nb = (size_t)v->nbond;
  int* start = (int*)calloc(n + 1, sizeof(int));
  int* other = (int*)malloc((2 * nb + 1) * sizeof(int));
  for (size_t b = 0; b < 2 * nb; b++) start[v->bonds[b] + 1]++;
  for (size_t i = 0; i < n; i++) start[i + 1] += start[i];
  int* fill = (int*)malloc((n + 1) * sizeof(int));
  memcpy(fill, start, (n + 1) * sizeof(int));
  for (size_t b = 0; b < nb; b++) {
    int i = v->bonds[2 * b], j = v->bonds[2 * b + 1];
    other[fill[i]++] = j;
    other[fill[j]++] = i;
  }
  int* depth = (int*)malloc(n * sizeof(int));
  int* queue = (int*)malloc(n * sizeof(int));
  for (size_t s = 0; s < n; s++) {
    if (!v->collides[s]) continue;
    for (size_t i = 0; i < n; i++) depth[i] = -1;
    size_t head = 0, tail = 0;
    depth[s] = 0;
    queue[tail++] = (int)s;
    while (head < tail) {
      int i = queue[head++];
      set_bit(near, s * n + (size_t)i);
      if (depth[i] == v->coll_hops) continue;
      for (int k = start[i]; k < start[i + 1]; k++) {
        int j = other[k];
        if (depth[j] < 0) {
          depth[j] = depth[i] + 1;
          queue[tail++] = j;
        }
      }
    }
  }
  free(start);
  free(other);
  free(fill);
  free(depth);
  free(queue);
  return near;
}

/* Whether any two colliding voxels are not excluded from colliding (coll_near built). */
static int some_pair_may_collide(const mjrVoxels* v) {
  size_t n = (size_t)v->nvox;
  for (size_t i = 0; i < n; i++) {
    if (!v->collides[i]) continue;
    for (size_t j = i + 1; j < n; j++) {
      size_t k = i * n + j;
      if (v->collides[j] && !((v->coll_near[k >> 3] >> (k & 7)) & 1)) return 1;
    }
  }
  return 0;
}

/* The beam bonds' arrays (mjrBeams) from the parsed per-bond rows. */
static void arrange_beams(mjrVoxels* v) {
  mjrBeams* b = &v->beam;
  size_t nb = (size_t)v->nbond, stride = nb > 0 ? nb : 1;
  b->stride = stride;
  b->constants = (double*)calloc(stride * MJR_BEAM_CONSTANTS, sizeof(double));
  b->outputs = (double*)calloc(stride * MJR_BEAM_OUTPUTS, sizeof(double));
  double* c = b->constants;
  for (size_t n = 0; n < nb; n++) {
    c[MJR_AXIS * stride + n] = v->axis[n];
    c[MJR_K_AXIAL * stride + n] = v->stiffness[4 * n];
    c[MJR_K_SHEAR * stride + n] = v->stiffness[4 * n + 1];
    c[MJR_K_BEND * stride + n] = v->stiffness[4 * n + 2];
    c[MJR_K_TWIST * stride + n] = v->stiffness[4 * n + 3];
    c[MJR_BETA * stride + n] = v->beta[3 * n];
    c[MJR_BETA_BEND * stride + n] = v->beta[3 * n + 1];
    c[MJR_BETA_TWIST * stride + n] = v->beta[3 * n + 2];
    c[MJR_LAW_K0 * stride + n] = v->law[3 * n];
    c[MJR_LAW_KD * stride + n] = v->law[3 * n + 1];
    c[MJR_LAW_LAT2 * stride + n] = v->law[3 * n + 2];
    c[MJR_MUSCLE_P * stride + n] = v->muscle[2 * n];
    c[MJR_MUSCLE_M * stride + n] = v->muscle[2 * n + 1];
  }
}

/* Resolve the voxels' bodies and joints. */
static void bind_bodies(mjrParse* p, mjrVoxels* v) {
  const mjModel* m = p->m;
  const char* names = config(m, p->instance, "voxels");
  v->qadr = (int*)calloc(v->nvox + 1, sizeof(int));
  v->vadr = (int*)calloc(v->nvox + 1, sizeof(int));
  v->body = (int*)calloc(v->nvox + 1, sizeof(int));
  v->pos0 = (double*)calloc(3 * v->nvox + 1, sizeof(double));
  char name[256];
  for (int i = 0; i < v->nvox && p->ok; i++) {
    while (*names == ' ' || *names == '\n' || *names == '\t' || *names == '\r') names++;
    int len = 0;
    while (names[len] && names[len] != ' ' && names[len] != '\n' && names[len] != '\t'
           && names[len] != '\r') len++;
    if (len >= (int)sizeof(name)) len = sizeof(name) - 1;
    memcpy(name, names, len);
    name[len] = 0;
    names += len;
    int body = mj_name2id(m, mjOBJ_BODY, name);
    if (body <= 0) {
      fail(p, "voxel %d names body '%s', which the model does not have", i, name);
      return;
    }
    v->body[i] = body;
    memcpy(v->pos0 + 3 * i, m->body_pos + 3 * body, 3 * sizeof(double));
    int njnt = m->body_jntnum[body], j = m->body_jntadr[body];
    if (njnt == 0) {
      v->qadr[i] = v->vadr[i] = -1;
      continue;
    }
    int ok = v->dim == 3 ? njnt == 1 && m->jnt_type[j] == mjJNT_FREE
                         : njnt == 3 && m->jnt_type[j] == mjJNT_SLIDE
                           && m->jnt_type[j + 1] == mjJNT_SLIDE && m->jnt_type[j + 2] == mjJNT_HINGE;
    if (!ok) {
      fail(p, "body '%s' needs %s", name,
           v->dim == 3 ? "one free joint" : "slide x, slide z, hinge y joints");
      return;
    }
    v->qadr[i] = m->jnt_qposadr[j];
    v->vadr[i] = m->jnt_dofadr[j];
  }
}

/* The robot's kind: dimension, voxel size, muscle timing and drive, bond element. */
static void configure_scene(mjrParse* p, mjrVoxels* v) {
  v->dim = (int)scalar(p, "dim");
  if (p->ok && v->dim != 2 && v->dim != 3) fail(p, "dim must be 2 or 3, got %d", v->dim);
  v->voxel_size = scalar(p, "voxel_size");
  if (p->ok && !(v->voxel_size > 0)) fail(p, "voxel_size must be > 0");
  v->omega = 2.0 * mjPI * scalar(p, "frequency");
  v->start = scalar(p, "start");
  if (*config(p->m, p->instance, "settle_rest")) {
    double* rest = doubles(p, "settle_rest", 2);
    if (rest) {
      v->rest_speed = rest[0];
      v->rest_window = rest[1];
      if (!(rest[0] >= 0.0 && rest[1] >= 0.0))
        fail(p, "settle_rest must be a speed and a time >= 0, got %g %g", rest[0], rest[1]);
    }
    free(rest);
  }
  v->contract = either(p, "waveform", "contract", "symmetric");
  v->ctrl_plus = v->ctrl_minus = -1;
  if (either(p, "drive", "ctrl", "waveform")) {
    v->ctrl_plus = mj_name2id(p->m, mjOBJ_ACTUATOR, "muscle_plus");
    v->ctrl_minus = mj_name2id(p->m, mjOBJ_ACTUATOR, "muscle_minus");
    if (v->ctrl_plus < 0 || v->ctrl_minus < 0)
      fail(p, "drive 'ctrl' needs the actuators 'muscle_plus' and 'muscle_minus'");
  }
  v->beams = either(p, "element", "beam", "tendons");
}

/* Each voxel's half muscle amplitude (m) of the two phases, from its phase and strain. */
static void configure_muscles(mjrParse* p, mjrVoxels* v) {
  int n = v->nvox;
  double* phase = doubles(p, "phase", n);
  double* strain = doubles(p, "strain", n);
  if (p->ok) {
    v->half_p = (double*)calloc(n, sizeof(double));
    v->half_m = (double*)calloc(n, sizeof(double));
    for (int i = 0; i < n; i++) {
      double half = 0.5 * v->voxel_size * strain[i];
      if (phase[i] > 0) v->half_p[i] = half;
      if (phase[i] < 0) v->half_m[i] = half;
      if (phase[i] != 0 && strain[i] != 0) v->waves = 1;
    }
  }
  free(phase);
  free(strain);
}

/* The bonds: their voxels, axes and muscle weights (driven bonds first), and their
   beam rows or tendons. */
static void configure_bonds(mjrParse* p, mjrVoxels* v) {
  int n = v->nvox, nb = v->nbond, nt = v->ntendon;
  v->bonds = ints(p, "bonds", 2 * nb, 0, n - 1);
  v->axis = ints(p, "bond_axis", nb, 0, 2);
  v->muscle = doubles(p, "bond_muscle", 2 * nb);
  if (p->ok) {
    while (v->ndriven < nb && (v->muscle[2 * v->ndriven] != 0 || v->muscle[2 * v->ndriven + 1] != 0))
      v->ndriven++;
    for (int b = v->ndriven; b < nb && p->ok; b++) {
      if (v->muscle[2 * b] != 0 || v->muscle[2 * b + 1] != 0)
        fail(p, "bond %d is driven but follows passive bonds; driven bonds come first", b);
    }
    for (int b = 0; b < 2 * nb; b++) v->muscle[b] *= v->voxel_size;
    if (v->ndriven) v->waves = 1;
  }
  if (v->beams) {
    v->stiffness = doubles(p, "bond_stiffness", 4 * nb);
    v->law = doubles(p, "bond_axial_law", 3 * nb);
    v->beta = doubles(p, "bond_beta", 3 * nb);
    return;
  }
  v->tendon_bond = ints(p, "tendon_bond", nt, 0, nb - 1);
  v->sites = doubles(p, "tendon_sites", 6 * nt);
  v->tk = doubles(p, "tendon_stiffness", nt);
  v->tc = doubles(p, "tendon_damping", nt);
  v->trest = doubles(p, "tendon_rest", nt);
  v->tlat2 = doubles(p, "tendon_lateral2", nt);
  for (int t = 1; t < nt && p->ok; t++) {
    if (v->tendon_bond[t] < v->tendon_bond[t - 1])
      fail(p, "tendon %d: a bond's tendons must be consecutive, in bond order", t);
  }
}

/* The floor: its springs, dampers, friction and stick rule. */
static void configure_floor(mjrParse* p, mjrVoxels* v) {
  int n = v->nvox;
  v->floor = (int)scalar(p, "floor");
  v->fk = doubles(p, "floor_stiffness", n);
  v->fc = doubles(p, "floor_damping", n);
  v->mu_s = doubles(p, "static_friction", n);
  v->mu_k = doubles(p, "kinetic_friction", n);
  v->friction_momentum = either(p, "friction_stop", "momentum", "energy");
  v->stop_time = scalar(p, "friction_stop_time");
  if (p->ok && !(v->stop_time >= 0.0)) fail(p, "friction_stop_time must be >= 0");
}

/* Self-collision (spheres, springs, the pairs that never collide) and drag. */
static void configure_collision_and_drag(mjrParse* p, mjrVoxels* v) {
  int n = v->nvox;
  v->coll_radius = scalar(p, "collision_radius");
  v->coll_skin = scalar(p, "collision_skin");
  v->ck = doubles(p, "collision_stiffness", n);
  v->cc = doubles(p, "collision_damping", n);
  int* hops = ints(p, "collision_hops", 1, 0, 1000);
  if (hops) v->coll_hops = *hops;
  free(hops);
  v->grid = ints(p, "grid", 3 * n, -1000000, 1000000);
  v->collides = ints(p, "collides", n, 0, 1);
  v->drag_lin = doubles(p, "drag_linear", n);
  v->drag_rot = doubles(p, "drag_rotational", n);
}

/* What the step derives once from the parsed configuration: the beams' arrays, whether
   drag and the collision stage run, the collision reach, and the work arrays. */
static void derive(mjrVoxels* v) {
  int n = v->nvox, colliders = 0;
  double largest = 0.0;
  for (int i = 0; i < n; i++) {
    colliders += v->collides[i];
    if (v->half_p[i] > largest) largest = v->half_p[i];
    if (v->half_m[i] > largest) largest = v->half_m[i];
  }
  if (v->beams) arrange_beams(v);
  for (int i = 0; i < n; i++) v->drag |= v->drag_lin[i] > 0.0 || v->drag_rot[i] > 0.0;
  v->collide = v->coll_radius > 0 && colliders > 1;
  if (v->collide) {
    v->coll_near = never_colliding(v);
    v->collide = some_pair_may_collide(v);  /* else no collision stage at all */
  }
  v->coll_reach = 2.0 * v->coll_radius * (1.0 + 2.0 * largest / v->voxel_size);
  v->state = (double*)calloc((size_t)MJR_STATE * n, sizeof(double));
  v->scratch = (double*)calloc((size_t)MJR_SCRATCH * n, sizeof(double));
  v->stick_next = (double*)calloc(n, sizeof(double));
  v->coll_ref = (double*)calloc(3 * n, sizeof(double));
  v->coll_pairs = (int*)calloc(v->collide ? (size_t)colliders * (colliders - 1) : 2, sizeof(int));
}

/* The instance's configuration, parsed; NULL with a message in `error` on bad input. */
static mjrVoxels* configure(const mjModel* m, int instance, char* error, int error_sz) {
  mjrParse parse = {m, instance, error, error_sz, 1};
  mjrParse* p = &parse;
  if (m->opt.integrator != mjINT_EULER) {
    /* the floor's stick rule and the muscles' time are defined per Euler step */
    fail(p, "the model's integrator must be Euler (the floor's stick state and the muscle "
         "drive advance once per Euler step)");
    return NULL;
  }
  mjrVoxels* v = (mjrVoxels*)calloc(1, sizeof(mjrVoxels));
  configure_scene(p, v);
  if (p->ok) {
    v->nvox = count_tokens(config(m, instance, "voxels"));
    v->nbond = count_tokens(config(m, instance, "bond_axis"));
    v->ntendon = v->beams ? 0 : count_tokens(config(m, instance, "tendon_bond"));
    if (v->nvox == 0) fail(p, "the robot has no voxels ('voxels' is empty)");
  }
  if (p->ok) bind_bodies(p, v);
  configure_muscles(p, v);
  configure_bonds(p, v);
  configure_floor(p, v);
  configure_collision_and_drag(p, v);
  if (!p->ok) {
    release(v);
    return NULL;
  }
  derive(v);
  return v;
}

mjrVoxels* mjr_instance(const mjModel* m, const mjData* d, int instance) {
  if (instance < 0 || instance >= m->nplugin || m->plugin[instance] != plugin_slot) return NULL;
  return (mjrVoxels*)d->plugin_data[instance];
}

/* Joint position rows per voxel: 7 in 3D, 3 in 2D. */
static int position_rows(int dim) { return dim == 3 ? 7 : 3; }

/* The stick flags, and with a settle rest its slots and the held positions. */
static int nstate(const mjModel* m, int instance) {
  int n = count_tokens(config(m, instance, "voxels"));
  if (strtod(config(m, instance, "settle_rest"), NULL) > 0.0)
    n += MJR_REST_POS + position_rows((int)strtod(config(m, instance, "dim"), NULL)) * n;
  return n;
}

static int init(const mjModel* m, mjData* d, int instance) {
  char error[512] = "";
  mjrVoxels* v = configure(m, instance, error, sizeof(error));
  if (!v) mju_error("%s", error);
  d->plugin_data[instance] = (uintptr_t)v;
  return 0;
}

static void destroy(mjData* d, int instance) {
  release((mjrVoxels*)d->plugin_data[instance]);
  d->plugin_data[instance] = 0;
}

static void copy(mjData* dest, const mjModel* m, const mjData* src, int instance) {
  (void)src;
  char error[512] = "";
  mjrVoxels* v = configure(m, instance, error, sizeof(error));
  if (!v) mju_error("%s", error);
  dest->plugin_data[instance] = (uintptr_t)v;
}

static void reset(const mjModel* m, mjtNum* plugin_state, void* plugin_data, int instance) {
  mjrVoxels* v = (mjrVoxels*)plugin_data;
  memset(plugin_state, 0, nstate(m, instance) * sizeof(mjtNum));
  if (v) {
    memset(v->stick_next, 0, v->nvox * sizeof(double));
    v->coll_built = 0;
  }
}

/* Whether the muscles are off at d's time (the rule of forces.c's drive: the time rounded
   to a whole step, before `start`). */
static int muscles_off(const mjModel* m, const mjData* d, const mjrVoxels* v) {
  double dt = m->opt.timestep;
  return floor(d->time / dt + 0.5) * dt < v->start;
}

int mjr_holding(const mjModel* m, const mjData* d, const mjrVoxels* v, const mjtNum* state) {
  return v->rest_speed > 0.0 && state[v->nvox + MJR_REST_HELD] != 0.0 && muscles_off(m, d, v);
}

/* Every voxel slower than the rest threshold: velocity rows (3D: 3 linear, 3 angular; 2D:
   2 linear, 1 angular), linear ones in voxel lengths/s. */
static int quiet(const mjrVoxels* v) {
  const size_t N = (size_t)v->nvox;
  const double* w = v->state + MJR_QVEL * N;
  int linear = v->dim == 3 ? 3 : 2, rows = v->dim == 3 ? 6 : 3;
  double fast = 0.0;
  for (int k = 0; k < rows; k++) {
    double limit = k < linear ? v->rest_speed * v->voxel_size : v->rest_speed;
    for (size_t n = 0; n < N; n++) fast += fabs(w[k * N + n]) >= limit ? 1.0 : 0.0;
  }
  return fast == 0.0;
}

int mjr_settle_rest(const mjModel* m, const mjData* d, mjrVoxels* v, mjtNum* state) {
  if (!(v->rest_speed > 0.0)) return 0;
  mjtNum* rest = state + v->nvox;
  if (rest[MJR_REST_HELD] != 0.0 || !muscles_off(m, d, v)) return 0;
  if (!quiet(v)) {
    rest[MJR_REST_QUIET] = 0.0;
    return 0;
  }
  if (rest[MJR_REST_QUIET] == 0.0) {
    rest[MJR_REST_QUIET] = 1.0;
    rest[MJR_REST_SINCE] = d->time;
  }
  if (d->time - rest[MJR_REST_SINCE] < v->rest_window) return 0;
  const size_t N = (size_t)v->nvox;
  rest[MJR_REST_HELD] = 1.0;
  memcpy(rest + MJR_REST_POS, v->state + MJR_QPOS * N,
         (size_t)position_rows(v->dim) * N * sizeof(double));
  memset(v->state + MJR_QVEL * N, 0, (size_t)(v->dim == 3 ? 6 : 3) * N * sizeof(double));
  return 1;
}

static void compute(const mjModel* m, mjData* d, int instance, int capability_bit) {
  (void)capability_bit;
  mjrVoxels* v = (mjrVoxels*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  v->held = mjr_holding(m, d, v, state);
  if (v->held) return; /* held still until the muscles start: no force */
  mjr_forces(m, d, v, state, 0);
}

/* mj_step's advance: the stick flags decided by the last compute become state, and the
   settle's rest is tracked; a held step's motion (gravity alone) is undone. */
static void advance(const mjModel* m, mjData* d, int instance) {
  mjrVoxels* v = (mjrVoxels*)d->plugin_data[instance];
  mjtNum* state = d->plugin_state + m->plugin_stateadr[instance];
  const size_t N = (size_t)v->nvox;
  if (v->held) {
    mjr_load_state(v, d);
    memcpy(v->state + MJR_QPOS * N, state + N + MJR_REST_POS,
           (size_t)position_rows(v->dim) * N * sizeof(double));
    memset(v->state + MJR_QVEL * N, 0, (size_t)(v->dim == 3 ? 6 : 3) * N * sizeof(double));
    mjr_store_state(v, d);
    return;
  }
  memcpy(state, v->stick_next, N * sizeof(mjtNum));
  if (v->rest_speed > 0.0) {
    mjr_load_state(v, d);
    if (mjr_settle_rest(m, d, v, state)) mjr_store_state(v, d);
  }
}

/* the bonds as lines between voxel centres, when tendons are shown */
static void visualize(const mjModel* m, mjData* d, const mjvOption* opt, mjvScene* scn,
                      int instance) {
  (void)m;
  mjrVoxels* v = (mjrVoxels*)d->plugin_data[instance];
  if (!v || !opt->flags[mjVIS_TENDON]) return;
  const float rgba[4] = {0.15f, 0.15f, 0.15f, 1.0f};
  for (int b = 0; b < v->nbond && scn->ngeom < scn->maxgeom; b++) {
    mjvGeom* g = scn->geoms + scn->ngeom;
    mjv_initGeom(g, mjGEOM_LINE, NULL, NULL, NULL, rgba);
    mjv_connector(g, mjGEOM_LINE, 2.0, d->xpos + 3 * v->body[v->bonds[2 * b]],
                  d->xpos + 3 * v->body[v->bonds[2 * b + 1]]);
    g->category = mjCAT_DECOR;
    scn->ngeom++;
  }
}

/* Bond forces only (no muscles, floor, self-collision, drag) at d's qpos/qvel, into
   d->qfrc_passive (zeroed first): the network whose stability limit sets the time step. */
void mjr_network_forces(const mjModel* m, mjData* d, int instance) {
  mjrVoxels* v = mjr_instance(m, d, instance);
  mju_zero(d->qfrc_passive, m->nv);
  if (v) mjr_forces(m, d, v, d->plugin_state + m->plugin_stateadr[instance], 1);
}

mjPLUGIN_LIB_INIT(mjregen_voxels) {
  mjpPlugin plugin;
  mjp_defaultPlugin(&plugin);
  plugin.name = "mjregen.voxels";
  plugin.capabilityflags |= mjPLUGIN_PASSIVE;
  plugin.nattribute = MJR_NATTRIBUTE;
  plugin.attributes = attributes;
  plugin.nstate = nstate;
  plugin.init = init;
  plugin.destroy = destroy;
  plugin.copy = copy;
  plugin.reset = reset;
  plugin.compute = compute;
  plugin.advance = advance;
  plugin.visualize = visualize;
  plugin_slot = mjp_registerPlugin(&plugin);
}
