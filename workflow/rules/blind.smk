# Blind benchmark of the diagnosis (issues 5, 12; mrhyst.blind, config blind). blind_generate writes N
# anonymous cases (closed world, compound, open world) and the key, from the blind config alone (the key's
# reference fit is independent of the diagnosis: issue 11 point 5); one blind_diagnose job per case reads
# ONLY its own case files (never the key: see tests/test_blind.py); blind_score alone reads the key. N is
# known from config, so every output is known up front (no checkpoint).
from mrhyst.blind import case_ids as _blind_case_ids

BLIND_IDS = _blind_case_ids(config["blind"])
BLIND_KEY = "results/blind/key.json"


rule blind_generate:
    """The rig and mrhyst.blind.openworld make every case: truth, drive, noise, the withheld cause(s); the key."""
    output:
        csv=expand("results/blind/cases/{case}.csv", case=BLIND_IDS),
        json=expand("results/blind/cases/{case}.json", case=BLIND_IDS),
        key=BLIND_KEY,
    params:
        config=config_of("blind"),
    log:
        "results/logs/blind_generate.log",
    script:
        "../scripts/blind_generate.py"


rule blind_diagnose:
    """One case, diagnosed exactly as `mrhyst diagnose` would (config diagnose); inputs: the case only."""
    input:
        csv="results/blind/cases/{case}.csv",
        json="results/blind/cases/{case}.json",
    output:
        "results/blind/diag/{case}.json",
    wildcard_constraints:
        case=r"case_\d+",
    params:
        config=config_of("diagnose"),
    log:
        "results/logs/blind/{case}.log",
    script:
        "../scripts/blind_diagnose.py"


rule blind_score:
    """The only reader of the key: closed-world top-1, compound one-of-pair / both-named, open-world false
    attribution / model-form recall, per class; the policy's trade-off curve when there is a policy."""
    input:
        diag=expand("results/blind/diag/{case}.json", case=BLIND_IDS),
        key=BLIND_KEY,
    output:
        "results/blind/score.json",
    params:
        config=config_of("blind"),
    log:
        "results/logs/blind_score.log",
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


BLIND_TARGETS = ["results/blind/score.json", "results/figures/blind.png"]
ALL_TARGETS += BLIND_TARGETS
