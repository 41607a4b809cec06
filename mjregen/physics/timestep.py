"""The time step of a robot, decided once at compile time and stored in the model only.

Two rules (the pipeline's ``timestep_rule``), both `Scene.timestep_safety` × a stability
limit of semi-implicit Euler:

- "network": the limit of the robot's own bond network. Semi-implicit Euler on a mode
  x'' + c x' + ω² x = 0 is stable iff h²ω² + 2hc ≤ 4. For the whole robot, ω² ≤ λ =
  λ_max(M⁻¹K) and c ≤ μ = λ_max(M⁻¹C), with K and C the stiffness and damping of the bonds
  linearised at rest (C = βK per bond: the mode with the largest ω² also has the largest c
  when β is uniform), so the step h = (√(μ² + 4λ) − μ) / λ. λ and μ are found by Lanczos
  iteration on the mass-weighted operators M^-½ K M^-½ and M^-½ C M^-½, applied
  matrix-free as central differences of the voxel plugin's bond forces
  (``mjr_network_forces``: the very forces the simulation integrates) about the rest state:
  K y from displacements (positions and rotations, through ``mj_integratePos``), C y from
  velocities, without self-collision or actuation. The engine floor is included as if
  every voxel touched it (its spring and damper on each voxel's vertical motion: the most
  any posture adds). Bonds whose muscles lengthen them stiffen, which the rest state leaves
  out: `strain_stiffening` bounds that (1 for the paper's contract-only muscles, 1.75 at
  ±50 %).
- "stiffest_bond" (and robots without bonds): the limit of a block of the robot's
  stiffest bond, the stiffest topology (`stiffest_bond_step`).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjregen.errors import PhysicsParameterError
from mjregen.physics import voxel_plugin
from mjregen.physics.params import Physics

LANCZOS_STEPS = 40
MODE_RATIO = 2.7  # fastest bond-network mode / a Timoshenko bond's sqrt(k/m)
RELATIVE_PROBE = 1e-7  # largest probe displacement, in voxel lengths (or radians)
BREAKDOWN = 1e-7  # Lanczos stops at a residual this small relative to the operator
CONVERGED = 1e-10  # ... or when its largest Ritz value moves less than this, relatively


def rotational_dofs(model: mujoco.MjModel) -> np.ndarray:
    """``(nv,)`` bool: the dofs that turn a body (hinges, free joints' last three), not
    slide it."""
    rotational = np.zeros(model.nv, dtype=bool)
    rotational[model.jnt_dofadr[model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE]] = True
    for adr in model.jnt_dofadr[model.jnt_type == mujoco.mjtJoint.mjJNT_FREE]:
        rotational[adr + 3: adr + 6] = True
    return rotational


class _NetworkForces:
    """The bond forces ``(nv,)`` of a voxel-plugin model at a perturbation of its rest state."""

    def __init__(self, model: mujoco.MjModel, *, voxel_size: float, instance: int,
                 floor_stiffness: np.ndarray | None, floor_damping: np.ndarray | None) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.instance = instance
        self._library = voxel_plugin.library()
        self.q0 = model.qpos0.copy()
        self.mass = np.zeros(model.nv)
        mujoco.mj_forward(model, self.data)  # the mass matrix
        mujoco.mj_mulM(model, self.data, self.mass, np.ones(model.nv))  # diagonal for voxels
        self.scale = 1.0 / np.sqrt(self.mass)  # mass-weighting S = M^-½
        # m per unit of each dof (a radian: one voxel length)
        self.dof_length = np.where(rotational_dofs(model), voxel_size, 1.0)
        self.voxel_size = voxel_size
        # the floor on every voxel's vertical dof, per mass (s⁻², s⁻¹)
        self.floor_k = np.zeros(model.nv) if floor_stiffness is None else floor_stiffness
        self.floor_c = np.zeros(model.nv) if floor_damping is None else floor_damping

    def forces(self, qvel_step: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """qfrc of the bonds at q0 ⊕ qvel_step (``mj_integratePos`` over 1 s), velocity."""
        data = self.data
        data.qpos[:] = self.q0
        mujoco.mj_integratePos(self.model, data.qpos, qvel_step, 1.0)
        data.qvel[:] = velocity
        self._library.mjr_network_forces(self.model._address, data._address, self.instance)
        return data.qfrc_passive.copy()

    def _epsilon(self, direction: np.ndarray) -> float:
        """Step along M^-½ `direction` whose largest displacement is RELATIVE_PROBE·L."""
        largest = float(np.max(np.abs(direction * self.scale) * self.dof_length))
        return RELATIVE_PROBE * self.voxel_size / max(largest, 1e-300)

    def stiffness(self, y: np.ndarray) -> np.ndarray:
        """M^-½ K M^-½ y (s⁻²)."""
        eps = self._epsilon(y)
        step = eps * self.scale * y
        zero = np.zeros_like(y)
        df = self.forces(step, zero) - self.forces(-step, zero)
        return -self.scale * df / (2.0 * eps) + self.floor_k * y

    def damping(self, y: np.ndarray) -> np.ndarray:
        """M^-½ C M^-½ y (s⁻¹)."""
        eps = self._epsilon(y)
        velocity = eps * self.scale * y
        zero = np.zeros_like(y)
        df = self.forces(zero, velocity) - self.forces(zero, -velocity)
        return -self.scale * df / (2.0 * eps) + self.floor_c * y


def largest_eigenvalue(apply, n: int, steps: int = LANCZOS_STEPS, seed: int = 0) -> float:
    """Largest eigenvalue of a symmetric operator `apply` on R^n (Lanczos with full
    reorthogonalisation, `steps` iterations, random start from `seed`).

    The iteration stops early when the Krylov space is spent: the residual is below
    BREAKDOWN × the largest coefficient so far, or the largest Ritz value has stopped
    moving (by less than CONVERGED of itself in each of the last two steps). Beyond that
    the basis would be built from the finite-difference operators' noise (and, for the
    engine's non-symmetric damping, its asymmetric part), whose coefficients grow without
    bound: small robots of several separate pieces have few distinct modes and spend their
    space in fewer than `steps` iterations."""
    if n == 0:
        return 0.0
    rng = np.random.default_rng(seed)
    q = rng.standard_normal(n)
    basis = [q / np.linalg.norm(q)]
    alphas, betas = [], []
    scale = 0.0  # the largest |coefficient| so far: the operator's size
    ritz = []  # the largest Ritz value after each step
    for k in range(min(steps, n)):
        w = apply(basis[k])
        alpha = float(basis[k] @ w)
        alphas.append(alpha)
        w = w - alpha * basis[k] - (betas[-1] * basis[k - 1] if k else 0.0)
        stack = np.array(basis)
        # full reorthogonalisation (einsum, not BLAS: OpenBLAS's threads would spin on)
        w -= np.einsum("kn,k->n", stack, np.einsum("kn,n->k", stack, w))
        beta = float(np.linalg.norm(w))
        scale = max(scale, abs(alpha), betas[-1] if betas else 0.0)
        ritz.append(_largest_ritz(alphas, betas))
        if beta <= BREAKDOWN * scale or beta == 0.0 or _converged(ritz):
            break
        betas.append(beta)
        basis.append(w / beta)
    return ritz[-1]


def _largest_ritz(alphas: list[float], betas: list[float]) -> float:
    """Largest eigenvalue of the Lanczos tridiagonal matrix of `alphas` (its diagonal)
    and the first len(alphas) - 1 `betas`."""
    size = len(alphas)
    tridiagonal = np.diag(alphas) + np.diag(betas[: size - 1], 1) + np.diag(betas[: size - 1], -1)
    return float(np.max(np.linalg.eigvalsh(tridiagonal)))


def _converged(ritz: list[float]) -> bool:
    """The largest Ritz value moved by less than CONVERGED of itself in each of the last
    two steps."""
    if len(ritz) < 3:
        return False
    top = abs(ritz[-1])
    return all(abs(ritz[-i] - ritz[-i - 1]) <= CONVERGED * top for i in (1, 2))


def network_rates(model: mujoco.MjModel, *, voxel_size: float, instance: int = 0,
                  floor_stiffness: np.ndarray | None = None,
                  floor_damping: np.ndarray | None = None,
                  held: np.ndarray | None = None) -> tuple[float, float]:
    """(λ s⁻², μ s⁻¹): the largest eigenvalues of M⁻¹K and M⁻¹C of the bond network.

    C of the paper engine's beam dampers (moment rows at half the force rows' ratio) is not
    symmetric; its eigenvalues are real, and the symmetric Lanczos estimate lands within
    3 % above the largest (measured on a bond pair and the paper's tripod), on the safe side.

    Args:
      model: a model with the voxel plugin as `instance` (its qpos0 is the rest state).
      voxel_size: L in m (the probes' scale).
      floor_stiffness, floor_damping: ``(nv,)`` s⁻² and s⁻¹, the floor's spring and damper
        per mass on each voxel's vertical dof (0 elsewhere), or None (no floor).
      held: ``(nv,)`` bool, dofs held still (left out of the modes), or None (none). The
        rotational dofs held are the network of voxels with infinite rotational inertia.
    """
    network = _NetworkForces(model, voxel_size=voxel_size, instance=instance,
                             floor_stiffness=floor_stiffness, floor_damping=floor_damping)
    n = network.model.nv
    stiffness, damping = network.stiffness, network.damping
    if held is not None:
        free = ~np.asarray(held, dtype=bool)
        if free.shape != (n,):
            raise PhysicsParameterError(
                f"held must be a ({n},) bool array (one per dof), got shape {free.shape}")
        stiffness, damping = (lambda y: free * network.stiffness(free * y),
                              lambda y: free * network.damping(free * y))
    return (largest_eigenvalue(stiffness, n), largest_eigenvalue(damping, n, seed=1))


def own_damping_rates(model: mujoco.MjModel, *, voxel_size: float,
                      instance: int = 0) -> np.ndarray:
    """``(nv,)`` s⁻¹: the diagonal of M⁻¹C of the bond network at rest, each dof's damping
    of its own velocity with every other dof still (one probe per dof).

    h times it is what a step that took each dof's own damping implicitly and the others'
    explicitly would add to its mass (or inertia), relatively: such a step is
    v' = v + h f / (m + h C_ii), f the explicit force.

    Args:
      model: a model with the voxel plugin as `instance` (its qpos0 is the rest state).
      voxel_size: L in m (the probes' scale).
    """
    network = _NetworkForces(model, voxel_size=voxel_size, instance=instance,
                             floor_stiffness=None, floor_damping=None)
    rates = np.empty(model.nv)
    probe = np.zeros(model.nv)
    for i in range(model.nv):
        probe[i] = 1.0
        rates[i] = network.damping(probe)[i]
        probe[i] = 0.0
    return rates


def strain_stiffening(beams, scene) -> float:
    """Largest factor by which a bond's modes stiffen over the rest lengths l its muscles
    command (>= 1). Two effects: the tendons' axial law k0 + kd l²/(l² + D²) stiffens
    along the axis, and the shear mode of two voxels (both turn by θ, their centres shift
    sideways by lθ/2) has ω² = k_s (2 + 3 (l/L)²)/m, 5 k_s/m at rest: the lever arm grows
    with l while the voxels' inertia does not. The damping (C = βK) stiffens alike.
    "contract" muscles only shorten their bonds (softer): 1.

    Args:
      beams: the robot's `BeamTable` (its axial laws and muscle weights, either element).
      scene: the `Scene` (voxel size, waveform).
    """
    driven = len(beams.muscle_weights)
    if scene.waveform == "contract" or driven == 0:
        return 1.0
    length = scene.voxel_size
    law = beams.axial_law[:driven]
    longest = length * (1.0 + np.abs(beams.muscle_weights).sum(axis=1))

    def tangent(rest: np.ndarray) -> np.ndarray:
        return law[:, 0] + law[:, 1] * rest ** 2 / (rest ** 2 + law[:, 2])

    axial = tangent(longest) / tangent(np.full(driven, length))
    shear = (2.0 + 3.0 * (longest / length) ** 2) / 5.0
    return float(max(1.0, np.max(axial), np.max(shear)))


def stable_step(stiffness_rate: float, damping_rate: float) -> float:
    """s: semi-implicit Euler's limit h with h²λ + 2hμ = 4."""
    if stiffness_rate <= 0.0:
        return math.inf if damping_rate <= 0.0 else 2.0 / damping_rate
    return (math.sqrt(damping_rate ** 2 + 4.0 * stiffness_rate) - damping_rate) / stiffness_rate


def stiffest_bond_step(physics: Physics, stiffness_per_mass: float) -> float:
    """Time step in s for the stiffest bond present (``timestep_rule="stiffest_bond"``,
    and robots without bonds): `timestep_safety` × the stability limit
    of semi-implicit Euler for the fastest mode of a block of that bond.

    A bond of stiffness k between voxels of mass m has frequency ω_b = sqrt(k/m)
    (`stiffness_per_mass` = k/m in s⁻², the largest over the robot's bonds). The network's
    fastest mode is ω = r·ω_b, and stiffness-proportional damping (c = 2ζ sqrt(mk)) gives
    it the damping ratio ζ·r. Semi-implicit Euler on x'' + 2ζr·ω x' + ω² x = 0 is stable
    iff dt·ω < 2 (sqrt(1 + (ζr)²) − ζr), so

        dt = safety × 2 (sqrt(1 + (ζr)²) − ζr) / (r ω_b).

    r = MODE_RATIO (2.7) for Timoshenko bonds, measured from where 4³ and 5³ blocks
    (interior voxels with 6 bonds: the stiffest topology) diverge at ζ = 1 and 2; shear-
    rigid bonds ("euler_bernoulli") have diagonals 2(1+ν) times stiffer, so r grows by
    sqrt(2(1+ν)) (measured: 4.4 from the limit at ζ = 0.4; predicted 4.44). These ratios
    are the tendon bundle's (and beams with its law and damping); the paper engine's beams,
    with their softer torsion and moment damping, are stable at longer steps (this rule is
    conservative for them; the network rule finds their limit). The paper engine's rule,
    0.9/(2π ω_b), ignores damping and the network; with ζ = 1 it diverges here.
    """
    if not (math.isfinite(stiffness_per_mass) and stiffness_per_mass > 0.0):
        raise PhysicsParameterError(
            f"stiffness_per_mass must be > 0 s⁻², got {stiffness_per_mass!r}")
    ratio = MODE_RATIO
    if physics.pipeline.bond_model == "euler_bernoulli":
        poisson = max(p.poisson_ratio for p in physics.materials.values())
        ratio *= math.sqrt(2.0 * (1.0 + poisson))
    damped = physics.scene.bond_damping_ratio * ratio
    limit = 2.0 * (math.sqrt(1.0 + damped * damped) - damped) / ratio
    return physics.scene.timestep_safety * limit / math.sqrt(stiffness_per_mass)


def engine_floor_rates(model: mujoco.MjModel, voxel_bodies: np.ndarray, *, dim: int,
                       stiffness: np.ndarray, damping: np.ndarray, masses: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """``(nv,)`` s⁻², s⁻¹: the engine floor's spring and damper per mass on each moving
    voxel's vertical dof (0 elsewhere), as if every voxel touched the floor.

    Args:
      voxel_bodies: ``(n,)`` body ids; stiffness, damping, masses: ``(n,)`` N/m, N·s/m, kg.
    """
    k, c = np.zeros(model.nv), np.zeros(model.nv)
    vertical = 2 if dim == 3 else 1
    for voxel, body in enumerate(voxel_bodies):
        if model.body_jntnum[body] == 0:
            continue
        dof = model.jnt_dofadr[model.body_jntadr[body]] + vertical
        k[dof] = stiffness[voxel] / masses[voxel]
        c[dof] = damping[voxel] / masses[voxel]
    return k, c
