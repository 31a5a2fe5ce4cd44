"""Blind benchmark, step 2 (rules ``blind_diagnose`` / ``blind_diagnose_rest``): diagnose anonymous cases.

Each case is diagnosed exactly as ``mrhyst diagnose CASE.csv --sensor hall1`` would
(:func:`mrhyst.diagnose.diagnose_file`, the same seed), from its own CSV (and its sidecar beside it) and
nothing else: no key, no case list, no other case. Several cases in one process (:func:`diagnose_cases`)
pay Python's, scipy's and numba's start-up once instead of once per case; a case's bytes do not depend on
which cases ran before it in the same process.

The case ids are numbered ``case_000`` ... (:func:`mrhyst.blind.case_ids`), so a job takes a *block*: the ids
that share all but their last ``log10(cases_per_job)`` digits (``case_000`` ... ``case_009`` for 10). A
Snakemake job has a fixed set of output patterns, and a block is the one set of case ids that a fixed pattern
(``case_{block}0`` ... ``case_{block}9``) names; the cases of every benchmark's incomplete last block are
one more job (rule ``blind_diagnose_rest``, whose outputs are named in full).
"""

from __future__ import annotations

import math


def block_digits(cases_per_job: int) -> int:
    """Digits a block leaves free: 0 for one case per job, 1 for 10, 2 for 100 (anything else: ValueError)."""
    d = round(math.log10(cases_per_job)) if cases_per_job >= 1 else -1
    if d < 0 or 10 ** d != cases_per_job:
        raise ValueError(f"cases_per_job must be 1, 10 or 100 (a power of ten: a block of case ids), got "
                         f"{cases_per_job}")
    return d


def split_blocks(ids: list[str], cases_per_job: int) -> tuple[list[str], list[str]]:
    """(block stems whose every id is in ``ids``, the ids left over). A stem is an id without its last digits:
    'case_01' stands for case_010 ... case_019 when cases_per_job is 10; with 1, every id is its own block."""
    d = block_digits(cases_per_job)
    if d == 0:
        return list(ids), []
    have = set(ids)
    stems = sorted({i[:-d] for i in ids})
    full = [s for s in stems if all(f"{s}{k:0{d}d}" in have for k in range(cases_per_job))]
    done = {f"{s}{k:0{d}d}" for s in full for k in range(cases_per_job)}
    return full, [i for i in ids if i not in done]


def diagnose_cases(csvs, outs, config: dict, log=print) -> list[str]:
    """Diagnose each case CSV into its JSON (``mrhyst diagnose`` with config ``diagnose``, seed 0), one
    after another in this process; return the effects. A sweep the diagnosis refuses (one-line input
    error, e.g. a protocol it does not support) is recorded as ``"effect": "failed"`` with the message, so
    that the benchmark counts it instead of stopping."""
    from mrhyst import diagnose
    from mrhyst.blind.cases import SENSOR

    if len(csvs) != len(outs):
        raise ValueError(f"{len(csvs)} case files but {len(outs)} outputs")
    config = diagnose.resolve_config(config)  # once for every case: the settings that run, checked
    return diagnose_each(csvs, outs, lambda csv, out: diagnose.diagnose_file(csv, sensor=SENSOR, out=out,
                                                                            config=config), log)


def diagnose_each(csvs, outs, one, log=print) -> list[str]:
    """``one(csv, out)`` -> diagnosis for each case in turn; a one-line input error is recorded as
    ``failed`` (write_failed) and the run goes on. Returns the effects."""
    import time

    from mrhyst.data import io

    effects = []
    for csv, out in zip(csvs, outs, strict=True):
        t0 = time.perf_counter()
        try:
            d = one(csv, out)
            effects.append(d["effect"])
            log(f"{csv}: {d['verdict']} ({time.perf_counter() - t0:.1f} s)")
        except io.InputError as e:
            effects.append(write_failed(out, e))
            log(f"{csv}: failed: {e}")
    return effects


def write_failed(out, err) -> str:
    """Record a case the diagnosis refused (a one-line input error) so the benchmark counts it; returns
    the effect it is scored as (``failed``)."""
    from mrhyst.blind.scoring import FAILED
    from mrhyst.data import io

    io.write_json({"effect": FAILED, "error": str(err), "ambiguous_with": [], "rms_before_T": None,
                   "rms_after_T": None, "noise_floor_T": None}, out)
    return FAILED
