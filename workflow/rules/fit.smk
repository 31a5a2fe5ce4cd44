# Identification (paper: "Implementation of PSO", Eqs. 14-15; Tables 1-3): per group, PSO for every seed
# and every setting in config pso.run_settings, LSM once (deterministic), and the identifiability profile
# of the median-J fit. The package computes (mrhyst.fit.identify); scripts only wire files.
#   results/fits/{group}_pso_s{seed}.json         the paper's PSO setting (config pso.setting)
#   results/fits/{group}_pso-{setting}_s{seed}.json  another setting, e.g. pso-clerc
#   results/fits/{group}_lsm.json                 least squares in the same box, from its centre
#   results/fits/{group}_profile.json             J profiled along each parameter

#   results/variants/{variant}/fits/...           the same fits on a rig variant's sweep (config rig.variants)

import re

PSO_SEEDS = [int(s) for s in config["pso"]["seeds"]]


def pso_label(setting):
    """File label of a PSO setting: 'pso' for the paper's (config pso.setting), 'pso-<name>' otherwise."""
    return "pso" if setting == config["pso"]["setting"] else f"pso-{setting}"


PSO_LABELS = [pso_label(s) for s in config["pso"]["run_settings"]]


def pso_setting(label):
    return config["pso"]["setting"] if label == "pso" else label[len("pso-"):]


def fits_of(group, label):
    """All fit files of one group and label (every seed for PSO)."""
    if label == "lsm":
        return [f"results/fits/{group}_lsm.json"]
    return [f"results/fits/{group}_{label}_s{s}.json" for s in PSO_SEEDS]


ALL_FITS = [f for g in GROUPS for lab in PSO_LABELS + ["lsm"] for f in fits_of(g, lab)]


def _pso_seed_lists():
    """{(seed, ...): [vdir, ...]}: the study's PSO seeds (vdir "") and each rig variant's (config
    rig.variants.NAME.pso_seeds, else the study's), the study's list first."""
    out = {tuple(PSO_SEEDS): [""]}
    for v in RIG_VARIANTS:
        seeds = tuple(int(s) for s in (config["rig"]["variants"][v].get("pso_seeds") or PSO_SEEDS))
        out.setdefault(seeds, []).append(f"variants/{v}/")
    return out


# One fit_pso job runs every seed of one group and setting, one after another in one process: Python, pyswarms,
# scipy and numba start once per group and setting, not once per seed (a fit itself takes ~0.1-0.3 s). A job's
# outputs are a fixed list of patterns, so each distinct seed list has its own rule: fit_pso for the study (and
# any rig variant with the same seeds), fit_pso_NAME for a rig variant NAME with its own pso_seeds.
for _i, (_seeds, _vdirs) in enumerate(_pso_seed_lists().items()):

    rule:
        """PSO fits (mrhyst.fit.identify.fit_file) of one group and setting, every seed, in the group's box
        (config pso.box: one box for both methods). {vdir}: empty for the study, variants/NAME/ for a rig variant."""
        name:
            "fit_pso" if _i == 0 else "fit_pso_" + _vdirs[0].split("/")[1]
        input:
            loop="results/{vdir}loops/{group}.csv",
        output:  # each fit's JSON, then its model curves beside it (F.json -> F.curve.csv, mrhyst.data.curves)
            [f"results/{{vdir}}fits/{{group}}_{{label}}_s{s}.json" for s in _seeds],
            [f"results/{{vdir}}fits/{{group}}_{{label}}_s{s}.curve.csv" for s in _seeds],
        wildcard_constraints:
            vdir="(?:" + "|".join(re.escape(v) for v in _vdirs) + ")",
            label=r"pso(-[A-Za-z0-9_]+)?",
        params:
            config=config_of(*STUDY_CONFIG),
            method="pso",
            setting=lambda w: pso_setting(w.label),
            seeds=list(_seeds),
        threads: 1
        priority: GATE_PRIORITY
        log:
            "results/logs/{vdir}fit_{group}_{label}.log",
        script:
            "../scripts/fit.py"


rule fit_lsm:
    """One least-squares fit (mrhyst.fit.identify.fit_file) in the same box as PSO, from its centre."""
    input:
        loop="results/{vdir}loops/{group}.csv",
    output:
        "results/{vdir}fits/{group}_lsm.json",
        "results/{vdir}fits/{group}_lsm.curve.csv",
    wildcard_constraints:
        vdir=VDIR_RE,
    params:
        config=config_of(*STUDY_CONFIG),
        method="lsm",
        setting=None,
        seeds=[0],
    threads: 1
    priority: GATE_PRIORITY
    log:
        "results/logs/{vdir}fit_{group}_lsm.log",
    script:
        "../scripts/fit.py"


rule profile:
    """Identifiability: J profiled along each parameter around the median-J fit of the method/setting in
    config identifiability.fit (mrhyst.fit.identify.profile_file)."""
    input:
        loop="results/loops/{group}.csv",
        fits=lambda w: fits_of(
            w.group,
            "lsm" if config["identifiability"]["fit"]["method"] == "lsm"
            else pso_label(config["identifiability"]["fit"]["setting"]),
        ),
    output:
        "results/fits/{group}_profile.json",
    params:
        config=config_of(*STUDY_CONFIG),
    threads: 1
    priority: GATE_PRIORITY
    log:
        "results/logs/profile_{group}.log",
    script:
        "../scripts/profile.py"


ALL_TARGETS += ALL_FITS + expand("results/fits/{group}_profile.json", group=GROUPS)
