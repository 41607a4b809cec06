/* mjregen voxel physics: one MuJoCo engine plugin ("mjregen.voxels") that computes every force
   of a soft voxel robot inside MuJoCo's passive stage, and a fast Euler stepper for models
   whose only forces it computes.

   Files: voxels.c (registration, configuration, lifecycle), forces.c (bonds, muscles,
   floor, self-collision, drag), step.c (the fast path of mj_step). All configuration comes
   from the plugin instance's attributes in the model (strings, read once per mjData in
   `init`); the state, in plugin_state, is the floor's stick flag of each voxel and, with
   `settle_rest`, the settle's rest (MJR_REST_*).
*/
#ifndef MJREGEN_VOXELS_H_
#define MJREGEN_VOXELS_H_

#include <mujoco/mujoco.h>

/* The configuration attributes, in the order the plugin registers them. Python checks its
   own keys against this list when it loads the library (`mjr_attribute`). */
#define MJR_ATTRIBUTES(X)                                                            \
  X(dim)              /* 2 or 3 */                                                   \
  X(voxel_size)       /* L, m */                                                     \
  X(voxels)           /* n body names, in voxel order */                            \
  X(frequency)        /* Hz of the muscles */                                        \
  X(start)            /* s: the muscles start (end of the settle) */                 \
  X(settle_rest)      /* (2) 1/s, s: the settle ends at rest once every voxel has   \
                         moved slower than [0] voxel lengths/s and turned slower than \
                         [0] rad/s for [1] s; the robot is then held still until the \
                         muscles start. Absent: the full settle */                   \
  X(waveform)         /* contract | symmetric */                                     \
  X(drive)            /* waveform | ctrl: strains from actuators muscle_plus/minus */ \
  X(phase)            /* (n) -1, 0, +1: muscle phase of each voxel */                \
  X(strain)           /* (n) linear strain amplitude of each voxel */                \
  X(element)          /* beam | tendons */                                           \
  X(bonds)            /* (nb, 2) voxel indices i j, j the +axis neighbour of i */    \
  X(bond_axis)        /* (nb) 0, 1, 2 */                                             \
  X(bond_muscle)      /* (nb, 2) w+ w-: rest length L (1 + w+ e+ + w- e-) */         \
  X(bond_stiffness)   /* beam: (nb, 4) axial N/m, transverse N/m, bending, torsion N m */ \
  X(bond_axial_law)   /* beam: (nb, 3) k straight N/m, k diagonal N/m, extent^2 m^2 */ \
  X(bond_beta)        /* beam: (nb, 3) s, damping per stiffness: forces, bending, torsion */ \
  X(tendon_bond)      /* tendons: (nt) bond of each tendon (bonds' tendons consecutive) */ \
  X(tendon_sites)     /* tendons: (nt, 6) m, site offsets in voxel i's and j's frames */ \
  X(tendon_stiffness) /* tendons: (nt) N/m */                                        \
  X(tendon_damping)   /* tendons: (nt) N s/m */                                      \
  X(tendon_rest)      /* tendons: (nt) m, rest length without actuation */           \
  X(tendon_lateral2)  /* tendons: (nt) m^2, lateral extent^2 (muscle rest length) */ \
  X(floor)            /* 1: the floor exists (plane z = 0) */                        \
  X(floor_stiffness)  /* (n) N/m */                                                  \
  X(floor_damping)    /* (n) N s/m */                                                \
  X(static_friction)  /* (n) */                                                      \
  X(kinetic_friction) /* (n) */                                                      \
  X(friction_stop)    /* momentum | energy: when a sliding voxel sticks */           \
  X(friction_stop_time) /* s, the momentum rule's impulse time; 0: the step */       \
  X(collision_radius) /* m at the voxel's nominal size; 0: no self-collision */      \
  X(collision_skin)   /* m, Verlet-list skin */                                      \
  X(collision_stiffness) /* (n) N/m; a pair: the harmonic mean */                    \
  X(collision_damping)   /* (n) N s/m; a pair: the harmonic mean */                  \
  X(collision_hops)   /* voxels within this many bond hops never collide; 0: grid   \
                         neighbours (face, edge, corner) never collide */            \
  X(grid)             /* (n, 3) grid indices */                                      \
  X(collides)         /* (n) 1: the voxel self-collides (it misses a face neighbour) */ \
  X(drag_linear)      /* (n) N s/m on every voxel centre */                          \
  X(drag_rotational)  /* (n) N m s on every voxel's rotation */

#define MJR_COUNT_ATTRIBUTE(name) +1
enum { MJR_NATTRIBUTE = 0 MJR_ATTRIBUTES(MJR_COUNT_ATTRIBUTE) };

