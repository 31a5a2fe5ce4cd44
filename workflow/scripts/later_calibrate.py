# Snakemake script for rule later_calibrate: J-A calibrated on the rig's first sweep (its later.sensor channel as
# `mrhyst convert` reads it, then `mrhyst fit LOOP --method lsm --form F`, F the diagnosis's form, so that the refit of
# a later sweep is comparable; the study's other settings; mrhyst.fit.identify.fit_file), the reference of the later
# sweeps (mrhyst.diagnose.later).
from mrhyst.data.io import raw_to_loop, read_raw, write_csv
from mrhyst.diagnose import resolve_config
from mrhyst.fit import identify
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    write_csv(raw_to_loop(read_raw(sm.input.csv), sm.params.sensor), sm.output.loop)
    cfg = dict(sm.params.config)
    form = resolve_config(cfg.pop("diagnose")).form
    res = identify.fit_file(sm.output.loop, method="lsm", form=form, out=sm.output.fit, config=cfg)
    print(f"calibration: {res['form']} form, RMS {1e3 * res['rms_T']:.4g} mT; {sm.output.fit}")
