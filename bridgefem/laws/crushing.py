"""Masonry that crushes: unilateral contact, Coulomb friction and a finite compressive strength f_c (Pa) at every
masonry joint (:mod:`bridgefem.laws.base`; chosen by the scene's ``[masonry] compressive_strength``).

**The FE pairs.** Per pair k, with d = [d_n, d_t] (m; d_n > 0 opens) and lam = [lam_n, lam_t] (N; lam_n > 0
compression) as in :mod:`bridgefem.laws.coulomb`, and the pair's crushing force C_k = f_c w l_k (N; w the width, l_k
the pair's tributary length along its joint, m):

    0 <= lam_n <= C;   d_n > 0 -> lam_n = 0;   0 < lam_n < C -> d_n = 0;   d_n < 0 -> lam_n = C
    |lam_t| <= mu lam_n;  Delta d_t = 0 while |lam_t| < mu lam_n;  lam_t = -mu lam_n sign(Delta d_t) when it slips

a crushed pair closes further (d_n < 0, the crushing) at the constant force C: perfectly plastic in compression, the
rectangular stress block of f_c over the pair's tributary length. The normal law is the monotone graph lam_n in
[0, C] with d_n's sign, written without history (a crushed pair that unloads reopens at d_n = 0): under the growing
load of a limit analysis the crushed zones only grow, where the holonomic and the incremental (plastic closure kept)
laws coincide; an unloading crushed pair follows the holonomic path (stated, not modelled).

**States.** Coulomb's ``open``, ``stick``, ``slip`` and ``crushed`` (lam_n = C, d_t held) and ``crushed-slip``
(lam_n = C, lam_t = s mu C). **Classification** (Alart & Curnier 1991): sigma_n = lam_n - c d_n, sigma_t = lam_t -
c Delta d_t; a pair is closed iff sigma_n > 0, crushed iff sigma_n > C, slips iff |sigma_t| > mu clip(sigma_n, 0, C);
the law holds iff lam_n = clip(sigma_n, 0, C) and lam_t = clip(sigma_t, -mu lam_n, mu lam_n)
(:meth:`CrushingJoints.residual`; the box projection of Hintermüller, Ito & Kunisch 2002's active-set method). The
safeguards' operations are Coulomb's on the tangential state, each keeping a pair's crushed flag.

**The mechanism proof.** A crushed pair's normal row fixes its force, not its displacement, so a diverging mode may
close it (crush it further). By virtual work on a rigid-block hinge mode d, any equilibrium with 0 <= lam_n <= C at
every pair has load work W = -sum lam_n d_n <= sum C max(-d_n, 0): the crushed pairs' closing dissipates at most
C per unit closing. The proof of collapse asks for W above that dissipation (:class:`bridgefem.laws.base.ModeRules`
``crushing``; :func:`bridgefem.solver.mechanism.judge`).

**Rigid-block rows** (:meth:`CrushingJoints.block_yield`; the rigid-block LP and the conic bounds). A joint of depth
t and width w whose normal force n sits on a rectangular stress block of f_c at one edge carries the moment

    |m| <= g(n) = n (t - n / (f_c w)) / 2,   0 <= n <= N_c = f_c w t,

a convex (parabolic) set (Heyman 1966; Gilbert & Melbourne 1994 and LimitState:RING's crushing; Orduña & Lourenço
2005, J. Struct. Eng. 131, for crushing yield surfaces of block joints). It is replaced by its K + 1 tangents at
n_i = i N_c / K (i = 0..K), rows +-m - g'(n_i) n <= g(n_i) - g'(n_i) n_i with g'(n) = t/2 - n/(f_c w): an outer
polygon, whose first row is the no-tension row |m| <= n t/2 and whose last two bound n <= N_c. **Error bound**: two
neighbouring tangents meet halfway, where they exceed the parabola by delta = (N_c/K)^2 / (8 f_c w) = f_c w t^2 /
(8 K^2), 1/K^2 of the joint's largest moment f_c w t^2/8, and nowhere more. So the LP's collapse load is an upper
bound on the exact parabola's and exceeds it by at most sum_j delta_j |theta_j| per unit live-load work on the exact
mechanism (theta_j its hinge rotations; the support functions differ by at most delta |theta|). Shear rows: Coulomb's.
The conic bounds take the parabola exactly (:meth:`CrushingJoints.conic`, :meth:`CrushingJoints.block_cones`):
+-m <= n t/2 - n^2/(2 f_c w) is n^2 <= 2 u v with u = f_c w t/sqrt2 and v = sqrt2 (n t/2 -+ m)/t (u v = f_c w (n t/2
-+ m); u and v both of the order of N_c), the second-order cone |(sqrt2 n, u - v)| <= u + v, one per sign, with the
tangents at n = 0 and n = N_c as linear rows (exact with the cones): no row set then overstates or understates
the stress block, so the static bound stays a lower bound, and the programme stays small (128 tangents slow the
interior-point solver down).

The FE's pairs are this same polygon: p + 1 evenly spaced pairs per joint with trapezoidal tributary lengths (ends
t/(2p)), filled at C from one edge, give the joint resultants (n, m) whose hull is exactly the tangent polygon with
K = p (its vertices sit where one more pair has crushed, delta above the parabola). The static theorem's LP on the
FE's own joints therefore takes the FE's stations (:func:`fe_stations`; for degree 2, Simpson's weights): the FE's
equilibria obey its rows exactly, and the FE converges to the parabola as the mesh is refined. A compressed zone
thinner than the edge pair's tributary length sits on the edge pair alone, as if infinitely strong; the joints are
therefore graded towards both edges where the stress block needs it
(:func:`bridgefem.structure.grading.graded_nodes`, chosen from the LP's hinges by
:mod:`bridgefem.analysis.stress_block`): spacing that grows from the edge keeps the polygon outside the parabola up
to the joint's middle, by about f_c w (2 s_k^2 - s_0^2)/8 at a vertex (s_k the local spacing, s_0 the edge's);
within a budget of elements per joint, the finest grading that fits
(:func:`bridgefem.structure.grading.graded_within`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI

    from ..scene.model import Scene

from .base import BlockYield, ContactState, JointLaw, LawRows, ModeRules
from .coulomb import CoulombJoints

CRUSHING_KINDS = ("voussoir", "springing", "base", "pier")
"""The kinds of joint (:data:`bridgefem.geometry.ring.JOINT_KINDS`) whose pairs crush: the faces of masonry blocks; a
ring interface (the mortar between two rings) and the arch-fill interface never do."""
TANGENTS = 128
"""Tangent intervals K of the rigid-block rows (module docstring): a joint's moment capacity overstated by at most
1/K^2 (6.1e-5) of its largest, far below the LP's agreement with the FE (0.5 %); 2K + 4 rows per joint."""


