# Snakemake script for rule gdlaws_fit: the temperature laws on one amplitude's gadolinium loops, one temperature
# withheld (mrhyst.materials.gdlaws.split, mrhyst.materials.templaws.fit_file).
from mrhyst.logs import to_log
from mrhyst.materials import gdlaws, templaws

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    cfg = gdlaws.gdlaws_config(sm.params.config)
    seen, held = gdlaws.split(sm.input.loops, cfg)
    res = templaws.fit_file(sm.input.loops, loop_index=",".join(map(str, seen)),
                            config=gdlaws.fit_config(sm.params.config, cfg), out=sm.output[0])
    print(f"laws on loops {seen} (withheld {held} at {cfg['withheld_C']:g} C): per loop "
          + ", ".join(f"{p['temperature_C']:g} C {1e3 * p['rms_T']:.1f} mT" for p in res["per_loop"]))
