# Snakemake script for rules fit_pso (every seed of one group and setting, in one process) and fit_lsm: the
# package computes (mrhyst.fit.identify), this only wires files. Output i is the fit with seed params.seeds[i]; the
# outputs after them are the fits' model curves (F.curve.csv, written by identify.fit_file beside F.json).
from mrhyst.fit import identify
from mrhyst.logs import to_log

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    settings = identify.resolve_config(sm.params.config)  # once: the config's sections over the schema's defaults
    for seed, out in zip(sm.params.seeds, sm.output[: len(sm.params.seeds)], strict=True):  # then the curves
        res = identify.fit_file(
            sm.input.loop,
            sm.params.method,
            seed=int(seed),
            out=out,
            n_over_le=None,  # H as the loop has it: the sweep's own coil (its sidecar's coil_turns_per_m) x I
            config=settings,
            group=sm.wildcards.group,
            setting=sm.params.setting,
        )
        print(f"{sm.wildcards.group} {sm.params.method} setting={res['setting']} seed={res['seed']}: "
              f"J = {res['rms_T']:.6g} T after {res['n_iterations']} iterations; params {res['params']}")
        for w in res["warnings"]:
            print("warning:", w)
