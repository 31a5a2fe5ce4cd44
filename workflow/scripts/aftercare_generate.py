# Snakemake script for rule aftercare_generate: virtual-rig sweeps of the Table 1 damper after one change each,
# and the key apart (mrhyst.blind.aftercare.generate).
from pathlib import Path

from mrhyst.blind import aftercare
from mrhyst.data.io import read_json
from mrhyst.diagnose.reference import load_reference
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = aftercare.aftercare_config(sm.params.config)
    ref = load_reference(cfg["reference"], sm.params.config["paper"])
    nle = float(read_json(sm.input.nle)["n_over_le"])
    key = aftercare.generate(cfg, ref.params, nle, Path(sm.output.key).parent / "cases", sm.output.key)
    print(f"{len(key['cases'])} cases against {cfg['reference']} at N/Le = {nle:g} /m")
