"""diagnose_gap, stage 2b: the search for effects, naming only what held-out data support.

One :class:`EffectSearch` per call of :func:`~greyml.gap.diagnose_gap`. It
owns everything the search draws or keeps: the random generator of the
placebos, the count of placebos drawn and the cache of cross products that
do not depend on the candidate. It is dropped when the call returns, and
with it every cache (the banks' own caches live in the candidates, which
the search holds).

At each step the best effect is *named* only if its held-out shrinkage
beats ``min_shrinkage``, every placebo given the same freedom, and its
95 % interval over tests lies above 0. The placebos give the one-sided
2.5 % test of "no better than chance" (39 placebos, Besag and Clifford
(1991)); the interval over tests, resampled as whole tests, gives the
one-sided 2.5 % test of "better on held-out tests, not on one test alone".
Both are required, so a named effect never shows a p-value below 0.05
beside an interval that reaches below 0. A pair is named only when each
member also adds to the other on its own (the interval of its own part
above 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from greyml.gap._effects import Bank, lag_bank, lag_picks
from greyml.gap._fit import Evaluation, evaluate, fold_design, placebo_walks
from greyml.gap._report import NOISE_RATIO

__all__ = [
    "EffectSearch",
    "Found",
    "Named",
    "Scored",
    "Step",
    "shrinkage",
    "shrinkage_interval",
    "showing_tests",
]

#: The two-sided level of the interval of the held-out shrinkage over tests.
LEVEL = 0.95
#: Bootstrap resamples of whole tests for that interval.
N_BOOT = 2000
#: Below this fraction of its largest value, a test's signatures count as absent.
_ABSENT = 1e-6


def shrinkage(after, before):
    """Held-out shrinkage 1 - after/before; 0 when there is no gap left to shrink."""
    return 1.0 - after / before if before > 0 else 0.0


def shrinkage_interval(before, after, bounds, level=LEVEL, n_boot=N_BOOT):
    """Percentile interval of the held-out shrinkage over tests resampled with replacement.

    ``before`` and ``after`` are held-out gaps on the same rows; each resample
    draws whole tests (``bounds``) and pools their squared gaps, as the
    shrinkage itself does. (NaN, NaN) when no resample has a gap.
    """
    b = np.array([np.sum(before[s:e] ** 2) for s, e in bounds])
    a = np.array([np.sum(after[s:e] ** 2) for s, e in bounds])
    # a fixed seed: the interval is a property of the data, not of random_state
    pick = np.random.default_rng(0).integers(0, len(bounds), size=(n_boot, len(bounds)))
    den = b[pick].sum(axis=1)
    ok = den > 0
    if not ok.any():
        return (np.nan, np.nan)
    shrink = 1.0 - np.sqrt(a[pick].sum(axis=1)[ok] / den[ok])
    lo, hi = np.quantile(shrink, [(1 - level) / 2, (1 + level) / 2])
    return (float(lo), float(hi))


def showing_tests(cand, bounds):
    """The tests in which some variant of ``cand`` has non-zero signatures, per variant.

    Returns a list (one per variant) of sets of test indices. An effect whose
    every variant shows in at most one test cannot be scored leave one test
    out: held out, that test's calibration tests do not show it.
    """
    values = cand.get_bank().values  # (n, V, m)
    peak = np.abs(values).max(axis=(0, 2))  # (V,)
    out = []
    for v in range(values.shape[1]):
        if not peak[v] > 0:
            out.append(set())
            continue
        out.append(
            {
                t
                for t, (a, b) in enumerate(bounds)
                if np.abs(values[a:b, v]).max() > _ABSENT * peak[v]
            }
        )
    return out


#: How many times the search runs again without the first effect of a set
#: that does not account for the gap.
_RETRIES = 2


@dataclass
class Scored:
    """One candidate scored at a step: its held-out evaluation, shrinkage and interval."""

    candidate: object  # Candidate
    evaluation: Evaluation
    shrinkage: float
    interval: tuple


@dataclass
class Step:
    """One step of the forward search.

    ``before``: the held-out evaluation the step starts from, ``after``:
    with the named (or best) effect added; ``scored``: every candidate
    scored, best first (empty for a pair's steps);
    ``placebo``: the held-out shrinkage of each placebo drawn; ``shrinkage``
    and ``interval``: the named (or best) effect's; ``why``: why the best
    was not named ("" when it was); ``pair``: the partner of a pair member.
    """

    number: int
    before: Evaluation
    after: Evaluation
    scored: list
    placebo: np.ndarray
    shrinkage: float
    interval: tuple
    min_shrinkage: float
    significant: bool = False
    ties: list = field(default_factory=list)
    pair: str | None = None
    why: str = ""
    why_all: bool = False  # ``why`` is every scored candidate's reason, not only the best's

    @property
    def placebo_max(self):
        """The best placebo's shrinkage, or NaN when none was drawn."""
        finite = self.placebo[np.isfinite(self.placebo)]
        return float(finite.max()) if finite.size else np.nan

    @property
    def threshold(self):
        """What the shrinkage had to beat: ``min_shrinkage`` or the best placebo."""
        best = self.placebo_max
        return max(self.min_shrinkage, best) if np.isfinite(best) else self.min_shrinkage

    @property
    def n_placebo(self):
        """Placebos drawn at this step."""
        return int(np.isfinite(self.placebo).sum())

    @property
    def p_value(self):
        """Sequential placebo p-value (Besag and Clifford, 1991): stop at the first placebo as good.

        Stopped after l placebos at the first one at least as good as the
        effect, p = 1/l; all drawn and none as good, p = 1/(l + 1). NaN when
        none was drawn.
        """
        drawn = self.placebo[np.isfinite(self.placebo)]
        if not drawn.size:
            return np.nan
        beaten = int(np.sum(drawn >= self.shrinkage))
        return beaten / drawn.size if beaten else 1.0 / (drawn.size + 1)


@dataclass
class Named:
    """A named effect: its candidate, its held-out evaluation and the step that named it."""

    candidate: object  # Candidate
    evaluation: Evaluation
    step: Step


@dataclass
class Found:
    """What the search named: ``named`` (:class:`Named`, in order), every
    :class:`Step`, the ``final`` held-out evaluation, the candidates
    ``dropped`` by pruning, whether the recalibration was ``kept`` and how many
    placebos were drawn (``n_placebo``)."""

    named: list
    steps: list
    final: Evaluation
    dropped: list
    kept: bool
    n_placebo: int


@dataclass
class _Pass:
    """One search (forward, pruning, forward again) from one starting point."""

    named: list
    steps: list
    final: Evaluation
    dropped: list


def _with(base, ev):
    """Each fold's base with one more effect, as that fold chose it."""
    return [np.hstack([b, d]) for b, d in zip(base, fold_design(ev.bank, ev.choices))]


def _low_interval(interval):
    """Why an interval does not support an effect ("" when it lies above 0)."""
    lo = interval[0]
    if np.isfinite(lo) and lo > 0:
        return ""
    return "its 95% interval over tests reaches below 0"


class EffectSearch:
    """The search for effects of one diagnosis, and everything it keeps.

    Parameters
    ----------
    ctx : GapContext
    start : Start
        Where the search starts (:func:`greyml.gap._search.starting_point`).
    rng : numpy.random.Generator
        Draws the placebos.
    n_placebo, min_shrinkage, max_effects, tie_tolerance
        As in :func:`~greyml.gap.diagnose_gap`.

    Attributes
    ----------
    n_drawn : int
        Placebos drawn so far.
    cache : dict
        Cross products that do not depend on the candidate (see
        :func:`greyml.gap._fit.evaluate`).
    """

    def __init__(self, ctx, start, rng, *, n_placebo, min_shrinkage, max_effects, tie_tolerance):
        self.ctx = ctx
        self.start = start
        self.rng = rng
        self.n_placebo = n_placebo
        self.min_shrinkage = min_shrinkage
        self.max_effects = max_effects
        self.tie_tolerance = tie_tolerance
        self.n_drawn = 0
        self.cache = {}

    # -- scoring -----------------------------------------------------------

    def evaluate(self, base, make, settings, recal):
        """Held-out evaluation of ``base`` + one candidate (``make``: a Bank or None)."""
        ctx = self.ctx
        return evaluate(ctx.r, base, make, settings, ctx.bounds, recal=recal, cache=self.cache)

    def score(self, base, before, cand, recal):
        """A :class:`Scored` candidate against the held-out gap ``before``."""
        ev = self.evaluate(base, cand.get_bank(), cand.settings, recal)
        interval = shrinkage_interval(before.held_out, ev.held_out, self.ctx.bounds)
        return Scored(cand, ev, shrinkage(ev.rmse, before.rmse), interval)

    def _placebo_bank(self, cand):
        """Random-walk signatures as free as ``cand``: a :class:`Bank` like its own.

        As many variants, features and time-constant settings: the variants
        are random walks from 0 in every test, lagged like the candidate's
        signatures (or used as they are when it has no time constant). A
        candidate with a placebo of its own (``initial_state``: random start
        offsets) gets that one.
        """
        ctx = self.ctx
        if cand.placebo is not None:
            return cand.placebo(self.rng)
        n, V, k = len(ctx.r), len(cand.variants), cand.n_features
        if cand.settings[0]:
            taus = cand.taus or tuple(sorted({float(t) for s in cand.settings for t in s}))
            walks = placebo_walks(self.rng, ctx.bounds, V)
            return Bank(lag_bank(walks, taus, ctx.dt, ctx.bounds), lag_picks(cand.settings, taus))
        walks = placebo_walks(self.rng, ctx.bounds, V * k).reshape(n, V, k)
        return Bank(walks, [list(range(k))])

    def placebos(self, base, before, cand, recal, beat):
        """Held-out shrinkage of up to ``n_placebo`` placebos as free as ``cand``.

        Stops at the first placebo whose shrinkage reaches ``beat`` (the
        effect's own): the effect is then not significant, whatever the
        others do. Returns the shrinkages and the best placebo's evaluation.
        """
        out, best = [], None
        for _ in range(self.n_placebo):
            ev = self.evaluate(base, self._placebo_bank(cand), cand.settings, recal)
            out.append(shrinkage(ev.rmse, before.rmse))
            if best is None or ev.rmse < best.rmse:
                best = ev
            if out[-1] >= beat:
                break
        self.n_drawn += len(out)
        return np.array(out), best

    def pair_placebos(self, base, before, first, second, recal, beat):
        """Held-out shrinkage of placebo pairs as free as (``first``, ``second``), and the best's
        evaluation."""
        out, best = [], None
        for _ in range(self.n_placebo):
            ev_a = self.evaluate(base, self._placebo_bank(first), first.settings, recal)
            ev_b = self.evaluate(
                _with(base, ev_a), self._placebo_bank(second), second.settings, recal
            )
            out.append(shrinkage(ev_b.rmse, before.rmse))
            if best is None or ev_b.rmse < best.rmse:
                best = ev_b
            if out[-1] >= beat:  # not significant, whatever the others do
                break
        self.n_drawn += len(out)
        return np.array(out), best

    # -- the search --------------------------------------------------------

    def run(self, candidates):
        """Search as the simulation is and, if recalibrated, with its parameters refitted.

        When the effects found do not account for the gap (see
        :meth:`_left`), the search is run again without the first of them,
        at most twice: a library effect that half mimics the gap can take
        the first step from the one that explains it. If no search names
        effects that account for the gap, the first one's are listed as tried.

        Returns a :class:`Found`.
        """
        found, kept = self._both(candidates)
        first = (found, kept)
        for retry in range(_RETRIES + 1):
            if self._left(found) is None:  # nothing named, or what is named accounts for it
                return Found(*self._result(found, kept), self.n_drawn)
            if retry == _RETRIES:
                break
            without = found.named[0].candidate
            candidates = [c for c in candidates if c is not without]
            if not candidates:
                break
            found, kept = self._both(candidates)
            if not found.named:
                break
        return Found(*self._result(*self._not_accounting(*first)), self.n_drawn)

    @staticmethod
    def _result(found, kept):
        """What a :class:`Found` holds of one search, but the placebo count."""
        return found.named, found.steps, found.final, found.dropped, kept

    def _both(self, candidates):
        """The search from the simulation as it is and, if recalibrated, from its refit."""
        start = self.start
        alt_rng = np.random.default_rng(self.rng.integers(2**63))
        found = self._pass(candidates, start.initial, None)
        kept = False
        if start.recal is not None:
            # Effects are searched for twice: against the simulation as it is,
            # and with its parameters refitted (jointly with every effect). The
            # recalibration is kept when its search leaves less of the gap held
            # out. Neither order is safe alone: refitted parameters can take up
            # part of an effect, and an effect can hide a parameter error of the
            # opposite sign, which the recalibration alone then seems to worsen.
            self.rng = alt_rng
            alt = self._pass(candidates, start.recalibrated, start.recal)
            if alt.final.rmse < found.final.rmse:
                found, kept = alt, True
        return found, kept

    def _left(self, found):
        """The share of the gap ``found``'s effects leave if they fail to account for it, or None.

        Effects account for the gap when, together, they leave it within the
        noise (the verdict ``"explained"``) or leave less than half of the
        held-out gap above the noise floor that the simulation's own
        parameters, refitted, leave (``rmse_recalibrated``; without a
        recalibration, the gap as it is). An effect outside the library
        (a second heater) is often half mimicked by a library effect or two,
        each supported on its own; named, they would be a wrong cause, so
        they are reported as tried and not supported, and the verdict
        ``"unexplained"`` gives the share left.
        """
        start = self.start
        if not found.named or not found.final.rmse > NOISE_RATIO * start.floor:
            return None
        ref = self._refitted()
        floor2 = start.floor**2
        above = ref.rmse**2 - floor2
        left = (found.final.rmse**2 - floor2) / above if above > 0 else 1.0
        return None if left < 0.5 else min(left, 1.0)

    def _not_accounting(self, found, kept):
        """The search naming none of ``found``'s effects, each listed as tried, and why."""
        left = self._left(found)
        names = " + ".join(n.candidate.effect for n in found.named)
        first = found.steps[0]
        # one step listing the effects that were named, each as tried and not
        # supported for this reason (a pair's steps score no other candidate);
        # the second is scored with the first, as it was named
        step = Step(
            1,
            first.before,
            found.final,
            [  # each scored, as the rows are, against the gap the search started from
                Scored(
                    n.candidate,
                    n.evaluation,
                    shrinkage(n.evaluation.rmse, first.before.rmse),
                    shrinkage_interval(
                        first.before.held_out, n.evaluation.held_out, self.ctx.bounds
                    ),
                )
                for n in found.named
            ],
            np.array([]),
            first.shrinkage,
            first.interval,
            self.min_shrinkage,
            why=(
                f"{names} would leave {left:.0%} of the held-out gap above the noise "
                "that refitting the simulation's parameters leaves: they do not account for "
                "the larger part of it"
            ),
            why_all=True,
        )
        return _Pass([], [step], self._refitted(), []), self.start.recal is not None

    def _refitted(self):
        """The held-out gap the simulation's refitted parameters leave (as it is, without)."""
        start = self.start
        return start.recalibrated if start.recal is not None else start.initial

    def _pass(self, candidates, before, recal):
        """Forward naming, backward pruning, and forward again without what was pruned."""
        named, steps, final = self._forward(candidates, before, recal)
        dropped = self._prune(named, recal) if len(named) > 1 else []
        if dropped:
            rest = [c for c in candidates if all(c is not d for d in dropped)]
            named, steps, final = self._forward(rest, before, recal)
        return _Pass(named, steps, final, dropped)

    def _forward(self, candidates, before, recal):
        """Greedy forward naming: add the best supported effect until none is left."""
        steps, named = [], []
        base = self.start.base
        remaining = list(candidates)
        while remaining:
            scored = sorted(
                (self.score(base, before, c, recal) for c in remaining),
                key=lambda s: -s.shrinkage,
            )
            best = scored[0]
            step = Step(
                len(steps) + 1,
                before,
                best.evaluation,
                scored,
                np.array([]),
                best.shrinkage,
                best.interval,
                self.min_shrinkage,
            )
            step.why = self._test(step, base, best, recal, room=len(named) < self.max_effects)
            step.significant = not step.why
            if step.significant:
                step.ties = [
                    s.candidate.effect
                    for s in scored[1:]
                    if best.shrinkage - s.shrinkage <= self.tie_tolerance
                ]
                steps.append(step)
                named.append(Named(best.candidate, best.evaluation, step))
                base = _with(base, best.evaluation)
                before = best.evaluation
                remaining = [c for c in remaining if c is not best.candidate]
                continue
            if len(remaining) >= 2 and len(named) + 2 <= self.max_effects:
                pair = self._pair(base, before, scored, recal, len(steps))
                if pair is not None:
                    steps.extend(p.step for p in pair)
                    named.extend(pair)
                    base = _with(_with(base, pair[0].evaluation), pair[1].evaluation)
                    before = pair[1].evaluation
                    remaining = [c for c in remaining if all(c is not p.candidate for p in pair)]
                    continue
            steps.append(step)
            break
        return named, steps, before

    def _test(self, step, base, best, recal, room):
        """Why ``best`` is not named at ``step`` ("" when it is); draws its placebos."""
        if not room:
            return f"max_effects={self.max_effects} effects are already named"
        if not best.shrinkage > self.min_shrinkage:
            return f"it shrinks the gap by no more than min_shrinkage={self.min_shrinkage:g}"
        low = _low_interval(best.interval)
        if low:
            return low
        step.placebo, placebo = self.placebos(
            base, step.before, best.candidate, recal, best.shrinkage
        )
        if not best.shrinkage > step.threshold:
            return f"placebos do as well (p = {step.p_value:.2g})"
        # beating every placebo must hold over tests, not by a fluke of one
        margin = shrinkage_interval(placebo.held_out, best.evaluation.held_out, self.ctx.bounds)
        if not margin[0] > 0:
            return (
                f"it beats the best placebo ({step.placebo_max:.0%}) by too little: its 95% "
                f"interval over tests against it is {margin[0]:.0%} to {margin[1]:.0%}"
            )
        return ""

    def _pair(self, base, before, scored, recal, number, top=3):
        """The best pair of effects, if held-out data support it and each member.

        Two effects withheld at once can each explain too little of the gap
        to beat placebos alone, while together they explain it. The best
        ``top`` single effects are each completed by every other effect
        (fitted given the first); the best pair must beat ``min_shrinkage``,
        its interval over tests must lie above 0, each member must add to
        the other on its own (the interval of the pair against the other
        member alone above 0), and the pair must beat ``n_placebo`` pairs
        of placebos given the same freedom (the first fitted alone, the
        second given it), the best of them over tests (the interval against
        it above 0). Returns two :class:`Named`, or None.
        """
        best = None
        for first in scored[:top]:
            with_first = _with(base, first.evaluation)
            for second in scored:
                if second is first:
                    continue
                cand = second.candidate
                ev = self.evaluate(with_first, cand.get_bank(), cand.settings, recal)
                if best is None or ev.rmse < best[2].rmse:
                    best = (first, second, ev)
        first, second, ev = best
        bounds = self.ctx.bounds
        pair_shrink = shrinkage(ev.rmse, before.rmse)
        if not pair_shrink > self.min_shrinkage:
            return None
        if _low_interval(shrinkage_interval(before.held_out, ev.held_out, bounds)):
            return None
        # each member's own part: the pair against the other member alone
        own = {}
        for member, other in ((first, second), (second, first)):
            interval = shrinkage_interval(other.evaluation.held_out, ev.held_out, bounds)
            if _low_interval(interval):
                return None
            own[id(member)] = (other, interval)
        placebo, best_placebo = self.pair_placebos(
            base, before, first.candidate, second.candidate, recal, pair_shrink
        )
        threshold = max(self.min_shrinkage, float(placebo.max()))
        if not pair_shrink > threshold:
            return None
        if _low_interval(shrinkage_interval(best_placebo.held_out, ev.held_out, bounds)):
            return None  # it beats the best placebo pair by a fluke of one test
        out = []
        for k, (member, partner) in enumerate(((first, second), (second, first))):
            other, interval = own[id(member)]
            step = Step(
                number + 1 + k,
                other.evaluation,  # its own part: what it adds to its partner alone
                ev,
                [],
                placebo,
                pair_shrink,
                interval,
                self.min_shrinkage,
                significant=True,
                pair=partner.candidate.effect,
            )
            evaluation = first.evaluation if member is first else ev
            out.append(Named(member.candidate, evaluation, step))
        return out

    def _prune(self, named, recal):
        """Named effects that the others make redundant (backward elimination).

        Greedy forward naming can add, early on, an effect that stands in for
        two later ones (a slow heat source for the air plus a drift). Each
        named effect is left out in turn, the others refitted; while leaving
        one out costs less than ``tie_tolerance`` of the held-out RMSE, the
        cheapest is dropped.
        """
        base = self.start.base
        designs = {
            id(n.candidate): fold_design(n.evaluation.bank, n.evaluation.choices) for n in named
        }
        keep = [n.candidate for n in named]

        def score(effects):
            fold = [
                np.hstack([b] + [designs[id(c)][f] for c in effects]) for f, b in enumerate(base)
            ]
            return self.evaluate(fold, None, [()], recal).rmse

        dropped = []
        full = score(keep)
        while len(keep) > 1:
            trials = [(score([c for c in keep if c is not e]), e) for e in keep]
            rmse, worst = min(trials, key=lambda t: t[0])
            if rmse > (1.0 + self.tie_tolerance) * full:
                break
            keep.remove(worst)
            dropped.append(worst)
            full = rmse
        return dropped
