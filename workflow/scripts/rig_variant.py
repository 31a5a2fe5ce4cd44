# Snakemake script for rule rig_variant: the rig's sweep with a variant's changes (mrhyst.rig.variant_config).
from mrhyst import rig
from mrhyst.data import io
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = rig.variant_config(sm.params.rig, sm.wildcards.variant)
    # the coil spec as in `python -m mrhyst.rig`: the inferred N/Le rounded to 0.001 turns/m
    nle = round(float(io.read_json(sm.input.nle)["n_over_le"]), 3)
    side = rig.generate_sweep(cfg, nle, int(cfg["seed"]), sm.output.csv)
    print(f"variant {sm.wildcards.variant}: truth form {cfg.get('form')}, N/Le {nle} /m, seed {cfg['seed']}")
