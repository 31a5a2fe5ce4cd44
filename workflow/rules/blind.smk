# Blind benchmark of the diagnosis (issues 5, 12, 13; mrhyst.blind, config blind). blind_generate writes N
# anonymous cases (closed world, compound, open world) and the key, from the blind config alone (the key's
# reference fit is independent of the diagnosis: issue 11 point 5); blind_diagnose jobs diagnose the cases,
# each case from its own files only (never the key: see tests/test_blind.py); blind_score alone reads the key.
# N is known from config, so every output is known up front (no checkpoint). Each benchmark lives in a folder:
# results/blind/ (the main one) and results/blind_variants/NAME/ (config blind.variants, e.g. bipolar sweeps).
#
# Jobs (config blind.cases_per_job = K, 100 by default): one blind_diagnose job diagnoses a block of K cases in
# one process (mrhyst.blind.diagnose_cases), so Python, scipy and numba start once per block, not once per case.
# A job's outputs are a fixed set of patterns, and the one set of case ids a fixed pattern can name is a block
# of ids sharing all but their last digits (case_000 ... case_099: the block "blind/diag/case_0"), hence K is
# 1, 10 or 100. The cases of a benchmark's incomplete last block (case_200 ... case_203 of 204; all 56 of the
# bipolar variant) are one more job of that benchmark, rule blind_diagnose_rest[_NAME]: its outputs are known
# when the workflow is parsed, so it needs no pattern. blind_diagnose names a block by its path below results/
# ({block}), constrained to the benchmarks' own blocks, so that no file has two rules that could make it.
import re

from mrhyst.blind import case_ids as _blind_case_ids
from mrhyst.blind import key_parts as _blind_key_parts
from mrhyst.blind import split_blocks as _blind_split
from mrhyst.blind import variant_config as _blind_variant

# cases_per_job and key_jobs are workflow settings: no benchmark's config (its key, its score) sees them
_BLIND_CFG = {k: v for k, v in config["blind"].items() if k not in ("cases_per_job", "key_jobs")}
BLIND_KEY_JOBS = int(config["blind"].get("key_jobs") or 1)
BLIND_BENCHES = {"blind/": _blind_variant(_BLIND_CFG)} | {
    f"blind_variants/{n}/": _blind_variant(_BLIND_CFG, n) for n in sorted(_BLIND_CFG.get("variants") or {})}
BLIND_IDS = {b: _blind_case_ids(c) for b, c in BLIND_BENCHES.items()}
BLIND_DIR_RE = "blind/|blind_variants/[A-Za-z0-9_]+/"
BLIND_K = int(config["blind"]["cases_per_job"])
BLIND_DIGITS = len(str(BLIND_K)) - 1
_blind_parts = {b: _blind_split(ids, BLIND_K) for b, ids in BLIND_IDS.items()}
# "blind/diag/case_00" (a block) and "blind/diag/case_203" (a leftover case): paths below results/, no suffix
BLIND_BLOCKS = [f"{b}diag/{s}" for b, (stems, _) in _blind_parts.items() for s in stems]
BLIND_REST = {b: [f"{b}diag/{i}" for i in rest] for b, (_, rest) in _blind_parts.items()}
BLIND_SUFFIXES = [f"{k:0{BLIND_DIGITS}d}" if BLIND_DIGITS else "" for k in range(BLIND_K)]


def _alternation(items):
    """A regex matching exactly these strings (one that matches nothing when there are none)."""
    return "|".join(re.escape(x) for x in items) if items else "(?!x)x"


def _case_file(stem, ext):
    """results/BENCH/cases/ID.ext of a case named by its diagnosis path below results/ (BENCH/diag/ID)."""
    bench, cid = stem.rsplit("diag/", 1)
    return f"results/{bench}cases/{cid}.{ext}"


def _block_ids(block):
    return [f"{block}{s}" for s in BLIND_SUFFIXES]


def _bench_name(bdir):
    return "" if bdir == "blind/" else "_" + bdir.split("/")[1]


