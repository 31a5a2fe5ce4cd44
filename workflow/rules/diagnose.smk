# Diagnosis of the measured sweeps (issue 5): where plain J-A misses, which unmodelled effect causes it, how
# far the miss shrinks once that effect is added (mrhyst.diagnose, config diagnose). One job per group.


rule diagnose:
    """One group's Hall channel of its raw sweep -> the `mrhyst diagnose` contract JSON."""
    input:
        csv=lambda w: raw_csv(w.group),
        json=lambda w: raw_json(w.group),
    output:
        "results/diagnosis/{group}.json",
    params:
        config=config_of("diagnose"),
        sensor=lambda w: config["groups"][w.group]["sensor"],
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/diagnose_{group}.log",
    script:
        "../scripts/diagnose.py"


rule diagnosis_figure:
    """Loop, fits before/after, and residual vs current by region, for one group's diagnosis."""
    input:
        nb="notebooks/diagnosis.ipynb",
        diag="results/diagnosis/{group}.json",
    output:
        nb="results/notebooks/diagnosis_{group}.ipynb",
        png=report("results/figures/diagnosis_{group}.png", caption="../report/diagnosis.rst", category="Diagnosis"),
    params:
        nbparams=lambda w, input, output: nbparams(diag=input.diag, group=w.group, out_png=output.png),
    log:
        "results/logs/diagnosis_figure_{group}.log",
    shell:
        PAPERMILL


DIAGNOSIS_TARGETS = expand("results/diagnosis/{group}.json", group=GROUPS) + expand(
    "results/figures/diagnosis_{group}.png", group=GROUPS
)
ALL_TARGETS += DIAGNOSIS_TARGETS
