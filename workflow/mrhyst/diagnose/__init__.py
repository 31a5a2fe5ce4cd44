"""Diagnosis of a raw sweep: where the J-A fit misses, which effect causes it, how far it shrinks.

Input: one raw sweep (ARCHITECTURE 4) and one of its Hall channels. Output: the ``DIAG.json`` of the
``mrhyst diagnose`` contract (:func:`diagnose_file`; :func:`diagnose` for a Sweep).

Modules (each stage one module; the decision is a pure function):

* :mod:`.sweep` - the sweep, the 0 -> max -> 0 protocol check, regions along the loop (ascending low / mid /
  high current, the turning point, descending high / mid / low, the 0 A remanence point), the noise floor
  (robust RMS of the residual's second differences along each branch, which a smooth misfit hardly reaches).
* :mod:`.problem` - J-A plus effects in one coordinate space through the one forward model
  (:func:`mrhyst.model.effects.forward`), solved by the domain-free batched LM (:mod:`mrhyst.fit.lm`).
* :mod:`.candidates` - plain J-A by multi-start LM (several seeds), every effect of the registry refitted
  from the plain fit with data-derived starts (cross-seeded among the leaders; a deep search from random
  starts when structure is left), pairs of effects, held-out errors (interleaved and contiguous-block
  K-fold CV, the branch hold-out: fit the ascending branch and the turning point, predict the descending
  one), standard errors from the Jacobian, BIC, plausible sizes.
* :mod:`.modelform` - physics J-A leaves out (issue 12): a second magnetic phase (two J-A loops), a
  Preisach model with a parametric switching-field distribution.
* :mod:`.policy` - ``decide(evidence, thresholds) -> verdict``: which effect is named, ``ambiguous_with``,
  ``secondary``, ``model_form``, or ``none`` / ``unexplained`` with ``partial`` (the evidence rule of
  issue 12: an effect is named only if it closes the gap, predicts held-out data no worse than plain J-A,
  has a plausible size, and no model-form candidate beats it).
* :mod:`.budget` - the gap budget along the chain (noise floor, RK4 integration, optimizer shortfall, model
  form, in quadrature) and the shrink (fitted and held-out).
* :mod:`.contract` - the JSON, with the ``evidence`` block the policy read (re-decidable offline).
* :mod:`.settings` - defaults from workflow/mrhyst/schemas/config.schema.yaml (the one place they live).

The ``air_gap`` is exactly a shift of alpha (ARCHITECTURE 5): its augmentation lets the effective
alpha' = (alpha - Nd)/(1 - Nd) go below 0, and the size reported is the smallest Nd that explains it
(alpha = 0): Nd = -alpha' / (1 - alpha').

Any piecewise-monotone current path is accepted (issue 13): the paper's 0 -> max -> 0, bipolar major
loops, repeated cycles, minor loops; regions follow :mod:`mrhyst.data.loops`. On repeated cycles the residual's
cycle-to-cycle difference separates a time-bound gap (a drift) from a field-bound one (``evidence.repeat``).
A third-party B(H) loop (:func:`diagnose_bh_file`) is diagnosed without a Hall chain (the offset is a B
offset, saturation a clipping; eddy lag and drift are skipped without sample times, and said so). An
ambiguous or unexplained verdict carries ``next_measurement`` (:mod:`.nextmeas`), computed from the
candidates' fitted models on protocol variants. Everything is deterministic for a given seed.
"""

from mrhyst.diagnose.candidates import (
                    bic,
                    deep_starts,
                    effect_starts,
                    fit_augmented,
                    fit_plain,
                    holdout,
                    random_starts,
                    std_errors,
)
from mrhyst.diagnose.core import diagnose, diagnose_bh_file, diagnose_bh_source, diagnose_file
from mrhyst.diagnose.policy import DEFAULT_THRESHOLDS, decide
from mrhyst.diagnose.problem import Fit, Problem, best, candidates, n_params
from mrhyst.diagnose.settings import defaults, resolve_config
from mrhyst.diagnose.sweep import (
                    REGIONS,
                    Sweep,
                    check_protocol,
                    folds,
                    load_sweep,
                    noise_floor,
                    region_breakdown,
                    region_labels,
                    sweep_from_arrays,
                    sweep_from_bh,
)

_best = best
CANDIDATES = candidates()  # the effects refitted (a snapshot; candidates() follows the registry)

__all__ = ["CANDIDATES", "DEFAULT_THRESHOLDS", "REGIONS", "Fit", "Problem", "Sweep", "best", "bic", "candidates",
           "check_protocol", "decide", "deep_starts", "defaults", "diagnose", "diagnose_bh_file", "diagnose_bh_source",
           "diagnose_file",
           "effect_starts",
           "fit_augmented", "fit_plain", "folds", "holdout", "load_sweep", "n_params", "noise_floor",
           "random_starts", "region_breakdown", "region_labels", "resolve_config", "std_errors",
           "sweep_from_arrays", "sweep_from_bh"]