for _bdir, _bcfg in BLIND_BENCHES.items():
    _parts = _blind_key_parts(_bcfg, BLIND_KEY_JOBS)

    if len(_parts) > 1:

        rule:
            """A part of the key's work (config blind.key_jobs): the cases of some classes drawn with their reference
            fits (each class from its own stream, so the parts are independent; mrhyst.blind.cases.write_part)."""
            name:
                "blind_draw" + _bench_name(_bdir)
            input:
                warmed("ja"),  # the J-A kernel compiled once, not by each draw that starts at once
            output:
                f"results/{_bdir}draws/part_{{part}}.json",
            wildcard_constraints:
                part="[0-9]+",
            params:
                config={"blind": _bcfg},
                key_jobs=BLIND_KEY_JOBS,
            log:
                f"results/logs/blind_draw{_bench_name(_bdir)}_{{part}}.log",
            # first in the queue: every blind_diagnose job of its benchmark waits for the key
            priority: 10 if _bdir == "blind/" else 9
            threads: 1
            script:
                "../scripts/blind_draw.py"

    rule:
        """The rig and mrhyst.blind.openworld make every case: truth, drive, noise, the withheld cause(s); the key
        (with config blind.key_jobs > 1: from the blind_draw parts, the same bytes)."""
        name:
            "blind_generate" + _bench_name(_bdir)
        input:
            parts=[f"results/{_bdir}draws/part_{i}.json" for i in range(len(_parts))] if len(_parts) > 1 else [],
        output:
            csv=expand(f"results/{_bdir}cases/{{case}}.csv", case=BLIND_IDS[_bdir]),
            json=expand(f"results/{_bdir}cases/{{case}}.json", case=BLIND_IDS[_bdir]),
            key=f"results/{_bdir}key.json",
        params:
            config={"blind": _bcfg},
        log:
            f"results/logs/blind_generate{_bench_name(_bdir)}.log",
        # first in the queue: the longest single job (the key's reference fits), and every blind_diagnose job of
        # its benchmark waits for it. One thread: its reference fits can run in `threads` processes (the same
        # bytes for any number; the SLURM profile's set-threads may give it more), but in that pool the parent
        # draws the cases in turn and every class ends with draws made ahead and thrown away: with 2 it kept 1.6
        # cores busy and took 87 CPU s where one process takes 74, while on one core the other core runs the
        # rest of the study meanwhile (README, Targets)
        priority: 10 if _bdir == "blind/" else 9  # the main benchmark is the largest
        threads: 1
        script:
            "../scripts/blind_generate.py"

    if BLIND_REST[_bdir]:

        rule:
            """The cases of the benchmark's incomplete last block, in one job, diagnosed like the others; inputs:
            these cases only."""
            name:
                "blind_diagnose_rest" + _bench_name(_bdir)
            input:
                csv=[_case_file(c, "csv") for c in BLIND_REST[_bdir]],
                json=[_case_file(c, "json") for c in BLIND_REST[_bdir]],
            output:
                [f"results/{c}.json" for c in BLIND_REST[_bdir]],
            params:
                config=config_of("diagnose"),
            log:
                f"results/logs/blind_diagnose_rest{_bench_name(_bdir)}.log",
            priority: BLOCK_PRIORITY if 2 * len(BLIND_REST[_bdir]) >= int(config["blind"]["cases_per_job"]) else 1
            script:
                "../scripts/blind_diagnose.py"


rule blind_diagnose:
    """A block of cases (config blind.cases_per_job), each diagnosed exactly as `mrhyst diagnose` would (config
    diagnose) from its own files, one after another in one process; inputs: these cases only."""
    input:
        csv=lambda w: [_case_file(c, "csv") for c in _block_ids(w.block)],
        json=lambda w: [_case_file(c, "json") for c in _block_ids(w.block)],
    output:
        [f"results/{{block}}{s}.json" for s in BLIND_SUFFIXES],
    wildcard_constraints:
        block=_alternation(BLIND_BLOCKS),
    params:
        config=config_of("diagnose"),
    log:
        "results/logs/{block}x.log",
    # the longest jobs first (common.smk): one started last would run alone on one core at the end of the build
    priority: BLOCK_PRIORITY
    script:
        "../scripts/blind_diagnose.py"


rule blind_score:
    """The only reader of the key: closed-world top-1, compound one-of-pair / both-named, open-world false
    attribution / model-form recall, per class; the policy's trade-off curve when there is a policy."""
    input:
        diag=lambda w: expand(f"results/{w.bdir}diag/{{case}}.json", case=BLIND_IDS[w.bdir]),
        key="results/{bdir}key.json",
    output:
        "results/{bdir}score.json",
    wildcard_constraints:
        bdir=BLIND_DIR_RE,
    params:
        config=lambda w: {"blind": BLIND_BENCHES[w.bdir]},
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/{bdir}blind_score.log",
    script:
        "../scripts/blind_score.py"


rule blind_figure:
    input:
        nb="notebooks/blind.ipynb",
        score="results/blind/score.json",
    output:
        nb="results/notebooks/blind.ipynb",
        png=report("results/figures/blind.png", caption="../report/blind.rst", category="Diagnosis"),
    params:
        nbparams=lambda w, input, output: nbparams(score=input.score, out_png=output.png),
    log:
        "results/logs/blind_figure.log",
    shell:
        PAPERMILL


BLIND_TARGETS = [f"results/{b}score.json" for b in BLIND_BENCHES] + ["results/figures/blind.png"]
ALL_TARGETS += BLIND_TARGETS
