# Snakemake script for rule profile: identifiability profile of the median-J fit (mrhyst.fit.identify.profile_file).
from mrhyst.fit import identify
from mrhyst.logs import to_log
from mrhyst.paper import tables as metrics

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    fit = metrics.median_fit(metrics.load_fits(sm.input.fits))
    print(f"profiling {fit['_path']} (J = {fit['rms_T']:.6g} T)")
    res = identify.profile_file(sm.input.loop, fit["_path"], out=sm.output[0], n_over_le=None,
                                config=sm.params.config, group=sm.wildcards.group)
    for name, p in res["params"].items():
        print(f"{name}: J <= {res['threshold']} J_min for [{p['range_lo']}, {p['range_hi']}], "
              f"curvature rel. s.e. {p['rel_se_curvature']}")
