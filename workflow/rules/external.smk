# Measured loops from other laboratories (data/external/, MIT): J-A fits in the cyclic steady state (closed
# loops) or with a fitted initial magnetisation (open paths); mrhyst.materials.external. Target `external`.
from mrhyst.materials.external import external_config as _external_config

EXTERNAL = _external_config(config)
EXTERNAL_SOURCES = sorted(EXTERNAL["sources"])


rule external_fit:
    """Fit every loop of one third-party file (one job per file): each loop on its own, and for a file with
    several loops of one material also all of them with one parameter set (joint)."""
    input:
        csv=lambda w: EXTERNAL["sources"][w.source]["path"],
        warm=warmed("variants"),  # the variants' kernels compiled once, not by each fit that starts at once
    output:  # the JSON, then its per-sample arrays beside it (F.json -> F.curve.csv, mrhyst.data.curves)
        "results/external/{source}.json",
        "results/external/{source}.curve.csv",
    wildcard_constraints:
        source="[A-Za-z0-9_]+",
    params:
        config=config_of("external", *STUDY_CONFIG),
    threads: 1
    log:
        "results/logs/external_fit_{source}.log",
    # a long job (every J-A variant of the file, 4-19 s in the builds of 2acdca7): common.smk. At 1 the 19-s one started
    # at 165 s of 190 in a build of ae2f79c and ended the build alone
    priority: EXTERNAL_FIT_PRIORITY
    script:
        "../scripts/external_fit.py"


rule external_diagnose:
    """The diagnosis of every loop of one third-party file (issue 13): which effect, model form or nothing
    explains its gap to J-A, without a Hall chain (one job per file); and each loop's figure (issue 26)."""
    input:
        csv=lambda w: EXTERNAL["sources"][w.source]["path"],
    output:
        json="results/external/diag/{source}.json",
        figs=directory("results/figures/external_diag/{source}"),  # one PNG per loop (mrhyst.report.diagfig)
    wildcard_constraints:
        source="[A-Za-z0-9_]+",
    params:
        config=config_of("diagnose", "external", "ja", "pso", "lsm"),  # a loop's material fit: the last 4
    threads: 1
    log:
        "results/logs/external_diagnose_{source}.log",
    # a long job (2-8 s per file in the build of 071708b): before the short ones. At 0 one started at 176 s of 193 and
    # ran alone with the report's last links (bench/README "Twelfth session")
    priority: 1
    script:
        "../scripts/external_diagnose.py"


rule external_table:
    """One row per loop and fit (per-loop; joint = one parameter set for all loops of a file): RMS (absolute,
    relative to the B amplitude and to the peak), start state, method, parameters, substeps, loop figures of
    data and fit; then the peers' rows (external.peers)."""
    input:
        fits=expand("results/external/{source}.json", source=EXTERNAL_SOURCES),
        peers=[EXTERNAL["peers"]] if EXTERNAL["peers"] else [],
    output:
        table="results/tables/external.csv",
        models="results/tables/external_models.csv",  # --model auto: every variant per file (issue 26)
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/external_table.log",
    script:
        "../scripts/external_table.py"


rule external_figure:
    input:
        nb="notebooks/external.ipynb",
        fits=expand("results/external/{source}.json", source=EXTERNAL_SOURCES),
        curves=expand("results/external/{source}.curve.csv", source=EXTERNAL_SOURCES),  # read with the fits
        table="results/tables/external.csv",
    output:
        nb="results/notebooks/external.ipynb",
        png=report("results/figures/external.png", caption="../report/external.rst", category="Appendix"),
    params:
        nbparams=lambda w, input, output: nbparams(fits=",".join(input.fits), table=input.table, out_png=output.png),
    log:
        "results/logs/external_figure.log",
    shell:
        PAPERMILL


EXTERNAL_TARGETS = expand("results/external/{source}.json", source=EXTERNAL_SOURCES) + expand(
    "results/external/{source}.curve.csv", source=EXTERNAL_SOURCES) + expand(
    "results/external/diag/{source}.json", source=EXTERNAL_SOURCES) + expand(
    "results/figures/external_diag/{source}", source=EXTERNAL_SOURCES) + [
    "results/tables/external.csv",
    "results/tables/external_models.csv",
    "results/figures/external.png",
]
ALL_TARGETS += EXTERNAL_TARGETS

