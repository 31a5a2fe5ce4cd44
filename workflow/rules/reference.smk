# The paper's damper after use (issue 24; mrhyst.blind.aftercare, config aftercare): the Table 1 model is the
# reference; the virtual rig sweeps the same damper after heating, with a shifted gap, with a drifted or offset
# sensor, with an eddy lag, or unchanged. aftercare_generate writes the cases and, apart, the key;
# aftercare_diagnose diagnoses every case in reference mode from its own files (`mrhyst diagnose CASE --sensor
# hall1 --reference table1:...`), one job for all of them (about 1 s a case); aftercare_score alone reads the key;
# aftercare_figures draws each diagnosis's figure (the report's appendix shows them with the plain summaries).
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
    priority: GATE_PRIORITY
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
    priority: GATE_PRIORITY
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


rule aftercare_figures:
    """The figure of every reference diagnosis (`mrhyst diagnose ... --figure`), from its JSON (never the key); the
    cases' sidecars only say the sweeps are synthetic. One job: matplotlib starts once (~0.5 s a figure)."""
    input:
        diag=expand("results/aftercare/diag/{case}.json", case=AFTERCARE_IDS),
        json=expand("results/aftercare/cases/{case}.json", case=AFTERCARE_IDS),
    output:
        expand("results/figures/aftercare/{case}.png", case=AFTERCARE_IDS),
    priority: GATE_PRIORITY
    log:
        "results/logs/aftercare_figures.log",
    script:
        "../scripts/aftercare_figures.py"


AFTERCARE_FIGS = expand("results/figures/aftercare/{case}.png", case=AFTERCARE_IDS)
AFTERCARE_TARGETS = ["results/aftercare/score.json"] + AFTERCARE_FIGS
ALL_TARGETS += AFTERCARE_TARGETS


# A later sweep of the same damper against the model calibrated from the first (issue 26; mrhyst.diagnose.later,
# config later): what a lab does with reference mode. later_generate writes the virtual rig's first sweep (data/raw's
# shipped bytes, made again: a lab's own sweep in data/raw is another damper) and its later sweeps of the same
# channel, one change each; later_calibrate fits J-A to the first sweep's loop (`mrhyst fit LOOP --method lsm`);
# later_diagnose diagnoses each later sweep against the calibration held (JSON + the figure of every diagnosis) and
# as a new sweep (what J-A's own parameters absorb). The report shows the figures and the plain summaries.
from mrhyst.diagnose import later as _later

LATER = _later.later_config(config)
LATER_CHANGES = list(LATER["changes"])
if LATER["sensor"] not in config["rig"]["sensors"]:  # the rig's channel, not data/raw's (a lab may name its own)
    raise ValueError(f"config later.sensor: the virtual rig has no sensor {LATER['sensor']!r} "
                     f"(config rig.sensors: {', '.join(config['rig']['sensors'])})")


rule later_calibrate:
    """J-A calibrated on the loop of the rig's first sweep (config later.sensor): the reference of the later sweeps."""
    input:
        csv="results/later/sweeps/first.csv",
        json="results/later/sweeps/first.json",
    output:
        loop="results/later/first_loop.csv",
        fit="results/later/calibration.json",
    params:
        config=config_of(*STUDY_CONFIG, "diagnose"),  # the fit's sections; diagnose: its form
        sensor=LATER["sensor"],
    priority: GATE_PRIORITY
    log:
        "results/logs/later_calibrate.log",
    script:
        "../scripts/later_calibrate.py"


rule later_generate:
    """The virtual rig's later sweeps of the same channel, one change each (synthetic)."""
    input:
        nle="results/sim/n_over_le.json",
    output:
        csv=expand("results/later/sweeps/{change}.csv", change=LATER_CHANGES),
        json=expand("results/later/sweeps/{change}.json", change=LATER_CHANGES),
        first=multiext("results/later/sweeps/first", ".csv", ".json"),
        settings="results/later/sweeps/settings.json",
    params:
        config=config_of("rig", "later"),
    priority: GATE_PRIORITY
    log:
        "results/logs/later_generate.log",
    script:
        "../scripts/later_generate.py"


rule later_diagnose:
    """One later sweep against the calibration held (JSON, figure) and as a new sweep (JSON)."""
    input:
        csv="results/later/sweeps/{change}.csv",
        json="results/later/sweeps/{change}.json",
        calibration="results/later/calibration.json",
    output:
        ref="results/later/diag/{change}_reference.json",
        png=report("results/figures/later/{change}_reference.png", caption="../report/diagnosis.rst",
                   category="Diagnosis"),
        plain="results/later/diag/{change}_plain.json",
    params:
        config=config_of("later", "diagnose", "paper", "reference"),
    priority: GATE_PRIORITY  # its figures go into the report: with the rest of its chain, not at the build's end
    log:
        "results/logs/later_diagnose_{change}.log",
    script:
        "../scripts/later_diagnose.py"


LATER_TARGETS = expand("results/later/diag/{change}_{mode}.json", change=LATER_CHANGES, mode=("reference", "plain"))
LATER_FIGS = expand("results/figures/later/{change}_reference.png", change=LATER_CHANGES)
ALL_TARGETS += LATER_TARGETS + LATER_FIGS
