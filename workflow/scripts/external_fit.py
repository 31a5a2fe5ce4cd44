# Snakemake script for rule external_fit: every loop of one third-party B(H) file (mrhyst.materials.external).
from mrhyst.logs import to_log
from mrhyst.materials import external

with to_log(snakemake.log[0]):  # noqa: F821
    name = snakemake.wildcards.source  # noqa: F821
    res = external.fit_source(snakemake.input.csv, name, config=snakemake.params.config,  # noqa: F821
                              out=snakemake.output[0])  # noqa: F821
    for lp in res["loops"]:
        print(f"{name} loop {lp['loop_index']}: start {lp['start']}, {lp['method']}, RMS {lp['rms_T']:.4g} T "
              f"({100 * lp['rms_rel']:.3g} % of the B amplitude {lp['B_amplitude_T']:.4g} T), "
              f"{lp['substeps']} substeps")
    for e in (res.get("joint") or {}).get("per_loop", []):
        print(f"{name} joint fit, loop {e['loop_index']}: RMS {e['rms_T']:.4g} T ({100 * e['rms_rel']:.3g} % of peak), "
              f"{res['joint']['substeps']} substeps")
    for m, j in (res.get("joint_variants") or {}).items():
        for e in j["per_loop"]:
            print(f"{name} joint fit ({m}), loop {e['loop_index']}: RMS {e['rms_T']:.4g} T "
                  f"({100 * e['rms_rel']:.3g} % of peak), {j['substeps']} substeps")
