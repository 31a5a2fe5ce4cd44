# Snakemake script for rules fit_pso (every seed of one group and setting, in one process) and fit_lsm: the
# package computes (mrhyst.fit.identify), this only wires files. Output i is the fit with seed params.seeds[i].
from mrhyst.fit import identify
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    settings = identify.resolve_config(sm.params.config)  # once: the config's sections over the schema's defaults
    for seed, out in zip(sm.params.seeds, sm.output, strict=True):
        res = identify.fit_file(
            sm.input.loop,
            sm.params.method,
            seed=int(seed),
            out=out,
            n_over_le=sm.input.nle,
            config=settings,
            group=sm.wildcards.group,
            setting=sm.params.setting,
        )
        print(f"{sm.wildcards.group} {sm.params.method} setting={res['setting']} seed={res['seed']}: "
              f"J = {res['rms_T']:.6g} T after {res['n_iterations']} iterations; params {res['params']}")
        for w in res["warnings"]:
            print("warning:", w)
