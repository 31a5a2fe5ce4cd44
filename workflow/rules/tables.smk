# Tables 1-3 with the paper's values beside ours (median-J seed), the seed spread, identifiability, and the
# check of the paper's numbers against each other (mrhyst.paper.tables). Figs. 8-10 plot the fits.


rule tables:
    input:
        fits=ALL_FITS,
        profiles=expand("results/fits/{group}_profile.json", group=GROUPS),
        nle="results/sim/n_over_le.json",
    output:
        table1=report("results/tables/table1.csv", caption="../report/table1.rst", category="Tables of the paper"),
        table2=report("results/tables/table2.csv", caption="../report/table2.rst", category="Tables of the paper"),
        table3=report("results/tables/table3.csv", caption="../report/table3.rst", category="Tables of the paper"),
        seed_spread="results/tables/seed_spread.csv",
        identifiability="results/tables/identifiability.csv",
        selected="results/tables/selected_fits.json",
        paper_check="results/tables/paper_check.json",
    params:
        config=config_of("paper", "metrics"),
    priority: GATE_PRIORITY
    log:
        "results/logs/tables.log",
    script:
        "../scripts/tables.py"


def variant_fits(variant):
    """A rig variant's fits: the paper's PSO setting on the variant's pso_seeds, and LSM, per group."""
    seeds = config["rig"]["variants"][variant].get("pso_seeds") or PSO_SEEDS
    return [f"results/variants/{variant}/fits/{g}_pso_s{s}.json" for g in GROUPS for s in seeds] + [
        f"results/variants/{variant}/fits/{g}_lsm.json" for g in GROUPS
    ]


rule variant_tables:
    """Tables 1-3 of the fits on a rig variant's sweep (same rules, same box, fewer PSO seeds)."""
    input:
        fits=lambda w: variant_fits(w.variant),
    output:
        table1="results/variants/{variant}/tables/table1.csv",
        table2="results/variants/{variant}/tables/table2.csv",
        table3="results/variants/{variant}/tables/table3.csv",
        seed_spread="results/variants/{variant}/tables/seed_spread.csv",
    params:
        config=config_of("paper", "metrics"),
    log:
        "results/logs/variants/{variant}/tables.log",
    script:
        "../scripts/variant_tables.py"


VARIANT_TABLES = expand("results/variants/{variant}/tables/table2.csv", variant=RIG_VARIANTS)


rule plot_fig08:
    """Fig. 8: the loops (rig, synthetic) and the J-A loops of the median-J PSO and the LSM fit, per group."""
    input:
        nb="notebooks/fig08.ipynb",
        loops=expand("results/loops/{group}.csv", group=GROUPS),
        selected="results/tables/selected_fits.json",
        table2="results/tables/table2.csv",
        raw_json=[raw_json(g) for g in GROUPS],  # each group's provenance: the virtual rig's or measured
    output:
        nb="results/notebooks/fig08.ipynb",
        png=report("results/figures/fig08.png", caption="../report/fig08.rst", category="Figures of the paper"),
    params:
        nbparams=lambda w, input, output: nbparams(
            loops=",".join(input.loops), groups=",".join(GROUPS), selected=input.selected,
            table2=input.table2, raw_json=",".join(input.raw_json), out_png=output.png,
        ),
    log:
        "results/logs/fig08.log",
    shell:
        PAPERMILL


rule plot_fig09:
    """Fig. 9: J after each LSM iteration, per group."""
    input:
        nb="notebooks/fig09.ipynb",
        fits=expand("results/fits/{group}_lsm.json", group=GROUPS),
        table3="results/tables/table3.csv",
    output:
        nb="results/notebooks/fig09.ipynb",
        png=report("results/figures/fig09.png", caption="../report/fig09.rst", category="Figures of the paper"),
    params:
        nbparams=lambda w, input, output: nbparams(
            fits=",".join(input.fits), groups=",".join(GROUPS), table3=input.table3, out_png=output.png
        ),
    log:
        "results/logs/fig09.log",
    shell:
        PAPERMILL


rule plot_fig10:
    """Fig. 10: J after each PSO iteration, per group: every seed, the median-J seed, each setting."""
    input:
        nb="notebooks/fig10.ipynb",
        fits=[f for g in GROUPS for lab in PSO_LABELS for f in fits_of(g, lab)],
        selected="results/tables/selected_fits.json",
        table3="results/tables/table3.csv",
    output:
        nb="results/notebooks/fig10.ipynb",
        png=report("results/figures/fig10.png", caption="../report/fig10.rst", category="Figures of the paper"),
    params:
        nbparams=lambda w, input, output: nbparams(
            fits=",".join(input.fits), groups=",".join(GROUPS), selected=input.selected,
            table3=input.table3, out_png=output.png,
        ),
    log:
        "results/logs/fig10.log",
    shell:
        PAPERMILL


ALL_TARGETS += [
    "results/tables/table1.csv",
    "results/tables/table2.csv",
    "results/tables/table3.csv",
    "results/tables/seed_spread.csv",
    "results/tables/identifiability.csv",
    "results/tables/paper_check.json",
    *VARIANT_TABLES,
    "results/figures/fig08.png",
    "results/figures/fig09.png",
    "results/figures/fig10.png",
]