/* plugin_state: the stick flags (nvox), then with `settle_rest` these slots and the held
   positions (the joint state's position rows, 7 nvox in 3D, 3 nvox in 2D). */
enum { MJR_REST_HELD = 0,   /* 1: at rest, held still until the muscles start */
       MJR_REST_QUIET = 1,  /* 1: every voxel slower than the threshold since ... */
       MJR_REST_SINCE = 2,  /* ... this time (s) */
       MJR_REST_POS = 3 };

/* Rows of the voxels' scratch (each nvox doubles), derived from the state each step:
   position, rotation matrix (row-major), velocity, angular velocity (world), force and
   torque (world, summed over the robot's forces), unit quaternion (w, x, y, z). */
enum { MJR_P = 0, MJR_R = 3, MJR_VEL = 12, MJR_W = 15, MJR_FORCE = 18, MJR_TORQUE = 21,
       MJR_QUAT = 24, MJR_SCRATCH = 28 };
/* Rows of the voxels' joint state (each nvox doubles): qpos (3D: position, quaternion;
   2D: x, z, angle) and qvel (3D: velocity, body-frame angular velocity; 2D: 3 rates). */
enum { MJR_QPOS = 0, MJR_QVEL = 7, MJR_STATE = 13 };

/* Beam bonds as a structure of arrays, so that the per-bond arithmetic runs as one loop the
   compiler vectorises: two blocks of rows of `stride` (= nbond) doubles, row r of block X
   at X + r * stride: constants from the configuration, and each step's outputs (added to
   the voxels in bond order). */
enum { /* constants */
  MJR_AXIS,                                    /* 0, 1, 2 (doubles: the data's width) */
  MJR_K_AXIAL, MJR_K_SHEAR, MJR_K_BEND, MJR_K_TWIST, /* N/m, N/m, N m, N m */
  MJR_BETA, MJR_BETA_BEND, MJR_BETA_TWIST,     /* s: damping per stiffness of the force
                                                  rows, the bending and the torsion */
  MJR_LAW_K0, MJR_LAW_KD, MJR_LAW_LAT2,        /* axial law: N/m, N/m, m^2 */
  MJR_MUSCLE_P, MJR_MUSCLE_M,                  /* m: rest L + muscle_p e+ + muscle_m e- */
  MJR_BEAM_CONSTANTS
};
enum { /* outputs */
  MJR_F = 0, MJR_TI = 3, MJR_TJ = 6,           /* world force on j (-F on i), torques */
  MJR_S2 = 9,                                  /* |vector part of q_i^-1 q_j|^2 */
  MJR_BEAM_OUTPUTS = 10
};
typedef struct {
  size_t stride;
  double *constants, *outputs;
} mjrBeams;

/* One robot's configuration and work space, per mjData (d->plugin_data[instance]). */
typedef struct {
  int dim, nvox, nbond, ntendon, ndriven;  /* driven bonds: 0 .. ndriven-1 */
  int contract, beams, floor, waves, collide;
  int ctrl_plus, ctrl_minus;  /* drive "ctrl": the actuators whose ctrl are the strains
                                 (e+, e-); -1: the waveform drives the muscles */
  double voxel_size, start, omega;
  double rest_speed;      /* 1/s: the settle's rest threshold (voxel lengths/s, rad/s); 0: off */
  double rest_window;     /* s the robot must stay below it */
  int held;               /* mj_step: this step's compute held the robot (no forces) */
  int* qadr;              /* (nvox) first qpos address, -1: welded to the world */
  int* vadr;              /* (nvox) first dof address, -1: welded */
  int* body;              /* (nvox) body ids */
  double* pos0;           /* (nvox, 3) body position at qpos 0 (2D, welded voxels) */
  double* half_p;         /* (nvox) m: L/2 strain of a "+" muscle voxel, else 0 */
  double* half_m;         /* (nvox) m: likewise "-" */
  int* bonds;             /* (nbond, 2) */
  int* axis;              /* (nbond) */
  double* muscle;         /* (nbond, 2) L w+, L w- */
  double* stiffness;      /* (nbond, 4) */
  double* law;            /* (nbond, 3) */
  double* beta;           /* (nbond, 3) */
  mjrBeams beam;          /* beams: the bonds as arrays (from the three above) */
  int* tendon_bond;       /* (ntendon) */
  double* sites;          /* (ntendon, 6) */
  double* tk;             /* (ntendon) */
  double* tc;             /* (ntendon) */
  double* trest;          /* (ntendon) */
  double* tlat2;          /* (ntendon) */
  double* fk;             /* (nvox) N/m floor stiffness */
  double* fc;             /* (nvox) N s/m floor damping */
  double* mu_s;           /* (nvox) */
  double* mu_k;           /* (nvox) */
  int friction_momentum;  /* sliding stops when mu_k N t >= m |v| (the paper engine, t the
                             step); 0: when the step's friction work exceeds the kinetic
                             energy */
  double stop_time;       /* s: t of the momentum rule; 0: the step */
  double coll_radius, coll_skin, coll_reach;
  double* ck;             /* (nvox) N/m collision stiffness (a pair: harmonic mean) */
  double* cc;             /* (nvox) N s/m collision damping (a pair: harmonic mean) */
  int coll_hops;          /* pairs within this many bond hops never collide; 0: face,
                             edge and corner grid neighbours never collide */
  int* grid;              /* (nvox, 3) */
  int* collides;          /* (nvox) */
  unsigned char* coll_near; /* (nvox * nvox bits) pairs that never collide */
  double* drag_lin;       /* (nvox) N s/m */
  double* drag_rot;       /* (nvox) N m s */
  int drag;               /* any drag */
  double* state;          /* (MJR_STATE, nvox): the joints' state as rows */
  double* scratch;        /* (MJR_SCRATCH, nvox) */
  double* stick_next;     /* (nvox) stick flags after this step (copied to plugin_state
                             by `advance`) */
  double* coll_ref;       /* (nvox, 3) positions when the Verlet list was built */
  int* coll_pairs;        /* (capacity, 2) */
  int coll_count, coll_built;
} mjrVoxels;

