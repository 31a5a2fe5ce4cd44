# Raw sweeps -> loops (Hall chain), and the N/Le inference (not in the paper).
# Rig variants (config rig.variants, issue 14): the rig's sweep made again with one design choice changed; the
# sweep and everything fitted on it live under results/variants/NAME/ and go through the same convert and fit
# rules ({vdir} = "" for the study, "variants/NAME/" for a variant).
from mrhyst.report.plotstyle import sidecar_synthetic as _rig_made

# A variant remakes the virtual rig's sweep: built where every group's sweep is the rig's (its sidecar says
# SYNTHETIC). A lab's own sweep in data/raw is another damper on other channels: no variant has a base in it (the
# report says so), and its sensor names need not be the rig's.
RIG_VARIANTS = (sorted((config.get("rig") or {}).get("variants") or {})
                if all(_rig_made(raw_json(g)) for g in GROUPS) else [])
VDIR_RE = r"(variants/[A-Za-z0-9_]+/)?"


def variant_raw(vdir, path):
    """The raw sweep file of the study (vdir "") or of a rig variant (vdir "variants/NAME/")."""
    return path if not vdir else f"results/{vdir}raw/{os.path.basename(path)}"


rule rig_variant:
    """The rig's sweep with a variant's change (mrhyst.rig.variant_config), same coil N/Le and noise seed."""
    input:
        nle="results/sim/n_over_le.json",
    output:
        csv="results/variants/{variant}/raw/{name}.csv",
        json="results/variants/{variant}/raw/{name}.json",
    params:
        rig=lambda w: config["rig"],
    priority: GATE_PRIORITY  # it starts the variant's chain convert -> fits -> tables into the report
    log:
        "results/logs/variants/{variant}/rig_{name}.log",
    script:
        "../scripts/rig_variant.py"



rule convert:
    """Hall voltage -> B for one group's sensor (mrhyst.data.io.raw_to_loop, as `mrhyst convert`). {vdir} is empty for
    the study, or variants/NAME/ for a rig variant's sweep (rule rig_variant, config rig.variants)."""
    input:
        csv=lambda w: variant_raw(w.vdir, raw_csv(w.group)),
        json=lambda w: variant_raw(w.vdir, raw_json(w.group)),
    output:
        "results/{vdir}loops/{group}.csv",
    wildcard_constraints:
        vdir=VDIR_RE,
    params:
        sensor=lambda w: config["groups"][w.group]["sensor"],
    priority: GATE_PRIORITY
    log:
        "results/logs/{vdir}convert_{group}.log",
    script:
        "../scripts/convert.py"


rule infer_nle:
    """N/Le per Table 1 set from the reported peak B (mrhyst.paper.nle)."""
    output:
        "results/sim/n_over_le.json",
    params:
        config=config_of("paper", "ja", "nle"),
    # the root of the deepest chains into the report (rig variant, later and aftercare benchmarks, Fig. 2, Tables):
    # at 0 it ran at 150 s of 178 and those chains filled the build's last 25 s one link at a time
    priority: GATE_PRIORITY
    log:
        "results/logs/infer_nle.log",
    script:
        "../scripts/infer_nle.py"


ALL_TARGETS += expand("results/loops/{group}.csv", group=GROUPS)
ALL_TARGETS += ["results/sim/n_over_le.json"]
