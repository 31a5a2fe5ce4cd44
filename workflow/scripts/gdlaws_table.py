# Snakemake script for rule gdlaws_table: ours (laws, per loop, the withheld diagnosis) beside the peer's figures
# (mrhyst.materials.gdlaws.table).
from mrhyst.data.io import write_csv
from mrhyst.logs import to_log
from mrhyst.materials import gdlaws

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = gdlaws.gdlaws_config(sm.params.config)
    t = gdlaws.table(sm.input.fit, sm.input.diag, sm.input.peer, float(cfg["withheld_C"]))
    write_csv(t, sm.output[0])
    print(t.to_string(index=False))