/* forces.c: add every force of the robot at d's state to d->qfrc_passive; the floor's stick
   flags for the end of this step go to v->stick_next (state: `stick`, nvox doubles).
   `network`: bonds only (no muscles, floor, self-collision or drag): the linear network
   whose stability limit sets the time step. */
void mjr_forces(const mjModel* m, mjData* d, mjrVoxels* v, const mjtNum* stick, int network);

/* forces.c: the same forces at the state rows v->state (not d's qpos/qvel; d gives time,
   ctrl and the applied forces), left in the scratch rows MJR_FORCE and MJR_TORQUE (world). */
void mjr_voxel_forces(const mjModel* m, mjData* d, mjrVoxels* v, const mjtNum* stick,
                      int network);

/* forces.c: d's qpos/qvel of the voxels into the state rows, and back (moving voxels) */
void mjr_load_state(mjrVoxels* v, const mjData* d);
void mjr_store_state(const mjrVoxels* v, mjData* d);

/* The generalized force of voxel n (its dofs' order) from the scratch rows s (nvox = N
   each): 3D the force and the body-frame torque R^T T, 2D (F_x, F_z, T_y); returns the
   number of dofs (6 or 3). */
static inline __attribute__((always_inline)) int mjr_generalized(
    const double* restrict s, size_t N, size_t n, int three, double* out) {
  const double* R = s + MJR_R * N + n;
  double T0 = s[MJR_TORQUE * N + n], T1 = s[(MJR_TORQUE + 1) * N + n],
         T2 = s[(MJR_TORQUE + 2) * N + n];
  if (!three) {
    out[0] = s[MJR_FORCE * N + n];
    out[1] = s[(MJR_FORCE + 2) * N + n];
    out[2] = T1;
    return 3;
  }
  for (int a = 0; a < 3; a++) {
    out[a] = s[(MJR_FORCE + a) * N + n];
    out[3 + a] = R[a * N] * T0 + R[(3 + a) * N] * T1 + R[(6 + a) * N] * T2;
  }
  return 6;
}

/* voxels.c: the instance's state on d (NULL if `instance` is not an mjregen.voxels plugin) */
mjrVoxels* mjr_instance(const mjModel* m, const mjData* d, int instance);

/* voxels.c: whether the step from d's time holds the robot still: it came to rest in the
   settle (`settle_rest`) and the muscles have not started. `state`: the instance's
   plugin_state. */
int mjr_holding(const mjModel* m, const mjData* d, const mjrVoxels* v, const mjtNum* state);

/* voxels.c: after a step's integration (the new state in v's rows, d's time advanced): with
   `settle_rest`, in the settle, track how long every voxel has been slower than the threshold;
   once for the window, the robot is at rest: its velocity rows are zeroed and its positions
   kept in `state`. Returns 1 when the rest begins (the rows changed). */
int mjr_settle_rest(const mjModel* m, const mjData* d, mjrVoxels* v, mjtNum* state);

#endif  /* MJREGEN_VOXELS_H_ */
