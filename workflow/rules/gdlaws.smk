# Gadolinium temperature laws, one temperature withheld (issue 24 item 4; mrhyst.materials.gdlaws, config gdlaws):
#   gdlaws_fit       the joint temperature-law fit (LSM) of one amplitude's loops but the withheld temperature's
#   gdlaws_diagnose  the withheld loop, temperature column dropped, diagnosed against those laws (reference mode)
#   gdlaws_table     ours beside the peer's figures (data/external/gd-temperature-nowicki/peer_rms.json)
# In `all` unless gdlaws.in_all is false (the tests' small study: the law fit was minutes of CPU when written, a4a1a5a;
# 9 s of job time in the builds of 4b44c62 and 89a36d4).
from mrhyst.materials import gdlaws as _gdlaws

GDLAWS = _gdlaws.gdlaws_config(config)
_GD_LOOPS = "data/external/gd-temperature-nowicki/loops.csv"


rule gdlaws_fit:
    input:
        loops=_GD_LOOPS,
    output:
        "results/gdlaws/fit.json",
    params:
        # diagnose: its stderr_rho_max caps the laws' stderr widening too (one cap)
        config=config_of("gdlaws", "temperature_laws", "ja", "pso", "lsm", "identifiability", "metrics", "paper",
                         "diagnose"),
    log:
        "results/logs/gdlaws_fit.log",
    priority: 1  # a long job (~40 s when written, aa90976; 9 s in the build of 89a36d4): before the short ones
    script:
        "../scripts/gdlaws_fit.py"


rule gdlaws_diagnose:
    input:
        loops=_GD_LOOPS,
        fit="results/gdlaws/fit.json",
    output:
        loop="results/gdlaws/withheld.csv",
        diag="results/gdlaws/withheld_diag.json",
    params:
        config=config_of("gdlaws", "diagnose", "paper", "reference"),
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/gdlaws_diagnose.log",
    script:
        "../scripts/gdlaws_diagnose.py"


rule gdlaws_table:
    input:
        fit="results/gdlaws/fit.json",
        diag="results/gdlaws/withheld_diag.json",
        peer="data/external/gd-temperature-nowicki/peer_rms.json",
    output:
        "results/tables/gdlaws.csv",
    params:
        config=config_of("gdlaws"),
    log:
        "results/logs/gdlaws_table.log",
    script:
        "../scripts/gdlaws_table.py"


rule gdlaws_figure:
    """The withheld loop's reference diagnosis drawn as every diagnosis is (`mrhyst diagnose ... --figure`, issue 26)."""
    input:
        diag="results/gdlaws/withheld_diag.json",
    output:
        png=report("results/figures/gdlaws_withheld.png", caption="../report/diagnosis.rst", category="Diagnosis"),
    log:
        "results/logs/gdlaws_figure.log",
    script:
        "../scripts/gdlaws_figure.py"


GDLAWS_TARGETS = ["results/tables/gdlaws.csv", "results/figures/gdlaws_withheld.png"]
if GDLAWS["in_all"]:
    ALL_TARGETS += GDLAWS_TARGETS
