# The paper's damper after use (issue 24; mrhyst.blind.aftercare, config aftercare): the Table 1 model is the
# reference; the virtual rig sweeps the same damper after heating, with a shifted gap, with a drifted or offset
# sensor, with an eddy lag, or unchanged. aftercare_generate writes the cases and, apart, the key;
# aftercare_diagnose diagnoses every case in reference mode from its own files (`mrhyst diagnose CASE --sensor
# hall1 --reference table1:...`), one job for all of them (about 1 s a case); aftercare_score alone reads the key.
from mrhyst.blind import aftercare as _aftercare

AFTERCARE = _aftercare.aftercare_config(config)
AFTERCARE_IDS = _aftercare.case_ids(AFTERCARE)


rule aftercare_generate:
    """Virtual-rig sweeps of the reference's damper after one change each, and the key."""
    input:
        nle="results/sim/n_over_le.json",
    output:
        csv=expand("results/aftercare/cases/{case}.csv", case=AFTERCARE_IDS),
        json=expand("results/aftercare/cases/{case}.json", case=AFTERCARE_IDS),
        key="results/aftercare/key.json",
    params:
        config=config_of("aftercare", "paper"),
    log:
        "results/logs/aftercare_generate.log",
    script:
        "../scripts/aftercare_generate.py"


rule aftercare_diagnose:
    """Reference-mode diagnosis of every case (never the key)."""
    input:
        csv=expand("results/aftercare/cases/{case}.csv", case=AFTERCARE_IDS),
        json=expand("results/aftercare/cases/{case}.json", case=AFTERCARE_IDS),
    output:
        expand("results/aftercare/diag/{case}.json", case=AFTERCARE_IDS),
    params:
        config=config_of("aftercare", "paper", "diagnose", "reference"),
    log:
        "results/logs/aftercare_diagnose.log",
    script:
        "../scripts/aftercare_diagnose.py"


rule aftercare_score:
    """The change named and its size against the key."""
    input:
        diag=expand("results/aftercare/diag/{case}.json", case=AFTERCARE_IDS),
        key="results/aftercare/key.json",
    output:
        "results/aftercare/score.json",
    params:
        config=config_of("aftercare"),
    log:
        "results/logs/aftercare_score.log",
    script:
        "../scripts/aftercare_score.py"


AFTERCARE_TARGETS = ["results/aftercare/score.json"]
ALL_TARGETS += AFTERCARE_TARGETS
