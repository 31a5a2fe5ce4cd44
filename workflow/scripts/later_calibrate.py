# Snakemake script for rule later_calibrate: J-A calibrated on one loop of data/raw (`mrhyst fit LOOP --method lsm
# --form F`, F the diagnosis's form, so that the refit of a later sweep is comparable; the study's other settings;
# mrhyst.fit.identify.fit_file), the reference of the later sweeps (mrhyst.diagnose.later).
from mrhyst.diagnose import resolve_config
from mrhyst.fit import identify
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = dict(sm.params.config)
    form = resolve_config(cfg.pop("diagnose")).form
    res = identify.fit_file(sm.input.loop, method="lsm", form=form, out=sm.output[0], config=cfg)
    print(f"calibration: {res['form']} form, RMS {1e3 * res['rms_T']:.4g} mT; {sm.output[0]}")
