"""Rigid-block limit analysis by linear programming: the collapse load factor of rigid blocks on no-tension
Coulomb joints, its mechanism, and whether the dead load alone stands.

The structure is an assembly of rigid blocks in contact through plane joints; the ground is a block without an
equilibrium equation. The static (lower-bound) formulation of Livesley (1978, *Limit analysis of structures formed
from rigid blocks*, Int. J. Numer. Meth. Eng. 12:1853) as Gilbert & Melbourne (1994, *Rigid-block analysis of
masonry structures*, The Structural Engineer 72(21):356) apply it to masonry arches (the program RING): the joint
forces are the unknowns, equilibrium of every block the equalities, the joints' yield conditions the inequalities,
and the live load's factor the objective. Units are SI throughout: m, N, N·m; velocities are virtual and
dimensionless in scale. The scene's ring as blocks: :mod:`bridgefem.limit.ring_blocks`.

**Joints.** Joint ``j`` is the segment from its start point ``a_j`` to its end point ``b_j`` (for a ring: intrados
to extrados), with length ``t_j``, centre ``c_j``, unit tangent ``T_j = (b_j - a_j)/t_j`` and unit normal
``N_j = (T_y, -T_x)``, which must point from the joint's *left* block into its *right* block. Its statics are

* ``n_j >= 0`` the normal (compressive) force, N;
* ``s_j`` the shear force, N;
* ``m_j = n_j e_j`` the moment of the normal force about ``c_j``, N·m, where ``e_j`` is the position of the thrust
  along ``T_j`` measured from ``c_j`` (``m > 0``: thrust on the extrados/``b`` side).

The left block pushes the right block with the force ``n N + s T`` acting at ``c + e T``, i.e. with moment ``-m``
about ``c`` (because ``T x N = -1``); the left block receives the opposite.

**Equilibrium** of every block ``k`` (forces x, y and moment about its reference point ``r_k``)::

    sum_j (joint contributions) + d_k + lambda l_k = 0        (A q + lambda l = -d)

with ``d_k``, ``l_k`` the generalised dead and live loads (Fx, Fy, M about ``r_k``). **Yield** (per joint, the rows of
the joints' law, :meth:`bridgefem.laws.base.JointLaw.block_yield`; for :class:`bridgefem.laws.coulomb.CoulombJoints`)::

    |m_j| <= n_j t_j / 2          no tension: the thrust lies within the joint
    |s_j| <= mu_j n_j + c_j       Coulomb friction (associative: c_j = 0)

With a compressive strength (:mod:`bridgefem.laws.crushing`, the scene's law: :func:`ring_model`) the moment row
becomes the tangent polygon of |m_j| <= n_j (t_j - n_j / (f_c w)) / 2. The deficit programmes relax each joint's rows
as :meth:`bridgefem.laws.base.BlockYield.relaxations` says; :func:`statics` reads the law's moment capacity; the
Tresca fixed point's admissibility test reads the shear rows as Coulomb's.

**Interfaces and cohesion.** A joint may be one straight *piece* of a longer joint of the structure
(``BlockModel.joint_ids``: a curved ring interface is its chords, each an LP joint). A piece of an *interface*
(``BlockModel.interface``: the bed between two rings) never crushes: whatever the law, its moment rows are the
no-tension rows ``|m_j| <= n_j t_j / 2`` (a row of the law on the moment keeps its shear coefficient and takes
``-t_j / 2`` on ``n`` and 0 on the right-hand side). ``BlockModel.cohesion`` (N per joint, default 0) is a shear
capacity at no normal force, ``|s_j| <= mu_j n_j + c_j``, in every programme (a ring interface's mortar bond:
``ring_cohesion`` x chord length x width).

The programme maximises the load factor ``lambda >= 0`` (``scipy.optimize.linprog``, HiGHS), once the deficit
programme below has found that the dead load stands. A deficit above zero is "unstable under self-weight" (no
statically admissible state at lambda = 0 exists, whatever the flow rule, and the live load follows the self-weight,
as in the FE): so, too, where a live load would steady blocks that cannot carry their own weight (a load on a pier
that leans under its spans' thrust), whose load programme alone is feasible at some lambda > 0. HiGHS can end a
programme with no status at all ("model_status is Unknown"): :class:`LPFailure`.

:func:`solve_blocks`, step by step:

1. assemble the programme (:class:`_Programme`): the equilibrium matrix ``A`` (3 rows per block, 3 columns per
   joint), four yield rows per joint, the live load as the column of ``lambda``; forces are divided by the total
   dead weight so that the unknowns are of order one;
2. with a live load, solve the deficit programme first: a deficit is "unstable under self-weight" (above);
3. solve the load programme with HiGHS (interior point and crossover: a basic solution with its duals);
4. for non-associative friction, iterate the Tresca fixed point below from the associative solution or a seed;
5. read the mechanism off the equilibrium duals: the block velocities, each joint's relative rotation and slip,
   the hinges and the sliding joints.

**Mechanism.** The equilibrium duals are the block virtual velocities ``(u, v, omega)`` at ``r_k`` (the velocity
is ``minus`` HiGHS' marginals, normalised so that the live load does unit work). At a joint the relative motion of
the right block with respect to the left one is described by the relative rotation ``[omega]``, the slip
``T . [v]`` and the opening ``N . [v](e) = N . [v](c) - e [omega]``. Since the opening is nonnegative along the
joint, a hinge with ``[omega] > 0`` is at the end ``b`` (extrados) and one with ``[omega] < 0`` at ``a`` (intrados).
Virtual work: ``d . u + lambda l . u = D`` where ``D = sum c_j |z_j|`` is the cohesive dissipation (zero for the
associative programme without cohesion, hence ``d . u = -lambda``). The mechanism by the structure's joints
(:func:`joint_mechanism`, ``LPResult.by_joint``): a joint of one piece is a hinge or slides as above; a joint of
interface pieces (a ring interface) *separates* where a piece opens beyond the dilatancy of its slip,
``max_e N . [v](e) - mu |T . [v]| = N . [v](c) + |[omega]| t/2 - mu |slip| > 0``, and slides where a piece slips;
it is never a hinge.

**Non-associative friction** (Gilbert, Casapulla & Ahmed 2006, Computers & Structures 84:873): associative
friction lets sliding joints dilate and overestimates the collapse load. The *Tresca fixed point* replaces the
Coulomb line of every joint by a fixed shear capacity ``|s| <= mu n~`` (no ``n`` term: the LP's flow rule then
slides without opening, no dilatancy) with the normal forces ``n~`` of a seed (given, e.g. an FE state's joint
forces, or the associative solution's), solves the LP, relaxes ``n~ <- n~ + beta (n - n~)`` and repeats until
the load factor is steady *and* the LP's own state obeys ``|s| <= mu n`` (:func:`_solve`). That state and the
LP's mechanism form a non-associative collapse state: equilibrium with no tension and Coulomb friction, and a
mechanism of hinges and slips without dilatancy on which the loads' work equals the friction dissipation
``mu n~ |slip|`` at the sliding joints, where ``|s| = mu n~`` and ``n ~ n~``. Its load factor never exceeds the
associative one (its state is admissible there). Non-associative collapse states are not unique (they depend on
the normal forces, e.g. the clamping left in the blocks), so a fixed point is one of them, reached from its seed,
never a bound; where a ring's collapse is statically determinate (hinges plus sliding joints, one degree of
freedom) the associative solution is itself a fixed point. A single Tresca LP (:func:`frozen_capacity_collapse`,
capacities frozen at given normal forces) is itself a standard problem with bound theorems (a shear limit
independent of the normal force: Livesley 1978, part I); how the FE uses both: :mod:`bridgefem.analysis.evidence`,
docs/joints-and-lp.md.

**Dead load only**: the *deficit* programme (:func:`dead_load_deficit`) minimises ``tau >= 0``, a uniform tensile
strength at the joint edges and cohesion that equilibrium needs (``|m| <= (n + tau) t/2``, ``|s| <= mu n + tau``).
The blocks stand when ``tau = 0``; otherwise the duals give the mechanism (dead-load work > 0).
:func:`standing_deficit` also lets ``n`` go down to ``-tau``: the static theorem under dead load for joint forces
known only to a tolerance. :func:`statics` evaluates the programme's rows at given joint forces (an FE state's).

Safeguards:

- *force scaling*: every force is divided by the total dead weight, so that the unknowns are of order one on a
  small ring and a large one alike and HiGHS' absolute tolerances keep their meaning;
- *self-weight first*: HiGHS may return no status for a load programme that has no feasible point (a ring that
  cannot carry its own weight), and a programme feasible only above lambda = 0 would report a collapse load of
  blocks that cannot carry their own weight; the deficit programme, solved first, proves both cases;
- ``MECHANISM_TOL``: a relative rotation or slip below this fraction of the largest one is round-off, not a hinge
  or a slip, so that the mechanism lists only the joints that move;
- ``_DEFICIT_TOL``: a deficit below this fraction of the dead weight is the LP's round-off: the blocks stand;
- *fixed-point stop*: the Tresca iteration stops only when ``lambda`` is steady over ``_WINDOW`` LPs *and* its state
  obeys Coulomb's law, so that neither a pause in a slow drift nor a steady load factor on a state that breaks
  Coulomb's law is taken for a collapse state; after ``FIXED_POINT_LPS`` LPs it returns its last state with
  ``converged = False``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

from ..laws.base import BlockYield, JointLaw
from ..laws.coulomb import CoulombJoints

FRICTION_MODELS = ("associative", "non-associative")
MECHANISM_TOL = 1e-6  # relative size below which a relative rotation or slip counts as zero
_DEFICIT_TOL = 1e-9  # deficit tau / dead weight below this is zero: LP round-off, the blocks stand
_WINDOW = 6  # non-associative iterations: converged when lambda is steady over this many LPs
RELAXATION = 0.6  # Tresca fixed point: n~ <- n~ + RELAXATION (n - n~) between LPs
FIXED_POINT_RTOL = 1e-6  # Tresca fixed point: tolerance on lambda and on the Coulomb condition
FIXED_POINT_LPS = 200  # Tresca fixed point: LPs at most
_LP_METHOD = "highs-ipm"  # HiGHS interior point + crossover (basic solution and duals): 5x faster than simplex


@dataclass(frozen=True)
class BlockModel:
    """Generic rigid-block data; ``nb`` blocks, ``nj`` joints, ground = block id -1.

    ref: (nb, 2) reference point of each block (m), about which ``dead``/``live`` moments are taken;
    dead, live: (nb, 3) generalised loads (Fx, Fy in N; M in N·m, counter-clockwise), live for unit load factor;
    joint_a, joint_b: (nj, 2) joint start and end points (m); the normal (T_y, -T_x) must point left -> right;
    joint_left, joint_right: (nj,) block ids (-1: ground); friction: (nj,) Coulomb coefficients;
    law: the joints' law, whose :meth:`bridgefem.laws.base.JointLaw.block_yield` gives their yield rows;
    joint_ids: (nj,) the structure's joint each joint is a piece of (None: joint k is the structure's joint k);
    interface: (nj,) bool, the pieces of interfaces between rings, which never crush and separate rather than hinge
    (None: none); cohesion: (nj,) shear capacity at no normal force, N (None: none). Module docstring,
    *Interfaces and cohesion*.
    """

    ref: np.ndarray
    dead: np.ndarray
    live: np.ndarray
    joint_a: np.ndarray
    joint_b: np.ndarray
    joint_left: np.ndarray
    joint_right: np.ndarray
    friction: np.ndarray
    law: type[JointLaw] | JointLaw = CoulombJoints
    joint_ids: np.ndarray | None = None
    interface: np.ndarray | None = None
    cohesion: np.ndarray | None = None

    @property
    def n_blocks(self) -> int:
        return len(self.ref)

    @property
    def n_joints(self) -> int:
        return len(self.joint_a)

    @property
    def structure_joints(self) -> np.ndarray:
        """(nj,) the structure's joint id of each joint (``joint_ids``, or 0 .. nj - 1)."""
        return np.arange(self.n_joints) if self.joint_ids is None else np.asarray(self.joint_ids, int)

    @property
    def interfaces(self) -> np.ndarray:
        """(nj,) bool: the pieces of interfaces between rings (``interface``, or none)."""
        return np.zeros(self.n_joints, bool) if self.interface is None else np.asarray(self.interface, bool)

    @property
    def cohesions(self) -> np.ndarray:
        """(nj,) shear capacity at no normal force, N (``cohesion``, or zeros)."""
        return np.zeros(self.n_joints) if self.cohesion is None else np.asarray(self.cohesion, float)

    def pieces_at(self, joints: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For points ``position`` (m) along the structure's ``joints`` (from their start), the LP joint that holds
        each (the piece of its joint whose stretch of the summed chord lengths contains it; the last piece beyond)
        and the point's distance (m) from that piece's start."""
        joints, position = np.asarray(joints, int), np.asarray(position, float)
        if self.joint_ids is None:
            return joints, position
        ids = self.structure_joints
        t = self.frames()[0]
        start = np.zeros(self.n_joints)  # each piece's distance from its joint's start
        for j in np.unique(ids):
            k = np.flatnonzero(ids == j)
            start[k] = np.concatenate([[0.0], np.cumsum(t[k])[:-1]])
        piece = np.empty(len(joints), int)
        for j in np.unique(joints):
            at, k = joints == j, np.flatnonzero(ids == j)
            piece[at] = k[np.clip(np.searchsorted(start[k], position[at], side="right") - 1, 0, len(k) - 1)]
        return piece, position - start[piece]

    def frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Joint lengths t (m), centres c, unit tangents T and unit normals N (arrays over joints)."""
        d = self.joint_b - self.joint_a
        t = np.linalg.norm(d, axis=1)
        tang = d / t[:, None]
        return t, 0.5 * (self.joint_a + self.joint_b), tang, np.column_stack([tang[:, 1], -tang[:, 0]])


def generalised_loads(ref: np.ndarray, blocks, points, forces) -> np.ndarray:
    """(nb, 3) loads (Fx, Fy, M about ``ref``) from forces (k, 2) in N applied at points (k, 2) on given blocks."""
    blocks = np.asarray(blocks, int)
    points, forces = np.atleast_2d(points).astype(float), np.atleast_2d(forces).astype(float)
    arm = points - ref[blocks]
    out = np.zeros((len(ref), 3))
    np.add.at(out, blocks, np.column_stack([forces, arm[:, 0] * forces[:, 1] - arm[:, 1] * forces[:, 0]]))
    return out


@dataclass(frozen=True)
class JointMechanism:
    """A mechanism by the structure's joints (:attr:`BlockModel.joint_ids`): the ids of the joints that are hinges,
    where each hinge sits ("intrados": at its start point, "extrados": at its end), the joints that slide and the
    interfaces that separate."""

    hinges: list[int] = field(default_factory=list)
    hinge_positions: dict[int, str] = field(default_factory=dict)
    sliding: list[int] = field(default_factory=list)
    separated: list[int] = field(default_factory=list)


@dataclass
class LPResult:
    """Outcome of a rigid-block analysis (all arrays over joints/blocks in model order).

    load: total live load at collapse, N (level x sum of live forces; None without live load);
    level: multiplier of the live-load pattern (for scenes the pattern is ``factor`` N per load, so this is
    the load level in N); level_associative: the associative value (differs only for non-associative runs);
    level_seeded: non-associative runs, the level of the first Tresca LP (shear capacities mu x the seed's normal
    forces; None without an optimum);
    status: "limit load found" | "unstable under self-weight" | "no collapse (unbounded)";
    hinges / sliding: the model's joints with a relative rotation / slip in the mechanism; hinge_positions: joint ->
    "intrados" (start point a) | "extrados" (end point b); joint_forces: n (N), s (N), m (N·m);
    block_velocities: (nb, 3) u, v (m/s-like) and omega (rad) at the reference points, live-load work = 1
    (dead-load-only problems: largest block speed = 1); joint_rotation, joint_slip: relative motions;
    work_dead, work_live: d.u and l.u; dissipation: cohesive dissipation of the last non-associative LP;
    iterations: LPs solved; converged: False if the non-associative iteration hit its limit; time_s: wall time (s);
    load_sides: per scene load, the block ("left" | "right" | "split") that carries it when it lies on a joint,
    else None (:func:`bridgefem.limit.collapse.collapse_load`); by_joint: the mechanism by the structure's joints
    (:func:`joint_mechanism`: a ring interface's chords are one joint, which separates or slides).
    """

    load: float | None
    level: float | None
    status: str
    friction_model: str = "associative"
    level_associative: float | None = None
    level_seeded: float | None = None
    hinges: list[int] = field(default_factory=list)
    hinge_positions: dict[int, str] = field(default_factory=dict)
    sliding: list[int] = field(default_factory=list)
    joint_forces: dict[str, np.ndarray] = field(default_factory=dict)
    block_velocities: np.ndarray | None = None
    joint_rotation: np.ndarray | None = None
    joint_slip: np.ndarray | None = None
    work_dead: float | None = None
    work_live: float | None = None
    dissipation: float = 0.0
    iterations: int = 0
    converged: bool = True
    time_s: float = 0.0
    load_sides: list[str | None] = field(default_factory=list)
    by_joint: JointMechanism = field(default_factory=JointMechanism)

    def to_dict(self) -> dict:
        """JSON-serialisable copy (arrays become lists, joint ids stay ints)."""
        def conv(v):
            if isinstance(v, np.ndarray):
                return v.tolist()
            if isinstance(v, dict):
                return {(int(k) if isinstance(k, (int, np.integer)) else k): conv(x) for k, x in v.items()}
            if isinstance(v, (list, tuple)):
                return [conv(x) for x in v]
            if isinstance(v, np.generic):
                return v.item()
            if isinstance(v, JointMechanism):
                return conv(v.__dict__)
            return v
        return {k: conv(v) for k, v in self.__dict__.items()}


class _Programme:
    """Sparse LP data of a block model.

    Unknowns ``x = (n_0, s_0, m_0, n_1, ..., extra)`` with one extra scalar (the load factor or the deficit).
    Forces are scaled by ``fref`` (the total dead weight) so that the unknowns are O(1).
    """

    def __init__(self, model: BlockModel):
        self.model = model
        nb, nj = model.n_blocks, model.n_joints
        t, c, tang, nrm = model.frames()
        self.t = t
        self.fref = float(np.abs(model.dead[:, :2]).sum()) or 1.0
        rows, cols, vals = [], [], []
        for blocks, sign in ((model.joint_right, 1.0), (model.joint_left, -1.0)):
            j = np.nonzero(blocks >= 0)[0]
            k = blocks[j]
            arm = c[j] - model.ref[k]
            rows.append(3 * k[:, None] + np.array([0, 0, 1, 1, 2, 2, 2]))
            cols.append(3 * j[:, None] + np.array([0, 1, 0, 1, 0, 1, 2]))
            vals.append(sign * np.column_stack([
                nrm[j, 0], tang[j, 0], nrm[j, 1], tang[j, 1],
                arm[:, 0] * nrm[j, 1] - arm[:, 1] * nrm[j, 0],    # moment of n N about r_k
                arm[:, 0] * tang[j, 1] - arm[:, 1] * tang[j, 0],  # moment of s T about r_k
                -np.ones(len(j))]))
        self.A = sp.csr_matrix((np.concatenate(vals).ravel(),
                                (np.concatenate(rows).ravel(), np.concatenate(cols).ravel())),
                               shape=(3 * nb, 3 * nj))
        self.b_eq = -model.dead.ravel() / self.fref
        n_min = self.joint_yield(np.asarray(model.friction, float)).n_min / self.fref
        lo = np.append(np.column_stack([n_min, np.full((nj, 2), -np.inf)]).ravel(), 0.0)
        self.bounds = np.column_stack([lo, np.full(3 * nj + 1, np.inf)])

    def joint_yield(self, mu: np.ndarray, capacity: np.ndarray | None = None) -> BlockYield:
        """The joints' yield rows (their law's, :meth:`bridgefem.laws.base.JointLaw.block_yield`) with the Coulomb
        coefficients ``mu`` and the shear capacity at no normal force of the model's cohesion plus ``capacity`` (N;
        default none); on interface pieces the no-tension moment rows (:func:`_no_crushing`)."""
        model = self.model
        shear = model.cohesions if capacity is None else model.cohesions + capacity
        rules = model.law.block_yield(self.t, mu, shear)
        return _no_crushing(rules, self.t, model.interfaces) if model.interfaces.any() else rules

    def yield_rows(self, mu: np.ndarray, extra: np.ndarray) -> sp.csr_matrix:
        """The yield rows of every joint (for Coulomb ``+-m - n t/2`` and ``+-s - mu n``, 4 per joint), then
        column ``extra`` (4 nj,)."""
        nj = self.model.n_joints
        rules = self.joint_yield(mu)
        k, j = rules.per_joint, np.arange(nj)[:, None]
        rows, cols = k * j + rules.rows, 3 * j + rules.cols
        g = sp.csr_matrix((rules.vals.ravel(), (rows.ravel(), cols.ravel())), shape=(k * nj, 3 * nj))
        return sp.hstack([g, sp.csr_matrix(extra[:, None])], format="csr")

    def rhs(self, cohesion: np.ndarray) -> np.ndarray:
        """The right-hand sides of the yield rows with the shear ``cohesion`` (N per joint), scaled."""
        return self.joint_yield(np.asarray(self.model.friction, float), cohesion).rhs.ravel() / self.fref

    def solve(self, mu: np.ndarray, cohesion: np.ndarray, deficit: bool, floor: float = 0.0):
        """One LP; the extra unknown is lambda (maximised) or, if ``deficit``, tau (minimised).

        load:    max lambda   s.t. A q + lambda l = -d,  |m| <= n t/2,  |s| <= mu n + c
        deficit: min tau >= floor s.t. A q = -d,  |m| <= (n + tau) t/2,  |s| <= mu n + c + tau
        ``tau`` is the smallest tensile strength at the joint edges and cohesion (a force, uniform over the
        joints) that equilibrium under the dead load needs: zero when the dead load alone can be carried.
        ``floor`` (scaled by the dead weight, <= 0) lets tau go below zero (:func:`dead_load_margin`).
        """
        nj = self.model.n_joints
        if deficit:
            extra_col = sp.csr_matrix((self.A.shape[0], 1))
            extra_ub = self.joint_yield(mu).relaxations()[0].ravel()  # Coulomb: -(t/2, t/2, 1, 1) per joint
            cost_extra = 1.0
        else:
            extra_col = sp.csr_matrix(self.model.live.ravel()[:, None])
            extra_ub = np.zeros(self.joint_yield(mu).per_joint * nj)
            cost_extra = -1.0
        cost = np.zeros(3 * nj + 1)
        cost[-1] = cost_extra
        bounds = self.bounds
        if floor:
            bounds = bounds.copy()
            bounds[-1, 0] = floor
        return linprog(cost, A_ub=self.yield_rows(mu, extra_ub), b_ub=self.rhs(cohesion),
                       A_eq=sp.hstack([self.A, extra_col], format="csr"), b_eq=self.b_eq,
                       bounds=bounds, method=_LP_METHOD)


def _no_crushing(rules: BlockYield, t: np.ndarray, interface: np.ndarray) -> BlockYield:
    """``rules`` with the moment rows of the ``interface`` joints made the no-tension rows: each row on the moment
    m takes ``-t/2`` on the normal force and 0 on its right-hand side, so that it reads ``+-m - n t/2 <= 0`` (t: the
    joints' lengths, m) whatever the law's compressive strength; their least normal force is 0."""
    moment = np.zeros(rules.per_joint, bool)
    moment[rules.rows[rules.cols == 2]] = True
    on_n = (rules.cols == 0) & moment[rules.rows]
    vals, rhs = rules.vals.copy(), rules.rhs.astype(float)
    vals[np.ix_(interface, on_n)] = -t[interface, None] / 2
    rhs[np.ix_(interface, moment)] = 0.0
    return rules._replace(vals=vals, rhs=rhs, n_min=np.where(interface, 0.0, rules.n_min))


def _relative_velocity(model: BlockModel, vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative velocity [v] (nj, 2) at each joint's centre and relative rotation [omega] (nj,) of the right block
    with respect to the left one, for block velocities ``vel`` (nb, 3)."""
    _, c, _, _ = model.frames()
    padded = np.vstack([vel, np.zeros(3)])  # index -1: the ground, at rest
    ref = np.vstack([model.ref, np.zeros(2)])

    def at_centre(blocks):
        u = padded[blocks]
        arm = c - ref[blocks]
        return np.column_stack([u[:, 0] - u[:, 2] * arm[:, 1], u[:, 1] + u[:, 2] * arm[:, 0]]), u[:, 2]

    v_r, w_r = at_centre(model.joint_right)
    v_l, w_l = at_centre(model.joint_left)
    return v_r - v_l, w_r - w_l


def relative_motion(model: BlockModel, vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative rotation [omega] and slip T.[v] of the right block with respect to the left one at each joint."""
    dv, rot = _relative_velocity(model, vel)
    return rot, np.einsum("ij,ij->i", dv, model.frames()[2])


@dataclass(frozen=True)
class JointMotion:
    """What a mechanism does at the joints: ``rotation`` [omega] (rad) and ``slip`` T.[v] (m) per joint
    (:func:`relative_motion`), and the ids of the joints that rotate (``hinges``: not interface pieces), slide
    (``sliding``) and, interface pieces, open beyond their slip's dilatancy (``separated``; module docstring)."""

    rotation: np.ndarray
    slip: np.ndarray
    hinges: list[int]
    sliding: list[int]
    separated: list[int] = field(default_factory=list)


def joint_motion(model: BlockModel, vel: np.ndarray, other_speed: float = 0.0) -> JointMotion:
    """The joints that the block velocities ``vel`` (nb, 3) move. A joint is a hinge (sliding) where its relative
    rotation times the model's extent (its slip) exceeds ``MECHANISM_TOL`` x the largest motion: the largest such
    rotation or slip, or ``other_speed`` (e.g. the largest speed of a fill that moves with the blocks); an interface
    piece is no hinge but separated where its largest opening beyond its slip's dilatancy,
    ``N.[v](c) + |[omega]| t/2 - mu |slip|``, exceeds the same."""
    dv, rot = _relative_velocity(model, vel)
    t, _, tang, nrm = model.frames()
    slip = np.einsum("ij,ij->i", dv, tang)
    size = np.ptp(np.vstack([model.joint_a, model.joint_b]), axis=0).max()  # extent of the model, m
    scale = max(np.abs(rot).max() * size, np.abs(slip).max(), other_speed, 1e-300)
    interface = model.interfaces
    opening = np.einsum("ij,ij->i", dv, nrm) + np.abs(rot) * t / 2 - model.friction * np.abs(slip)
    return JointMotion(rot, slip,
                       [int(j) for j in np.nonzero((np.abs(rot) * size > MECHANISM_TOL * scale) & ~interface)[0]],
                       [int(j) for j in np.nonzero(np.abs(slip) > MECHANISM_TOL * scale)[0]],
                       [int(j) for j in np.nonzero((opening > MECHANISM_TOL * scale) & interface)[0]])


def joint_mechanism(model: BlockModel, motion: JointMotion) -> JointMechanism:
    """``motion`` by the structure's joints: a joint is a hinge, slides or separates when one of its pieces does
    (a joint of one piece: its hinge's position from the sign of its rotation)."""
    ids = model.structure_joints

    def mapped(joints):
        return sorted({int(ids[j]) for j in joints})

    return JointMechanism(mapped(motion.hinges),
                          {int(ids[j]): ("extrados" if motion.rotation[j] > 0 else "intrados") for j in motion.hinges},
                          mapped(motion.sliding), mapped(motion.separated))


def _fill_result(res: LPResult, model: BlockModel, prog: _Programme, sol, cohesion: np.ndarray) -> None:
    """Joint forces, mechanism (from the equilibrium duals) and work terms of an optimal LP."""
    nj = model.n_joints
    q = sol.x[:3 * nj].reshape(nj, 3) * prog.fref
    res.joint_forces = {"n": q[:, 0], "s": q[:, 1], "m": q[:, 2]}
    vel = -np.asarray(sol.eqlin.marginals).reshape(-1, 3)
    if res.level is None:  # dead load only: largest block speed = 1
        speed = np.hypot(vel[:, 0], vel[:, 1]).max()
        vel = vel / speed if speed > 0 else vel
    motion = joint_motion(model, vel)
    res.block_velocities, res.joint_rotation, res.joint_slip = vel, motion.rotation, motion.slip
    res.hinges, res.sliding = motion.hinges, motion.sliding
    res.hinge_positions = {j: ("extrados" if motion.rotation[j] > 0 else "intrados") for j in res.hinges}
    res.by_joint = joint_mechanism(model, motion)
    res.work_dead = float(model.dead.ravel() @ vel.ravel())
    res.work_live = float(model.live.ravel() @ vel.ravel())
    z = np.asarray(sol.ineqlin.marginals)
    res.dissipation = float(-(prog.rhs(cohesion) @ z) * prog.fref) if res.level is not None else 0.0


class LPFailure(RuntimeError):
    """HiGHS gave no answer for a programme (its message says why)."""


def _status(sol, model: BlockModel, prog: _Programme, friction_model: str) -> LPResult:
    """An LPResult carrying the outcome of a load-factor LP (forces and mechanism still empty)."""
    if sol.status == 2:
        return LPResult(None, None, "unstable under self-weight", friction_model)
    if sol.status == 3 or not np.any(model.live):
        return LPResult(None, None, "no collapse (unbounded)", friction_model)
    if sol.status != 0:
        raise LPFailure(f"rigid-block LP failed: {sol.message}")
    lam = float(sol.x[-1] * prog.fref)
    total_live = float(np.hypot(model.live[:, 0], model.live[:, 1]).sum())
    return LPResult(lam * total_live, lam, "limit load found", friction_model)


def _solve(prog: _Programme, deficit: bool, friction_model: str, beta: float, rtol: float, max_iterations: int,
           seed: np.ndarray | None = None):
    """Solve the associative LP, then (non-associative) the Tresca fixed point of the module docstring.

    Returns the last solution, its shear capacities (N, the ``cohesion`` of the Tresca rows; zero for the
    associative LP), the number of LPs, whether the iteration reached a fixed point, and the values of the extra
    unknown (unscaled; None without an optimum) of the associative LP and of the first Tresca LP (capacities
    ``mu`` x the seed; None for the associative programme).

    Iteration k solves the LP with ``|s| <= mu n~`` (capacities fixed, no ``n`` term) and relaxes
    ``n~ <- n~ + beta (n - n~)``, from ``n~`` = ``seed`` (N, per joint) or the associative normal forces. It stops
    at a fixed point: the extra unknown (lambda or tau, scaled by the dead weight) steady to ``rtol`` over the last
    ``_WINDOW`` LPs *and* the LP's own state Coulomb-admissible, ``|s| <= mu n`` on every joint to ``rtol`` x the
    largest normal force (:func:`_coulomb_excess`). An iteration LP without optimum ends the iteration.
    """
    if friction_model not in FRICTION_MODELS:
        raise ValueError(f"friction_model = {friction_model!r}: allowed are {', '.join(FRICTION_MODELS)}")
    mu = np.asarray(prog.model.friction, float)
    cohesion = np.zeros(prog.model.n_joints)
    sol = prog.solve(mu, cohesion, deficit)
    iterations = 1
    first = sol.x[-1] * prog.fref if sol.status == 0 else None
    if friction_model == "associative" or (sol.status != 0 and seed is None):
        return sol, cohesion, iterations, True, (first, None)
    n_tilde = np.asarray(seed, float) / prog.fref if seed is not None else sol.x[0:-1:3].copy()
    history, seeded = [], None
    for _ in range(max_iterations):
        cohesion = mu * n_tilde * prog.fref
        sol = prog.solve(np.zeros_like(mu), cohesion, deficit)
        iterations += 1
        if sol.status != 0:
            break
        n = sol.x[0:-1:3]
        history.append(sol.x[-1])
        seeded = history[0] * prog.fref
        last = history[-_WINDOW:]
        steady = len(last) == _WINDOW and max(last) - min(last) <= rtol * max(abs(last[-1]), 1.0)
        if steady and _coulomb_excess(sol.x, mu, prog.model.cohesions / prog.fref) <= rtol:
            return sol, cohesion, iterations, True, (first, seeded)
        n_tilde = n_tilde + beta * (n - n_tilde)
    return sol, cohesion, iterations, False, (first, seeded)


def _coulomb_excess(x: np.ndarray, mu: np.ndarray, cohesion: np.ndarray) -> float:
    """Largest excess of a state's shear over its own Coulomb limit, ``max(|s| - mu n - c)`` / the largest ``n``
    (``x`` and the ``cohesion`` c in the programme's scaled forces)."""
    q = x[:-1].reshape(-1, 3)
    return float(np.max(np.abs(q[:, 1]) - mu * q[:, 0] - cohesion) / max(q[:, 0].max(), 1e-300))


def solve_blocks(model: BlockModel, friction_model: str = "associative", *, seed: np.ndarray | None = None,
                 beta: float = RELAXATION, rtol: float = FIXED_POINT_RTOL,
                 max_iterations: int = FIXED_POINT_LPS, self_weight: bool = True) -> LPResult:
    """Collapse load factor of a block model (see the module docstring for the programme).

    friction_model: "associative" (one LP; an upper bound when joints slide) or "non-associative" (the Tresca fixed
    point of Gilbert, Casapulla & Ahmed 2006: ``seed`` the starting normal forces, N per joint, default the
    associative ones; ``beta`` the under-relaxation of the normal forces, ``rtol`` the tolerance on lambda and on
    the Coulomb condition, ``max_iterations`` the number of Tresca LPs). ``converged`` says whether a fixed point
    (a non-associative collapse state) was reached. ``self_weight=False``: the caller has found that the blocks
    carry their dead load (:func:`dead_load_deficit` of the same blocks and dead load), so step 2 is skipped.
    """
    start = time.perf_counter()
    if self_weight and np.any(model.live):  # the self-weight first: the deficit programme decides
        _, dead = dead_load_deficit(model)  # statics alone: a deficit rules out every flow rule's equilibrium
        if dead.status == "unstable under self-weight":
            dead.friction_model, dead.time_s = friction_model, time.perf_counter() - start
            return dead
    prog = _Programme(model)
    sol, cohesion, iterations, converged, levels = _solve(prog, False, friction_model, beta, rtol, max_iterations,
                                                          seed)
    res = _status(sol, model, prog, friction_model)  # no status, though the blocks carry their weight: LPFailure
    res.level_associative, res.level_seeded = levels
    if res.level is not None:
        _fill_result(res, model, prog, sol, cohesion)
    res.iterations, res.converged, res.time_s = iterations, converged, time.perf_counter() - start
    return res


@dataclass(frozen=True)
class Statics:
    """How far given joint forces are from the programme's constraints at a load level (:func:`statics`):
    ``equilibrium`` (nb, 3), the residual ``A q + level l + d`` of every block (Fx, Fy in N; M in N·m about its
    reference point; zero in equilibrium); per joint ``tension`` = -n (N), ``friction`` = |s| - mu n - c (N, c the cohesion)
    and ``eccentricity`` = |m| - the law's moment capacity (N·m; Coulomb and interface pieces: n t/2, with crushing
    the tangent polygon of :mod:`bridgefem.laws.crushing`), each <= 0 where the yield conditions hold."""

    equilibrium: np.ndarray
    tension: np.ndarray
    friction: np.ndarray
    eccentricity: np.ndarray


def statics(model: BlockModel, level: float, forces: np.ndarray) -> Statics:
    """The programme's equality and yield rows (module docstring) evaluated at joint forces ``forces`` (nj, 3: n, s
    in N, m in N·m about the joint centre) and load level ``level``: whether a state, e.g. an FE state's joint
    resultants, is statically admissible for these blocks (then ``level`` is at most their collapse load factor,
    the static theorem)."""
    prog = _Programme(model)
    n, s, m = np.asarray(forces, float).T
    residual = prog.A @ np.asarray(forces, float).ravel() + level * model.live.ravel() + model.dead.ravel()
    capacity = np.where(model.interfaces, n * prog.t / 2, model.law.moment_capacity(prog.t, n))
    return Statics(residual.reshape(-1, 3), -n, np.abs(s) - model.friction * n - model.cohesions,
                   np.abs(m) - capacity)


def frozen_capacity_collapse(model: BlockModel, normal_forces: np.ndarray) -> LPResult:
    """The collapse of the blocks with every joint's shear capacity frozen at ``mu n~`` (``normal_forces`` n~, N
    per joint): the first Tresca LP of :func:`solve_blocks` (``level``, mechanism, joint forces).

    Its yield rows ``|m| <= n t/2``, ``|s| <= mu n~`` are convex and its mechanism obeys their normality (slips
    without opening, rotations about a joint's edge), so the bound theorems of limit analysis hold (Livesley 1978,
    part I, module docstring): ``level`` is *the* collapse load factor of these
    blocks, at least that of any statically admissible state, and the LP duality makes every optimal state do
    exactly the mechanism's dissipation ``mu n~ |slip|`` (complementary slackness)."""
    return solve_blocks(model, "non-associative", seed=normal_forces, max_iterations=1)


def dead_load_deficit(model: BlockModel, friction_model: str = "associative", *, beta: float = RELAXATION,
                      rtol: float = FIXED_POINT_RTOL, max_iterations: int = FIXED_POINT_LPS) -> tuple[float, LPResult]:
    """Smallest uniform joint tensile strength and cohesion ``tau`` (N) that the dead load needs, and the LP outcome.

    ``tau = 0``: the blocks carry their dead load ("stable under self-weight"); ``tau > 0``: they do not
    ("unstable under self-weight"), and the mechanism (equilibrium duals, dead-load work > 0, largest block speed
    1) is how they fail. Options as in :func:`solve_blocks`.
    """
    start = time.perf_counter()
    prog = _Programme(model)
    sol, cohesion, iterations, converged, _ = _solve(prog, True, friction_model, beta, rtol, max_iterations)
    if sol.status != 0:
        raise LPFailure(f"rigid-block deficit LP failed: {sol.message}")
    tau = float(sol.x[-1] * prog.fref)
    res = LPResult(None, None, "unstable under self-weight" if sol.x[-1] > _DEFICIT_TOL else "stable under self-weight",
                   friction_model)
    _fill_result(res, model, prog, sol, cohesion)
    res.iterations, res.converged, res.time_s = iterations, converged, time.perf_counter() - start
    return tau, res


def dead_load_margin(model: BlockModel) -> float:
    """The associative deficit programme of :func:`dead_load_deficit` with ``tau`` free down to minus the dead
    weight W (N): its least ``tau``,

        min tau >= -W  s.t.  A q = -d,  |m| <= (n + tau) t/2,  |s| <= mu n + tau

    positive: the deficit (the same optimum); negative: the blocks stand with room, every joint's thrust and shear
    carried with ``-tau`` to spare at its edges and on its friction (the floor bounds it where the room has no
    end, e.g. a thick flat ring). Where the deficit stays zero on the whole side that stands, the margin keeps
    changing through zero, so that a search over a dimension (:func:`bridgefem.limit.thickness.min_thickness`) can
    interpolate across the change from falling to standing. Raises :class:`LPFailure` when the LP fails."""
    prog = _Programme(model)
    sol = prog.solve(np.asarray(model.friction, float), np.zeros(model.n_joints), True, floor=-1.0)
    if sol.status != 0:
        raise LPFailure(f"rigid-block margin LP failed: {sol.message}")
    return float(sol.x[-1] * prog.fref)


def standing_deficit(model: BlockModel) -> float:
    """The least uniform joint tension and cohesion tau (N) with which the blocks carry their dead load when every
    joint may also carry a net tension of tau (0: they stand):

        min tau >= 0  s.t.  A q = -d,  n >= -tau,  |m| <= (n + tau) t/2,  |s| <= mu n + tau

    the deficit programme of :func:`dead_load_deficit` with its ``n >= 0`` relaxed to ``n >= -tau``, solved in
    ``nu = n + tau >= 0``. Any state that violates no tension, the thrust's place and Coulomb's law by at most those
    amounts is a point of it, so a deficit above them proves that no such state exists (the static theorem under
    dead load; :class:`bridgefem.analysis.evidence.StaticBound`). Raises :class:`LPFailure` when the LP fails."""
    prog = _Programme(model)
    nj = model.n_joints
    mu = np.asarray(model.friction, float)
    extra = prog.joint_yield(mu).relaxations()[1].ravel()  # n = nu - tau in the rows (Coulomb: 0, 0, mu-1, mu-1)
    shift = -np.asarray(prog.A[:, 0::3].sum(axis=1)).ravel()  # ... and in equilibrium
    cost = np.zeros(3 * nj + 1)
    cost[-1] = 1.0
    sol = linprog(cost, A_ub=prog.yield_rows(mu, extra), b_ub=prog.rhs(np.zeros(nj)),
                  A_eq=sp.hstack([prog.A, sp.csr_matrix(shift[:, None])], format="csr"), b_eq=prog.b_eq,
                  bounds=prog.bounds, method=_LP_METHOD)
    if sol.status != 0:
        raise LPFailure(f"rigid-block deficit LP failed: {sol.message}")
    return float(sol.x[-1] * prog.fref)
