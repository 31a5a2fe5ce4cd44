# Snakemake script for rule later_diagnose: one later sweep against the calibration held (reference mode, with its
# figure) and as a new sweep (mrhyst.diagnose.later.diagnose_both).
from mrhyst.diagnose import later
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = later.later_config(sm.params.config)
    later.diagnose_both(sm.input.csv, sm.input.calibration, cfg["sensor"], sm.params.config, sm.output.ref,
                        sm.output.png, sm.output.plain)
