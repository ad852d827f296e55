"""What a diverging solve shows: a mechanism, a proof of collapse, or a wrong active set (with its repair).

When the linear system of an active set is (nearly) singular, its solution runs off along a *mode*: the solution
minus the step's converged start, seen at the joint pairs as relative displacements d = [d_n, d_t] (m; d_n > 0
opens) together with the work of the loads on it. :func:`judge` decides, from the mode alone:

1. Its *sense*. A hinge mode (friction slip at most ``ADMISSIBLE_TOL`` of its largest joint displacement) is taken
   in the sense in which the driving load (the live load; the self-weight at live load 0) does positive work, or the
   whole load when the driving load does none. A mode with slip (the slip law makes the system unsymmetric, so the
   loads' sense means nothing) is taken in the sense that violates the joint laws least; when it violates them in
   both senses, in the sense in which the whole load and the sliding pairs' friction forces (s mu lam_n, lam_n of the
   last solved iterate) do positive work, the sense in which that free mode runs, when their power is significant;
   a tie (``TIE_TOL``) without significant power is broken by the lower joint of the two senses' worst pairs, so that
   the choice does not depend on the rounding that sets the diverging solve's sign (the same under MPI).
   E.g. both springings sliding outwards let the ring translate freely: in either sense one springing slips against
   its friction force, and the ring runs towards the springing with the smaller friction force, so the other one is
   the one whose slip is wrong.
2. Its *violation* in that sense, per pair, by the joint law's rules (:meth:`bridgefem.laws.base.JointLaw.mode_rules`):
   an open pair that the mode closes (interpenetration, -d_n), a sliding pair that it slips against the pair's
   friction force (for Coulomb: the slip law lam_t = s mu lam_n assumes slip d_t of sign -s, so s d_t > 0 is
   backwards), measured by mu s d_t, the friction's work on it per unit normal force (mu = 0 pairs slip freely).
   Closed pairs keep d_n = 0 and holding pairs d_t = 0 by their laws.
3. A *flaw*: a hinge mode on which the driving load does no work (below ``WORK_TOL`` of |f|_1 |u|_inf: e.g. a part
   of the ring freed by opening a whole joint), or a violation beyond ``ADMISSIBLE_TOL`` of the largest joint
   displacement. A flawed mode is a wrong active set, no mechanism; its *repair* closes the pairs whose violation is
   within ``REPAIR`` of the worst, narrowed to its *first contact* when the mode carries the gaps of the step's
   start (:func:`first_contact`); the solver closes them (:meth:`bridgefem.laws.base.JointLaw.repaired`: for
   Coulomb sticking, or sliding on a sliding joint). A flaw that is a slip against the friction force marks a
   *sliding* mode (``Verdict.slides``: the solver solves its set again with a proximal term).
4. A *proof*: an admissible rigid-block hinge mode, with violation and friction slip below ``PROOF_TOL`` (mu = 0
   pairs may slip) on which the driving load does positive work and the whole load more than the joints can
   dissipate on it (the tension T that the law lets an open pair carry, sum T d_n; none for Coulomb's no-tension
   joints; and the crushing force C of a crushed pair, which the mode may close further, sum C max(-d_n, 0)). By
   virtual work any equilibrium with joint forces -T <= lam_n <= C would give that work as -sum(lam_n d_n) <=
   sum T d_n + sum C max(-d_n, 0): no equilibrium exists. Only for a linear elastic structure (``provable``; a yielding fill dissipates on the mode).

Every reduction is over ``comm``: the pairs may be spread over MPI ranks.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from mpi4py import MPI

from ..laws.base import ModeRules

ADMISSIBLE_TOL = 1e-3  # violation (friction slip) of a mode, of its largest joint displacement, beyond which it is
# inadmissible (a slip mode)
WORK_TOL = 1e-6  # load work on a mode, of |f|_1 |u|_inf, below which the load does none
PROOF_TOL = 1e-6  # violation and friction slip of a proving mode, of its largest joint displacement
REPAIR = 0.5  # the repair closes the pairs whose violation is at least this fraction of the worst
FIRST_CONTACT = 0.1  # ... and of those open, the ones its mode closes within this fraction of the mode's amplitude
# at the first contact (:func:`first_contact`)
TIE_TOL = 1e-6  # a slip mode violating the laws alike in both senses, within this of its largest joint displacement,
# is a tie (step 1)


@dataclass(frozen=True)
class Mode:
    """A diverging direction at this rank's pairs. ``d`` (m, 2): relative displacements [d_n, d_t]; ``rules``: what
    the joint law forbids a mode of the active set that diverged (:class:`bridgefem.laws.base.ModeRules`); ``joint``:
    joint ids (for messages). ``works``: (driving load, whole load) work on the mode and
    ``scales`` their |f|_1 |u|_inf (global values, N m); ``driver``: the driving load's name; ``power``: the power of
    the whole load and the sliding pairs' friction forces on the mode and its scale (|f|_1 + sum mu lam_n) |u|_inf
    (N m; step 1); ``gap``: the pairs' normal gaps d_n at the step's start (m; None: the repair is not narrowed to
    the first contact, step 3)."""

    d: np.ndarray
    rules: ModeRules
    joint: np.ndarray
    works: tuple[float, float]
    scales: tuple[float, float]
    driver: str = "live load"
    power: tuple[float, float] = (0.0, 0.0)
    gap: np.ndarray | None = None


class Verdict(NamedTuple):
    """Why the mode is no mechanism (None: admissible), the local pairs its repair closes, whether it proves
    that no equilibrium exists, and whether its flaw is a slip against the friction force (a sliding mode)."""

    flaw: str | None
    repair: np.ndarray | None
    proof: bool
    slides: bool = False


def judge(mode: Mode, provable: bool = True, comm: MPI.Comm = MPI.COMM_SELF) -> Verdict:
    """The verdict on a diverging mode (module docstring, steps 1-4). Collective over ``comm``."""

    def norm(a: np.ndarray) -> float:
        return float(comm.allreduce(np.abs(a).max() if a.size else 0.0, op=MPI.MAX))

    d, rules, works, scales = mode.d, mode.rules, np.asarray(mode.works), np.asarray(mode.scales)
    significant = np.abs(works) > WORK_TOL * scales
    span = norm(d.ravel())
    slip = norm(np.where(rules.rough, d[:, 1], 0.0))  # slip against friction (mu = 0 slips freely)
    slipping = slip > ADMISSIBLE_TOL * span
    senses = [np.sign(works[0])] if significant[0] and not slipping else \
        [np.sign(works[1])] if significant[1] and not slipping else [1.0, -1.0]
    closing = np.where(rules.open, -d[:, 0], np.nan)  # times the sense: > 0 interpenetrates
    backwards = rules.backwards * d[:, 1]  # times the sense: > 0 slips against the friction force; mu s d_t is the
    # friction's work on it per unit normal force (none where mu = 0); NaN where no slip law holds
    worst = []
    for sense in senses:
        violation = np.fmax(sense * closing, sense * backwards)
        local = (-np.inf, 0, 0)
        if np.any(np.isfinite(violation)):
            i = int(np.nanargmax(violation))
            local = (float(violation[i]), int(mode.joint[i]), int(not np.isnan(rules.backwards[i])))
        worst.append(max(comm.allgather(local)))
    values = [w[0] for w in worst]
    k = int(np.argmin(values))
    if slipping and min(values) > ADMISSIBLE_TOL * span and abs(mode.power[0]) > WORK_TOL * mode.power[1]:
        k = senses.index(np.sign(mode.power[0]))  # flawed in both senses: the sense in which the free mode runs
    elif slipping and abs(values[0] - values[1]) <= TIE_TOL * span:
        k = int(np.argmin([w[1] for w in worst]))  # a tie: the sense whose worst pair is at the lower joint
    orient, (value, joint, backward) = senses[k], worst[k]
    flaw, slides = None, False
    if not significant[0] and not slipping:
        flaw = f"the {mode.driver} does no work on it ({abs(works[0]) / max(scales[0], 1e-300):.2g} of its largest)"
    elif value > ADMISSIBLE_TOL * span:
        what = "a slip against the friction force" if backward else "interpenetration"
        flaw, slides = f"{what} {value / span:.2g} of its largest joint displacement at joint {joint}", bool(backward)
    if flaw is not None:
        violation = np.nan_to_num(np.fmax(orient * closing, orient * backwards), nan=-np.inf)
        repair = violation > max(ADMISSIBLE_TOL * span, REPAIR * value)
        if mode.gap is not None:
            repair = first_contact(repair, -orient * d[:, 0], mode.gap, rules.open, comm)
        return Verdict(flaw, repair, False, slides)
    dissipation = comm.allreduce(float(np.sum(np.where(rules.open, rules.tension * np.maximum(orient * d[:, 0], 0.0),
                                                       0.0))))  # the open pairs' tension's work on the opening
    if rules.crushing is not None:  # the crushed pairs' compression's work on their closing
        dissipation += comm.allreduce(float(np.sum(rules.crushing * np.maximum(-orient * d[:, 0], 0.0))))
    proof = (provable and value <= PROOF_TOL * span and slip <= PROOF_TOL * span
             and orient * works[1] - dissipation > WORK_TOL * scales[1] and orient * works[0] > 0)
    return Verdict(None, None, bool(proof))


def first_contact(repair: np.ndarray, rate: np.ndarray, gap: np.ndarray, open_pairs: np.ndarray,
                  comm: MPI.Comm = MPI.COMM_SELF) -> np.ndarray:
    """A ``repair`` (per pair) narrowed to the open pairs that close first when the structure moves from the step's
    start along the mode in the sense the repair closes, and its closed pairs (``open_pairs``: the open pairs of the
    mode's active set).
    ``rate``: each pair's closing per unit of the mode (-d_n in that sense, m), ``gap``: its normal gap d_n at the
    start (m; a negative one counts as closed). An open pair closing faster than ``ADMISSIBLE_TOL`` of the fastest
    closes at the amplitude gap / rate; the least sets the first contact, and the open pairs closing within
    ``FIRST_CONTACT`` of it are closed (a hinge's pairs close together, up to the blocks' elastic strain), the others
    stay open: a free rigid-block motion moves the blocks until its first contact stops it, and closing a hinge it
    would reach later imposes a rotation the blocks can only take by straining. A repair that closes no open pair
    (it sticks pairs that slip backwards) is returned as it is. Collective over ``comm``."""
    span = float(comm.allreduce(np.abs(rate).max(initial=0.0), op=MPI.MAX))
    closes = open_pairs & (rate > ADMISSIBLE_TOL * span)
    if not comm.allreduce(bool((repair & closes).any()), op=MPI.LOR):
        return repair
    amplitude = np.where(closes, np.maximum(gap, 0.0) / np.where(closes, rate, 1.0), np.inf)
    first = comm.allreduce(float(amplitude.min(initial=np.inf)), op=MPI.MIN)
    return (repair & ~open_pairs) | (closes & (amplitude <= (1.0 + FIRST_CONTACT) * first))
