# Fig. 2: the J-A loop of the paper's Simulation section; Fig. 6: the measured loops.


rule simulate_fig2:
    """One J-A loop for the Fig. 2 parameter set (mrhyst.model.ja), excitation chosen in config fig2."""
    input:
        nle="results/sim/n_over_le.json",
    output:
        "results/sim/fig2.csv",
    params:
        config=config_of("paper", "ja", "fig2"),
    priority: GATE_PRIORITY  # it starts a chain into the report (a figure): not left for the build's end
    log:
        "results/logs/simulate_fig2.log",
    script:
        "../scripts/simulate_fig2.py"


rule plot_fig02:
    input:
        nb="notebooks/fig02.ipynb",
        sim="results/sim/fig2.csv",
        nle="results/sim/n_over_le.json",
    output:
        nb="results/notebooks/fig02.ipynb",
        png=report("results/figures/fig02.png", caption="../report/fig02.rst", category="Figures of the paper"),
    params:
        nbparams=lambda w, input, output: nbparams(sim=input.sim, nle=input.nle, out_png=output.png),
    log:
        "results/logs/fig02.log",
    shell:
        PAPERMILL


rule plot_fig06:
    input:
        nb="notebooks/fig06.ipynb",
        loops=expand("results/loops/{group}.csv", group=GROUPS),
        raw_json=[raw_json(g) for g in GROUPS],  # each group's provenance
    output:
        nb="results/notebooks/fig06.ipynb",
        png=report("results/figures/fig06.png", caption="../report/fig06.rst", category="Figures of the paper"),
    params:
        nbparams=lambda w, input, output: nbparams(
            loops=",".join(input.loops), groups=",".join(GROUPS), raw_json=",".join(input.raw_json), out_png=output.png
        ),
    log:
        "results/logs/fig06.log",
    shell:
        PAPERMILL


ALL_TARGETS += ["results/figures/fig02.png", "results/figures/fig06.png", "results/sim/fig2.csv"]
