# Blind benchmark of the diagnosis (issues 5, 12, 13; mrhyst.blind, config blind). blind_generate writes N
# anonymous cases (closed world, compound, open world) and the key, from the blind config alone (the key's
# reference fit is independent of the diagnosis: issue 11 point 5); one blind_diagnose job per case reads
# ONLY its own case files (never the key: see tests/test_blind.py); blind_score alone reads the key. N is
# known from config, so every output is known up front (no checkpoint). Each benchmark lives in a folder:
# results/blind/ (the main one) and results/blind_variants/NAME/ (config blind.variants, e.g. bipolar sweeps).
from mrhyst.blind import case_ids as _blind_case_ids
from mrhyst.blind import variant_config as _blind_variant

BLIND_BENCHES = {"blind/": _blind_variant(config["blind"])} | {
    f"blind_variants/{n}/": _blind_variant(config["blind"], n) for n in sorted(config["blind"].get("variants") or {})}
BLIND_IDS = {b: _blind_case_ids(c) for b, c in BLIND_BENCHES.items()}
BLIND_DIR_RE = "blind/|blind_variants/[A-Za-z0-9_]+/"


def _bench_name(bdir):
    return "" if bdir == "blind/" else "_" + bdir.split("/")[1]


for _bdir, _bcfg in BLIND_BENCHES.items():

    rule:
        """The rig and mrhyst.blind.openworld make every case: truth, drive, noise, the withheld cause(s); the key."""
        name:
            "blind_generate" + _bench_name(_bdir)
        output:
            csv=expand(f"results/{_bdir}cases/{{case}}.csv", case=BLIND_IDS[_bdir]),
            json=expand(f"results/{_bdir}cases/{{case}}.json", case=BLIND_IDS[_bdir]),
            key=f"results/{_bdir}key.json",
        params:
            config={"blind": _bcfg},
        log:
            f"results/logs/blind_generate{_bench_name(_bdir)}.log",
        script:
            "../scripts/blind_generate.py"


rule blind_diagnose:
    """One case, diagnosed exactly as `mrhyst diagnose` would (config diagnose); inputs: the case only."""
    input:
        csv="results/{bdir}cases/{case}.csv",
        json="results/{bdir}cases/{case}.json",
    output:
        "results/{bdir}diag/{case}.json",
    wildcard_constraints:
        case=r"case_\d+",
        bdir=BLIND_DIR_RE,
    params:
        config=config_of("diagnose"),
    log:
        "results/logs/{bdir}diag/{case}.log",
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
