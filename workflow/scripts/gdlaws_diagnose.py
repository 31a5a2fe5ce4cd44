# Snakemake script for rule gdlaws_diagnose: the withheld loop (its temperature dropped) diagnosed against the laws
# in reference mode (mrhyst.diagnose.refdiag.reference_file, as `mrhyst diagnose BH.csv --reference FIT.json`).
from mrhyst.data.io import write_csv
from mrhyst.diagnose import refdiag
from mrhyst.logs import to_log
from mrhyst.materials import gdlaws

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    conf = sm.params.config
    cfg = gdlaws.gdlaws_config(conf)
    _, held = gdlaws.split(sm.input.loops, cfg)
    write_csv(gdlaws.withheld_loop(sm.input.loops, held, int(cfg["diagnose_samples"])), sm.output.loop)
    d = refdiag.reference_file(sm.output.loop, sm.input.fit, config=conf.get("diagnose"), paper=conf.get("paper"),
                               rcfg=refdiag.ref_config(conf), out=sm.output.diag)
    print(d["verdict"])