@dataclass
class CrushingJoints(CoulombJoints):
    """Coulomb friction and the compressive ``strength`` f_c (Pa) over the joints' ``width`` w (m) (module
    docstring); ``capacity``: each pair's crushing force C = f_c w l (N); ``tangents``: the tangent intervals K of the
    rigid-block rows, or ``stations``: the (position, weight) fractions of the depth whose polygon they are
    (:meth:`polygon`)."""

    strength: float = math.inf
    width: float = 1.0
    capacity: np.ndarray | None = None
    tangents: int = TANGENTS
    stations: tuple[tuple[float, float], ...] | None = None

    CRUSHED: ClassVar[int] = 3
    CRUSHED_SLIP: ClassVar[int] = 4
    STATES: ClassVar[tuple[str, ...]] = ("open", "stick", "slip", "crushed", "crushed-slip")
    OUTPUT_CODES: ClassVar[dict[str, int]] = {"stick": 1, "slip": 2, "open": 3, "crushed": 4, "crushed-slip": 5}
    CANDIDATES: ClassVar[tuple[tuple[int, int], ...]] = CoulombJoints.CANDIDATES + (
        (CRUSHED, 0), (CRUSHED_SLIP, 1), (CRUSHED_SLIP, -1))
    _CRUSH: ClassVar[int] = CRUSHED - CoulombJoints.STICK  # a state's code + this: the same state, crushed

    @classmethod
    def for_pairs(cls, pairs, friction, c: np.ndarray, force_tol: float, *, strength: float = math.inf,
                  width: float = 1.0, ring_cohesion: float = 0.0) -> "CrushingJoints":
        """The law at ``pairs`` (:class:`bridgefem.fe.pairs.JointPairs`): C = ``strength`` x ``width`` x each pair's
        tributary length on the joints of :data:`CRUSHING_KINDS`, infinite elsewhere; the rest as
        :meth:`CoulombJoints.for_pairs`."""
        law = super().for_pairs(pairs, friction, c, force_tol, ring_cohesion=ring_cohesion, width=width)
        law.strength, law.width = float(strength), float(width)
        masonry = np.isin(pairs.kind, CRUSHING_KINDS)
        law.capacity = np.where(masonry, law.strength * law.width * np.asarray(pairs.length, float), np.inf)
        return law

    @classmethod
    def blocks(cls, strength: float, width: float, tangents: int = TANGENTS,
               stations: tuple[tuple[float, float], ...] | None = None) -> "CrushingJoints":
        """The law for rigid-block joints only (:attr:`bridgefem.limit.rigid_block.BlockModel.law`): no pairs."""
        empty = np.zeros(0)
        return cls(empty, empty, 0.0, strength=float(strength), width=float(width), capacity=empty,
                   tangents=int(tangents), stations=stations)

    # ----------------------------------------------------------------- vocabulary
    def crushed(self, active: ContactState) -> np.ndarray:
        """The crushed pairs (lam_n = C)."""
        return active.state >= self.CRUSHED

    def sliding(self, active: ContactState) -> np.ndarray:
        return (active.state == self.SLIP) | (active.state == self.CRUSHED_SLIP)

    def stress_block_depth(self, normal_force: float) -> float | None:
        """N / (f_c w) (m): the depth of the rectangular stress block at f_c that carries ``normal_force`` (N); None
        for an infinite strength."""
        if not math.isfinite(self.strength):
            return None
        return float(normal_force) / (self.strength * self.width)

    def _sticking(self, state: np.ndarray) -> np.ndarray:
        """The pairs whose shear row holds d_t: sticking and crushed ones."""
        return (state == self.STICK) | (state == self.CRUSHED)

    def _coulomb(self, active: ContactState) -> ContactState:
        """``active`` with the crushed flags dropped: Coulomb's states."""
        state = np.where(active.state >= self.CRUSHED, active.state - self._CRUSH, active.state).astype(np.int8)
        return ContactState(state, active.sign.copy())

    def _crush(self, active: ContactState, crushed: np.ndarray) -> ContactState:
        """Coulomb's ``active`` with the closed ones of ``crushed`` crushed. In place; returned."""
        flag = crushed & (active.state != self.OPEN) & (active.state < self.CRUSHED)
        active.state[flag] += self._CRUSH
        return active

    # ----------------------------------------------------------------- classify, assemble, converge
    def classify(self, prev: ContactState, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray
                 ) -> tuple[ContactState, np.ndarray]:
        """Coulomb's classification (:meth:`CoulombJoints.classify`) with the friction bound mu clip(sigma_n, 0, C),
        and crushed where sigma_n > C (hysteresis ``force_tol``); the violation of a pair that crushes or unloads
        from crushing is |sigma_n - C|."""
        sig_n = lam[:, 0] - self.c * d[:, 0]
        bounded = lam.copy()
        bounded[:, 0] = np.minimum(lam[:, 0], self.capacity + self.c * d[:, 0])  # sigma_n capped at C
        new, violation = super().classify(self._coulomb(prev), bounded, d, slip_ref)
        tol = self.force_tol
        was = self.crushed(prev)
        crushed = np.where(was, sig_n >= self.capacity - tol, sig_n > self.capacity + tol)
        violation = np.where((crushed != was) & (new.state != self.OPEN), np.abs(sig_n - self.capacity), violation)
        return self._crush(new, crushed), violation

    def residual(self, lam: np.ndarray, d: np.ndarray, slip_ref: np.ndarray) -> np.ndarray:
        """Alart-Curnier residual (N) per pair with the normal force projected on [0, C]."""
        return self._residual(lam, d, slip_ref, self.capacity)

    def rows(self, active: ContactState) -> LawRows:
        """Contact pairs keep d_n, crushed and open pairs carry a fixed lam_n (C, 0); sticking and crushed pairs
        keep d_t, sliding ones carry lam_t = s (mu lam_n + k)."""
        contact = (active.state == self.STICK) | (active.state == self.SLIP)
        stick = self._holding(active)
        return LawRows(contact.astype(float), stick.astype(float), (~contact).astype(float), (~stick).astype(float),
                       -self.mu * active.sign * self.sliding(active))

    def rhs(self, active: ContactState, slip_ref: np.ndarray, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A contact pair's gap and a sticking pair's slip stay those of the last converged step (d = G u +
        ``ground``); a crushed pair carries lam_n = C; a sliding pair's shear has the cohesion's part s k (N)."""
        contact = (active.state == self.STICK) | (active.state == self.SLIP)
        r_n = np.where(contact, -self.c * ground[:, 0], np.where(self.crushed(active), self.capacity, 0.0))
        return r_n, self._shear_rhs(active, slip_ref, ground)

    def free_directions(self, active: ContactState) -> tuple[np.ndarray, np.ndarray]:
        """Open pairs are free in both directions, crushed ones normally, sliding ones tangentially."""
        return (active.state == self.OPEN) | self.crushed(active), ~self._holding(active)

    # ----------------------------------------------------------------- the solver's safeguards
    def hold(self, active: ContactState, pairs: np.ndarray) -> None:
        """The closed ones of ``pairs`` stick (crushed ones stay crushed); open ones stay open."""
        crushed = self.crushed(active)
        super().hold(active, pairs)
        self._crush(active, crushed & pairs)

    def hold_reversals(self, new: ContactState, old: ContactState) -> None:
        """A pair proposed to slide against its slip of ``old`` sticks instead (crushed ones stay crushed)."""
        crushed = self.crushed(new)
        view = self._coulomb(new)
        super().hold_reversals(view, self._coulomb(old))
        new.state[:], new.sign[:] = self._crush(view, crushed).state, view.sign

    def hold_opposed_slips(self, new: ContactState, old: ContactState, joint: np.ndarray, comm: MPI.Comm) -> None:
        """Coulomb's rule (:meth:`CoulombJoints.hold_opposed_slips`) on the tangential states."""
        crushed = self.crushed(new)
        view = self._coulomb(new)
        super().hold_opposed_slips(view, self._coulomb(old), joint, comm)
        new.state[:], new.sign[:] = self._crush(view, crushed).state, view.sign

    def repaired(self, active: ContactState, repair: np.ndarray, joint: np.ndarray, comm: MPI.Comm
                 ) -> ContactState:
        """Coulomb's repair (:meth:`CoulombJoints.repaired`) on the tangential states; crushed pairs stay crushed."""
        return self._crush(super().repaired(self._coulomb(active), repair, joint, comm), self.crushed(active))

    def complementarity(self, d0: np.ndarray, C: np.ndarray) -> None:
        """No complementarity problem: the condensation enumerates the states (:meth:`candidates`)."""
        return None

    # ----------------------------------------------------------------- verdicts
    def mode_rules(self, active: ContactState) -> ModeRules:
        """Coulomb's rules on the tangential states; a crushed pair may close, doing work against its force C."""
        rules = super().mode_rules(self._coulomb(active))
        return rules._replace(crushing=np.where(self.crushed(active), self.capacity, 0.0))

    # ----------------------------------------------------------------- limit analysis
    def conic(self) -> "CrushingJoints":
        """The conic bounds' joints (module docstring): the tangents at n = 0 and N_c as rows (K = 1), the parabola
        itself as cones (:meth:`block_cones`)."""
        return CrushingJoints.blocks(self.strength, self.width, 1)

    def block_cones(self, length: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per joint of depth t (``length``, m) the two cones |(sqrt2 n, u - v)| <= u + v, u = f_c w t/sqrt2, v =
        sqrt2 (n t/2 - sign m)/t, sign = +1, -1 (module docstring), as s = rhs - A q: s_0 = u + v, s_1 = sqrt2 n,
        s_2 = u - v; local rows 0-2 and 3-5, columns 0 (n) and 2 (m)."""
        t = np.asarray(length, float)[:, None]
        r2 = math.sqrt(2.0)
        one = np.ones_like(t)
        per_sign = []
        for sign in (1.0, -1.0):  # v = n/sqrt2 - sign sqrt2 m / t
            per_sign.append(np.hstack([-one / r2, sign * r2 / t, -r2 * one, one / r2, -sign * r2 / t]))
        vals = np.hstack(per_sign)
        rows = np.tile([0, 0, 1, 2, 2, 3, 3, 4, 5, 5], (len(t), 1))
        cols = np.tile([0, 2, 0, 0, 2, 0, 2, 0, 0, 2], (len(t), 1))
        u = self.strength * self.width * t / r2
        return rows, cols, vals, np.hstack([u, 0 * u, u, u, 0 * u, u])

    def polygon(self) -> tuple[np.ndarray, np.ndarray]:
        """The moment rows of a joint of unit depth and unit crushing force: per row the slope a_k and intercept
        b_k of |m| <= t a_k n + f_c w t^2 b_k (module docstring). The joint's stations (``stations``, default K + 1
        evenly spaced ones with trapezoidal weights) are filled at f_c from the extrados edge one after another:
        station k at s_k (fraction of t from the intrados) fills along a_k = s_k - 1/2 from the corner (N_k, M_k) of
        the stations before it, so b_k = sum_{i<k} w_i a_i - a_k sum_{i<k} w_i. For a layout symmetric about the
        middle the intrados' rows are the same."""
        s, w = (np.array(self.stations, float).T if self.stations is not None else uniform_stations(self.tangents))
        order = np.argsort(-s, kind="stable")
        s, w = s[order], w[order] / w.sum()
        a = s - 0.5
        before_w = np.concatenate([[0.0], np.cumsum(w)[:-1]])
        before_m = np.concatenate([[0.0], np.cumsum(w * a)[:-1]])
        return a, before_m - a * before_w

    def block_yield(self, length: np.ndarray, mu: np.ndarray, capacity: np.ndarray) -> BlockYield:
        """Per joint the rows +-m - t a_k n <= f_c w t^2 b_k (:meth:`polygon`; for K tangents a_k = 1/2 - k/K,
        b_k = k^2 / (2 K^2), the tangents of the module docstring) and Coulomb's shear rows +-s - mu n <=
        capacity, and n >= 0."""
        t = np.asarray(length, float)
        a, b = self.polygon()
        k = len(a)
        slope = t[:, None] * a  # m
        intercept = self.strength * self.width * t[:, None] ** 2 * b  # N m
        n = len(t)
        one = np.ones((n, 1))
        moment_rows = np.repeat(np.arange(2 * k), 2)
        moment_cols = np.tile([2, 0], 2 * k)
        moment_vals = np.stack([np.broadcast_to(one, (n, k)), -slope, -np.broadcast_to(one, (n, k)), -slope],
                               axis=2).reshape(n, -1)
        shear = 2 * k
        rows = np.concatenate([moment_rows, [shear, shear, shear + 1, shear + 1]])
        cols = np.concatenate([moment_cols, [1, 0, 1, 0]])
        vals = np.hstack([moment_vals, np.column_stack([one[:, 0], -mu, -one[:, 0], -mu])])
        rhs = np.hstack([np.repeat(intercept, 2, axis=1), np.column_stack([capacity, capacity])])
        return BlockYield(rows, cols, vals, rhs, np.zeros(n))

    def moment_capacity(self, length: np.ndarray, n: np.ndarray) -> np.ndarray:
        """The largest |m| (N m) of the rows at normal forces ``n`` (N): min_k t a_k n + f_c w t^2 b_k; negative
        beyond N_c."""
        t = np.asarray(length, float)[:, None]
        a, b = self.polygon()
        return np.min(self.strength * self.width * t ** 2 * b + t * a * np.asarray(n, float)[:, None], axis=1)

    def largest_moment(self, length: np.ndarray, n: np.ndarray) -> np.ndarray:
        """The exact parabola g(n) = n (t - n / (f_c w)) / 2 (N m), the limit of the rows as K grows."""
        n = np.asarray(n, float)
        return n * (np.asarray(length, float) - n / (self.strength * self.width)) / 2


def uniform_stations(k: int) -> tuple[np.ndarray, np.ndarray]:
    """K + 1 evenly spaced stations (fractions of the depth) with trapezoidal weights: the K tangents' polygon."""
    w = np.full(k + 1, 1.0 / k)
    w[[0, -1]] = 0.5 / k
    return np.linspace(0.0, 1.0, k + 1), w


def fe_stations(scene: Scene, nodes: tuple[float, ...] | None = None) -> tuple[tuple[float, float], ...]:
    """The FE's pairs through a joint (module docstring) as (position, weight) fractions of the depth: the joint's
    element ends ``nodes`` (fractions of the depth from the intrados, increasing from 0 to 1; None:
    ``elements_through_thickness`` even elements) with elements of ``degree`` 1 (trapezoidal weights) or 2 (a node
    at each element's middle too, Simpson's weights: 1/6, 2/3, 1/6 of the element)."""
    ends = np.asarray(nodes, float) if nodes is not None else \
        np.linspace(0.0, 1.0, scene.mesh.elements_through_thickness + 1)
    size = np.diff(ends)
    if scene.mesh.degree == 1:
        s, w = ends, np.zeros(len(ends))
        w[:-1] += size / 2
        w[1:] += size / 2
    else:
        s = np.zeros(2 * len(size) + 1)
        s[0::2], s[1::2] = ends, (ends[:-1] + ends[1:]) / 2
        w = np.zeros(len(s))
        w[0:-1:2] += size / 6
        w[2::2] += size / 6
        w[1::2] = 4 * size / 6
    return tuple(zip(s.tolist(), w.tolist()))


def scene_law(scene: Scene, fe: bool = False, nodes: tuple[float, ...] | None = None
              ) -> type[JointLaw] | JointLaw:
    """The rigid-block joints' law of a scene: Coulomb's (a class) without ``[masonry] compressive_strength``,
    else :class:`CrushingJoints` with that strength over the arch's width, with ``TANGENTS`` tangents or (``fe``)
    the FE's stations on its joints' element ends ``nodes`` (:func:`fe_stations`; None: even elements): the FE's
    own joints, the static theorem's rows."""
    strength = scene.masonry.compressive_strength
    if strength is None:
        return CoulombJoints
    return CrushingJoints.blocks(strength, scene.arch.width, stations=fe_stations(scene, nodes) if fe else None)


def scene_law_factory(scene: Scene):
    """The FE's joint-law factory of a scene (:data:`bridgefem.analysis.build.JointLawFactory`): Coulomb's
    ``for_pairs`` without a compressive strength, else :class:`CrushingJoints` at the scene's strength, with the
    ring interfaces' cohesion ``[joints] ring_cohesion`` over the arch's width when it has one."""
    strength, cohesion = scene.masonry.compressive_strength, scene.joints.ring_cohesion
    if strength is None and not cohesion:
        return CoulombJoints.for_pairs
    law, strong = (CoulombJoints, {}) if strength is None else (CrushingJoints, {"strength": strength})
    return functools.partial(law.for_pairs, ring_cohesion=cohesion, width=scene.arch.width, **strong)


def strength_text(scene: Scene) -> str:
    """The scene's compressive strength for messages (empty without one): a weak masonry can stand at no thickness
    at all (its self-weight's thrust grows with the thickness)."""
    strength = scene.masonry.compressive_strength
    return "" if strength is None else f" and compressive strength {strength:g} Pa"
