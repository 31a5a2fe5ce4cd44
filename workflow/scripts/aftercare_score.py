# Snakemake script for rule aftercare_score: the only step that reads the key (mrhyst.blind.aftercare.score).
from mrhyst.blind import aftercare
from mrhyst.data.io import write_json
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = aftercare.aftercare_config(sm.params.config)
    s = aftercare.score(list(sm.input.diag), sm.input.key, float(cfg["size_tol"]))
    write_json(s, sm.output[0])
    print({"named_frac": s["named_frac"], **{c: v for c, v in s["per_change"].items()}})
