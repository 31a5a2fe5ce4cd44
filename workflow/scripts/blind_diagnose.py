# Snakemake script for rule blind_diagnose: one anonymous case, diagnosed like any lab's file. It receives
# the case's CSV (and its sidecar beside it) and nothing else: no key, no case list. A sweep the diagnosis
# refuses (one-line input error, e.g. a bipolar protocol it does not support yet) is recorded as
# "effect": "failed" with the message, so the benchmark counts it instead of stopping.
from mrhyst import blind, diagnose
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    try:
        d = diagnose.diagnose_file(
            snakemake.input.csv,  # noqa: F821
            sensor=blind.SENSOR,
            out=snakemake.output[0],  # noqa: F821
            config=snakemake.params.config["diagnose"],  # noqa: F821
        )
        print(d["verdict"])
    except io.InputError as e:
        io.write_json({"effect": blind.FAILED, "error": str(e), "ambiguous_with": [], "rms_before_T": None,
                       "rms_after_T": None, "noise_floor_T": None}, snakemake.output[0])  # noqa: F821
        print(f"failed: {e}")
