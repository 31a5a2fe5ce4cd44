# Snakemake script for rule report_forms: the package computes (mrhyst.report.collect.form_comparison);
# this only wires files.
from mrhyst.data import io
from mrhyst.logs import to_log
from mrhyst.report import collect as report

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    n_over_le = io.read_json(sm.input.nle)["n_over_le"]
    loops = dict(zip(sm.params.groups, sm.input.loops))
    res = report.form_comparison(sm.params.config, n_over_le, loops, io.read_json(sm.input.selected),
                                 lsm_max_iterations=int(sm.params.config["lsm"]["max_iterations"]))
    io.write_json(res, sm.output[0])
    for s, x in sorted(res["sets"].items()):
        print(f"{s}: max |B_paper - B_physical| = {x.get('max_abs_diff_T')} T")
    for r in res["fits"]:
        print(f"{r['group']} {r['method']} {r['setting']}: J {r['J_fitted_T']:.6g} ({r['form_fitted']}), "
              f"{r['J_same_params_other_form_T']:.6g} same params {r['form_other']}, "
              f"{r['J_refit_other_form_T']:.6g} refit {r['form_other']}")
