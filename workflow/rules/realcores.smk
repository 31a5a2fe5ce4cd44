# Benchmark "real cores, known faults" (issue 23; mrhyst.blind.realcores / realscore; config realcores). Target
# `realcores`. realcores_generate makes the anonymous cases (the loops of data/external as B(H) loops and as
# stepped Hall sweeps, each with one known fault or none) and the key; realcores_diagnose jobs diagnose the cases,
# each from its own files only (never the key); realcores_score alone reads the key.
from mrhyst.blind import realcores as _rc

RC_CFG = _rc.resolve(config.get("realcores"))  # frozen and checked once; the params below hand it on as it is
RC_PROTO = _rc.case_protocols(RC_CFG)
RC_IDS = sorted(RC_PROTO)
RC_JOBS = list(range(min(int(RC_CFG["jobs"]), len(RC_IDS)) or 1))


def _rc_share(job):
    """Every jobs-th case from job's own: the B(H) and Hall cases of every core spread over the jobs."""
    return RC_IDS[int(job):: len(RC_JOBS)]


rule realcores_generate:
    """The cases and the key (one job: a few seconds)."""
    input:
        list(RC_CFG["sources"].values()),
    output:
        csv=expand("results/realcores/cases/{case}.csv", case=RC_IDS),
        json=[f"results/realcores/cases/{c}.json" for c in RC_IDS if RC_PROTO[c] == "hall"],
        key="results/realcores/key.json",
    params:
        config={"realcores": RC_CFG},
    priority: 9  # it gates the two long real-core jobs: as early as the bipolar key's draws
    log:
        "results/logs/realcores_generate.log",
    script:
        "../scripts/realcores_generate.py"


for _job in RC_JOBS:

    rule:
        """A share of the cases, each diagnosed as `mrhyst diagnose` would (config diagnose) from its own files."""
        name:
            f"realcores_diagnose_{_job}"
        input:
            csv=[f"results/realcores/cases/{c}.csv" for c in _rc_share(_job)],
            json=[f"results/realcores/cases/{c}.json" for c in _rc_share(_job) if RC_PROTO[c] == "hall"],
        output:
            [f"results/realcores/diag/{c}.json" for c in _rc_share(_job)],
        params:
            config=config_of("diagnose", "external", "ja", "pso", "lsm"),  # a B(H) loop's material fit: the last 4
        log:
            f"results/logs/realcores_diagnose_{_job}.log",
        priority: REALCORES_PRIORITY  # a long job (half the cases, ~26 s): common.smk
        script:
            "../scripts/realcores_diagnose.py"


rule realcores_score:
    """The only reader of the key: fault named, size recovered, clean false alarms, the material/measurement
    split, per class (protocol x fault); the table for the report."""
    input:
        diag=expand("results/realcores/diag/{case}.json", case=RC_IDS),
        key="results/realcores/key.json",
    output:
        score="results/realcores/score.json",
        table="results/tables/realcores.csv",
    params:
        config={"realcores": RC_CFG},
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/realcores_score.log",
    script:
        "../scripts/realcores_score.py"


rule realcores_figure:
    input:
        nb="notebooks/realcores.ipynb",
        score="results/realcores/score.json",
    output:
        nb="results/notebooks/realcores.ipynb",
        png=report("results/figures/realcores.png", caption="../report/realcores.rst", category="Diagnosis"),
    params:
        nbparams=lambda w, input, output: nbparams(score=input.score, out_png=output.png),
    log:
        "results/logs/realcores_figure.log",
    shell:
        PAPERMILL


REALCORES_TARGETS = ["results/realcores/score.json", "results/tables/realcores.csv", "results/figures/realcores.png"]
ALL_TARGETS += REALCORES_TARGETS
