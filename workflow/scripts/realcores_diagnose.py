# Snakemake script for rule realcores_diagnose: a share of the real-core cases, each from its own files (no key).
from mrhyst.blind import realcores
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    csvs = [sm.input.csv] if isinstance(sm.input.csv, str) else list(sm.input.csv)
    realcores.diagnose_cases(csvs, list(sm.output), sm.params.config["diagnose"], material=sm.params.config)
