# Raw sweeps -> loops (Hall chain), and the N/Le inference (not in the paper).


rule convert:
    """Hall voltage -> B for one group's sensor (mrhyst.hall via the `mrhyst convert` CLI)."""
    input:
        csv=lambda w: raw_csv(w.group),
        json=lambda w: raw_json(w.group),
    output:
        "results/loops/{group}.csv",
    params:
        sensor=lambda w: config["groups"][w.group]["sensor"],
    log:
        "results/logs/convert_{group}.log",
    shell:
        MRHYST + " convert {input.csv} --sensor {params.sensor} --out {output} > {log} 2>&1"


rule infer_nle:
    """N/Le per Table 1 set from the reported peak B (mrhyst.nle)."""
    output:
        "results/sim/n_over_le.json",
    params:
        config=config_of("paper", "ja", "nle"),
    log:
        "results/logs/infer_nle.log",
    script:
        "../scripts/infer_nle.py"


ALL_TARGETS += expand("results/loops/{group}.csv", group=GROUPS)
ALL_TARGETS += ["results/sim/n_over_le.json"]
