# Snakemake script for rule report_data: every number the report shows in one JSON (mrhyst.report.collect.collect).
from pathlib import Path

from mrhyst.data import io
from mrhyst.logs import to_log
from mrhyst.report import collect as report

with to_log(snakemake.log[0]):  # noqa: F821
    sm = snakemake  # noqa: F821
    inp, par = sm.input, sm.params
    data = report.collect(
        config=sm.config,
        config_path=inp.config,
        raw_paths=list(inp.raw),
        commit=par.commit,
        versions=dict(par.versions),
        nle=inp.nle,
        fig2_csv=inp.fig2,
        loops=dict(zip(par.groups, inp.loops)),
        tables={k: getattr(inp, k) for k in ("table1", "table2", "table3", "seed_spread", "identifiability",
                                             "paper_check", "selected")},
        forms=inp.forms,
        diagnosis={Path(p).stem: p for p in inp.diagnosis} if par.has_diagnosis else None,
        blind=inp.blind[0] if par.has_blind else None,
        blind_variants={Path(p).parent.name: p for p in inp.blind_variants} or None,
        external=inp.external[0] if par.has_external else None,
        external_models=inp.external_models[0] if par.has_external else None,
        external_diagnosis=list(inp.external_diag) or None,
        realcores=inp.realcores[0] if inp.realcores else None,
        aftercare=inp.aftercare[0] if len(inp.aftercare) else None,
        aftercare_diagnoses=list(inp.aftercare_diag) or None,
        gdlaws=tuple(inp.gdlaws) if len(inp.gdlaws) else None,
        later=None if not len(inp.later_ref) else {
            "calibration": inp.later_cal[0], "settings": inp.later_settings[0],
            "diagnoses": {c: (r, p, f) for c, r, p, f in zip(par.later_changes, inp.later_ref, inp.later_plain,
                                                                inp.later_figs)}},
        variants={v: {"tables": {k: str(Path(t).with_name(f"{k}.csv")) for k in ("table1", "table2", "table3",
                                                                                 "seed_spread")},
                      "loops": {g: f"results/variants/{v}/loops/{g}.csv" for g in par.groups}}
                  for v, t in zip(par.variants, inp.variant_tables)},
    )
    io.write_json(data, sm.output[0])
    print(f"commit {data['provenance']['commit']}, config sha256 {data['provenance']['config_sha256']}; sections: "
          + ", ".join(k for k, v in data.items() if v is not None))
