# Snakemake script for rule later_generate: the virtual rig's later sweeps of one channel, one change each
# (mrhyst.diagnose.later.generate; synthetic, the rig's provenance in each sidecar).
from pathlib import Path

from mrhyst.data.io import read_json
from mrhyst.diagnose import later
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = later.later_config(sm.params.config)
    nle = float(read_json(sm.input.nle)["n_over_le"])
    paths = later.generate(sm.params.config["rig"], cfg, nle, Path(sm.output.csv[0]).parent)
    print(f"{len(paths)} later sweeps of {cfg['sensor']} at N/Le = {nle:g} /m: " + ", ".join(p.name for p in paths))
