# Snakemake script for rule aftercare_diagnose: each case diagnosed in reference mode from its own files
# (mrhyst.blind.aftercare.diagnose_cases; the key is not an input of this rule).
from mrhyst.blind import aftercare
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = aftercare.aftercare_config(sm.params.config)
    aftercare.diagnose_cases(list(sm.input.csv), list(sm.output), cfg["reference"], sm.params.config)
