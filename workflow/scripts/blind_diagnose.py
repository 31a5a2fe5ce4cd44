# Snakemake script for rules blind_diagnose (a block of cases in one process) and blind_diagnose_rest (the leftovers):
# anonymous cases, each diagnosed like any lab's file (mrhyst.blind.diagnose_cases). A job receives its cases'
# CSVs (each sidecar beside its CSV) and nothing else: no key, no case list. A sweep the diagnosis refuses
# (one-line input error) is recorded as "effect": "failed" with the message, so the benchmark counts it.
from mrhyst import blind
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    csvs = snakemake.input.csv  # noqa: F821
    csvs = [csvs] if isinstance(csvs, str) else list(csvs)
    blind.diagnose_cases(csvs, list(snakemake.output), snakemake.params.config["diagnose"])  # noqa: F821
